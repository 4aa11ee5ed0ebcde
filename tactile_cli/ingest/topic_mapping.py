"""The YAML topic mapping of ``tactile ingest REC --mapping topics.yaml``: which topics of a
ROS bag or MCAP file become which streams of the tactile store.

In the spirit of the CSV mapping (:mod:`tactile_cli.ingest.mapping`): one entry per topic,
each naming the stream, the sensor kind, channel names, units and a description, so a new
robot rig needs a YAML file rather than code. ``configs/rosbag_tactile_rig.yaml`` is a worked
example. In brief::

    version: 1
    time: header                 # header (stamp of the message header, else log time) | log
    trials:
      marker: {topic: /trial}    # optional: std_msgs/String "start"/"stop" or Bool true/false
      labels: {origin: recorded, dataset: my_rig, lab: my_lab}
    streams:
      - topic: /digit/image_raw  # sensor_msgs/Image or CompressedImage -> frames
        name: digit
        kind: visuotactile
        reference: first         # first | INDEX | /TOPIC (each trial's no-contact frame)
      - topic: /taxels           # std_msgs/*MultiArray -> samples, layout dims as channel names
        name: taxels
        kind: taxel_array
        units: kPa
      - topic: /ft               # WrenchStamped, Imu, JointState -> samples with their units
        name: wrench
        kind: force_torque
        serial: FT12345
        calibration: ft_calibration.yaml
      - topic: /custom           # any message by field paths
        name: custom
        kind: pressure
        fields: [wrench.force.x, taxels[*].z]
        units: N
      - topic: /dvs/events       # dvs_msgs/EventArray -> the trial's events, exact
        name: dvs
        kind: event_camera

Every model forbids unknown keys; :func:`load_topic_mapping` turns any problem into one
:class:`~tactile_cli.errors.InputError` naming the file, the line and the key. Checks that
need the recording (a topic it lacks, a field path its message type does not have) run
before anything is written.
"""

from __future__ import annotations

import re
from pathlib import Path
from typing import Literal

from pydantic import BaseModel, ConfigDict, Field, field_validator, model_validator

from ..config_file import describe_key_first, load_yaml_model
from ..errors import InputError
from ..store.spec import load_spec

#: Where a message's time comes from: its header stamp (log time for messages without a
#: header) or the time the recorder logged it.
TimeSource = Literal["header", "log"]

#: A field path: names separated by dots, each optionally followed by ``[INDEX]`` or ``[*]``
#: (every element of an array), e.g. ``wrench.force.x`` or ``taxels[*].z``.
FIELD_PATH = re.compile(r"^[A-Za-z_]\w*(\[(\d+|\*)\])*(\.[A-Za-z_]\w*(\[(\d+|\*)\])*)*$")


class _Model(BaseModel):
    model_config = ConfigDict(extra="forbid", use_attribute_docstrings=True, frozen=True)


class Marker(_Model):
    """A topic whose messages open and close trials (``std_msgs/String`` or ``Bool``)."""

    topic: str
    """The marker topic. A ``std_msgs/Bool`` opens a trial with true and closes it with false;
    a ``std_msgs/String`` opens with ``start`` and closes with ``stop`` (the values below)."""
    start: str = "start"
    """The String value that opens a trial; ``start:NAME`` also opens one and names it."""
    stop: str = "stop"
    """The String value that closes the open trial."""


class Trials(_Model):
    """How the recording is cut into trials, and the labels every trial gets."""

    marker: Marker | None = None
    """Cut the recording at the messages of a marker topic; default one trial per
    recording (``--trials-from FILE.csv`` cuts by time ranges instead)."""
    labels: dict[str, str | int | float] = Field(default_factory=dict)
    """Constant labels of every trial, e.g. ``{origin: recorded, dataset: my_rig}``."""


class TopicStream(_Model):
    """One topic of the recording made into one stream of every trial."""

    topic: str
    """The topic name as recorded (``/digit/image_raw``)."""
    name: str
    """Stream name (``/trials/<trial>/signals/<name>``) and sensor name."""
    kind: str
    """Sensor kind, one of the schema's ``sensor_kind`` values. ``visuotactile`` makes the
    trial's frames (Image, CompressedImage), ``event_camera`` its events (dvs_msgs/EventArray);
    any other kind a sampled stream."""
    description: str = ""
    """Free text stored with the sensor."""
    fields: list[str] | None = None
    """Field paths read from each message, in channel order (``wrench.force.x``,
    ``taxels[*].z``: ``[*]`` takes every element); default the message type's own layout
    (MultiArray data, Wrench, Imu, JointState, a fixed-size array field)."""
    channels: list[str] | None = None
    """Output channel names, one per value read; default from the message (MultiArray
    layout dimensions, JointState names, the field paths)."""
    units: str | list[str] | None = None
    """One unit for every channel or one per channel; default the message type's units
    (N and N m for a wrench, rad/s and m/s^2 for an Imu) or none."""
    time: TimeSource | None = None
    """This stream's time source (default the mapping's ``time``)."""
    reference: str | int = "first"
    """Frames only: the no-contact reference frame of each trial: ``first`` or the frame's
    index in the trial (0-based; in stamp order when ``sort_stamps`` sorts them), which
    stays a frame of the sequence; or an image topic (``/digit/reference``, starting with
    ``/``) whose latest message logged before the trial's first frame is the reference (its
    first message when none comes that early: a reference published once, just after the
    camera started). Why that rule: a no-contact image must be taken before the press, and
    the latest one is the gel and lighting closest to the trial's frames; a rig that
    publishes one reference per recording, or one before each press, both get the right one."""
    serial: str | None = None
    """The sensor's serial number, kept as the sensor attribute ``serial``."""
    calibration: Path | None = None
    """A calibration file of the sensor (relative to the mapping file), kept as a source and
    as sensor attributes ``calibration_file``, ``calibration_sha256`` and, for a text file of
    at most 64 KiB, ``calibration_text``."""
    width_px: int | None = None
    """Event cameras only: the sensor width in px (default the EventArray's ``width``)."""
    height_px: int | None = None
    """Event cameras only: the sensor height in px (default the EventArray's ``height``)."""

    @field_validator("kind")
    @classmethod
    def _known_kind(cls, value: str) -> str:
        kinds = load_spec().enums["sensor_kind"]
        if value not in kinds:
            raise ValueError(f"unknown sensor kind {value!r}; use one of: {', '.join(kinds)}")
        return value

    @field_validator("fields")
    @classmethod
    def _paths(cls, value: list[str] | None) -> list[str] | None:
        for path in value or []:
            if not FIELD_PATH.match(path):
                raise ValueError(f"{path!r} is not a field path (names joined by dots, each "
                                 "with optional [INDEX] or [*], e.g. taxels[*].z)")
        if value is not None and not value:
            raise ValueError("list at least one field path, or leave `fields` out")
        return value

    @field_validator("reference")
    @classmethod
    def _reference(cls, value: str | int) -> str | int:
        if isinstance(value, str):
            if value.isdigit():
                return int(value)
            if value != "first" and not value.startswith("/"):
                raise ValueError(f"{value!r} is neither `first`, a frame index nor a topic "
                                 "(a topic starts with /)")
        elif value < 0:
            raise ValueError(f"frame index {value} must be 0 or more")
        return value

    @model_validator(mode="after")
    def _consistent(self) -> TopicStream:
        if self.kind in ("visuotactile", "event_camera") and self.fields is not None:
            raise ValueError(f"`fields` reads values into samples; a {self.kind} stream takes "
                             "the whole image or event array (leave `fields` out)")
        if self.reference_topic is not None and not self.is_frames:
            raise ValueError("`reference` names a reference frame; only a visuotactile stream "
                             "takes one")
        if self.reference_topic == self.topic:
            raise ValueError(f"`reference` is the stream's own topic {self.topic}; give the "
                             "frame's index instead (`reference: 0`)")
        if self.channels is not None and len(set(self.channels)) != len(self.channels):
            raise ValueError("`channels` has duplicates")
        return self

    @property
    def reference_topic(self) -> str | None:
        """The topic the reference frame comes from, or None (``first`` or an index)."""
        ref = self.reference
        return ref if isinstance(ref, str) and ref.startswith("/") else None

    @property
    def is_frames(self) -> bool:
        return self.kind == "visuotactile"

    @property
    def is_events(self) -> bool:
        return self.kind == "event_camera"


class TopicMapping(_Model):
    """A whole topic mapping (see the module docstring)."""

    version: Literal[1] = 1
    """The mapping format version."""
    time: TimeSource = "header"
    """Default time source of every stream: ``header`` (the message header's stamp, log time
    for messages without one) or ``log`` (when the recorder received the message)."""
    trials: Trials = Field(default_factory=Trials)
    """How the recording is cut into trials."""
    streams: list[TopicStream] = Field(min_length=1)
    """One entry per topic to ingest; topics not listed are named as left out."""

    @model_validator(mode="after")
    def _unique(self) -> TopicMapping:
        for what, values in (("topic", [s.topic for s in self.streams]),
                             ("name", [s.name for s in self.streams])):
            seen = {v for v in values if values.count(v) > 1}
            if seen:
                raise ValueError(f"stream {what} {sorted(seen)[0]!r} is listed twice")
        for kind in ("visuotactile", "event_camera"):
            if sum(s.kind == kind for s in self.streams) > 1:
                raise ValueError(f"a trial holds one {kind} stream; map one {kind} topic per "
                                 "ingest (ingest the others into a second file)")
        return self


def load_topic_mapping(path: str | Path) -> TopicMapping:
    """Read and validate a topic mapping; every problem is one InputError naming the file,
    the line and the key."""
    mapping = load_yaml_model(path, TopicMapping, not_a_mapping="a topic mapping is a YAML "
                              "mapping with `streams:` (see configs/rosbag_tactile_rig.yaml)",
                              empty="the topic mapping is empty; list `streams:`",
                              what="topic mapping", describe=describe_key_first)
    path = Path(path)
    streams = []
    for k, stream in enumerate(mapping.streams):
        if stream.calibration is not None:
            cal = stream.calibration if stream.calibration.is_absolute() else (
                path.parent / stream.calibration)
            if not cal.is_file():
                raise InputError(f"`streams.{k}.calibration`: {cal} does not exist (a path "
                                 "relative to the mapping file)", path=path)
            stream = stream.model_copy(update={"calibration": cal})
        streams.append(stream)
    return mapping.model_copy(update={"streams": streams})


__all__ = ["FIELD_PATH", "Marker", "TimeSource", "TopicMapping", "TopicStream", "Trials",
           "load_topic_mapping"]
