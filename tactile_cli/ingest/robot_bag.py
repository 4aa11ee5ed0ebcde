"""Robot recordings into the tactile store: ROS 1 bags (``.bag``), ROS 2 bag folders (sqlite3
or mcap storage) and standalone MCAP files (``.mcap``), mapped topic by topic.

Two formats on the ingest contract, sharing everything but the container reader (see
:mod:`tactile_cli.ingest.robot_recording` for why ``rosbags`` reads the bags and ``mcap``
the MCAP files):

- ``rosbag``: a ``.bag`` file or a folder with ``metadata.yaml``;
- ``mcap``: a ``.mcap`` file.

``tactile info REC`` lists every topic (message type, count, rate as 1 / the median interval
between log times, jitter, time span, bytes), read-only. ``tactile ingest REC --mapping
topics.yaml`` makes the topics the mapping names into streams of each trial (the mapping:
:mod:`tactile_cli.ingest.topic_mapping`; messages into arrays:
:mod:`tactile_cli.ingest.robot_messages`; trials: :mod:`tactile_cli.ingest.robot_trials`):

- **frames** (kind ``visuotactile``): ``sensor_msgs/Image`` (8-bit encodings) and
  ``CompressedImage`` (JPEG, PNG) as (height, width, 3) uint8 RGB, streamed to the file in
  small batches; each trial's reference is its first frame, the frame at ``reference``
  (which stays a frame of the sequence) or, when ``reference`` names an image topic, that
  topic's latest message logged before the trial's first frame (its first message when
  none comes that early; see :class:`~tactile_cli.ingest.topic_mapping.TopicStream`);
- **events** (kind ``event_camera``): ``dvs_msgs/EventArray``, every event as recorded (time
  to the microsecond of the schema; a note says when a stamp had finer digits);
- **samples** (any other kind): one row per message, the sensor's channels from the message
  type or the mapping's ``fields``; a stream keeps its own stamps (no resampling).

Time: each stream takes its messages' header stamps (``time: header``, the default; log time
for a message type without a header, or when every header stamp is 0) or their log times
(``time: log``). Sampled streams are written in blocks of
:data:`~tactile_cli.store.writer.SIGNAL_CHUNK_BYTES` of values as they come, so memory does
not grow with a trial's length (a trial within one block is written in one piece). Stamps
that go back are refused with their count unless ``sort_stamps``: samples are then sorted
(stable) per trial, once the trial is written (reading its values back); frames, which are
streamed to the file, are sorted (stable) within a window of half a frame batch
(:data:`FRAME_BATCH_BYTES`; about 18 frames of 320x240 RGB), and a frame going back further
than that is one error. Every
stream's rate, jitter and gaps (intervals over twice the median) are returned as a note and
kept as sensor attributes (``rate_hz`` in ``sample_rate_hz``, ``jitter_s``, ``gaps``,
``longest_gap_s``), beside the identity the recording and the mapping give: ``topic``,
``message_type``, ``frame_id`` (from the first header), ``serial`` and a named calibration
file (``calibration_file``, ``calibration_sha256``, ``calibration_text``), which is also
a source of the file. Topics the mapping does not take are named in a note and in each
trial's attribute ``topics_left_out``; nothing is dropped silently.
"""

from __future__ import annotations

import bisect
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import InputError
from ..progress import Progress
from ..store.provenance import sha256_of
from ..store.writer import SIGNAL_CHUNK_BYTES, StoreWriter
from .contract import FormatOptions, IngestFormat, RecordingSummary, StreamSummary, TrialSummary
from .robot_layouts import raw_rows
from .robot_messages import (
    check_path,
    compressed_rgb,
    event_columns,
    frame_id,
    header_stamp_ns,
    image_rgb,
    row_reader,
)
from .robot_recording import (
    BAG_SUFFIX,
    MCAP_SUFFIX,
    RobotRecording,
    is_ros2_folder,
    recording_kind,
    short_type,
)
from .robot_trials import (
    OPEN_END_NS,
    TrialSpan,
    csv_trials,
    marker_trials,
    recording_name,
    whole_recording,
)
from .stamps import interval_jitter_s, stamp_stats
from .topic_mapping import TopicMapping, TopicStream, load_topic_mapping

#: Frames held before one write (bytes of decoded RGB).
FRAME_BATCH_BYTES = 8 << 20
#: An interval longer than this many median intervals is a gap.
GAP_FACTOR = 2.0
#: Calibration text kept as an attribute up to this size.
CALIBRATION_TEXT_BYTES = 64 << 10


class RobotOptions(FormatOptions):
    """Options of the robot-recording formats (ROS bags, MCAP)."""

    mapping: Path | None = None
    """YAML topic mapping: which topics become which streams (see
    configs/rosbag_tactile_rig.yaml); required to ingest, optional for `tactile info`."""
    trials_from: Path | None = None
    """CSV of trial time ranges (start_s,end_s[,trial,labels...], seconds from the
    recording's first message), instead of one trial per recording or a marker topic."""
    sort_stamps: bool = False
    """Sort the samples and frames of a stream whose stamps go back, stable by stamp
    (default: refuse, with their count)."""


# -- timing ------------------------------------------------------------------------------
@dataclass(frozen=True)
class Timing:
    """Rate (1 / median positive interval, Hz), jitter (s), gaps and the longest interval."""

    rate_hz: float | None
    jitter_s: float | None
    gaps: int
    longest_gap_s: float | None


def timing(stamps_s: Sequence[np.ndarray]) -> Timing:
    """The timing of the stamps of one stream, over every trial (intervals within trials)."""
    steps = np.concatenate([np.diff(t) for t in stamps_s]) if stamps_s else np.zeros(0)
    positive = steps[steps > 0]
    if not len(positive):
        return Timing(None, interval_jitter_s(steps), 0, None)
    median = float(np.median(positive))
    gap = steps > GAP_FACTOR * median
    return Timing(float(1.0 / median), interval_jitter_s(steps), int(gap.sum()),
                  float(steps[gap].max()) if gap.any() else None)


# -- planning ----------------------------------------------------------------------------
def check_topics(rec: RobotRecording, mapping: TopicMapping, mapping_path: Path) -> None:
    """Every mapped topic exists, its type is defined and fits the stream's kind."""
    for stream in mapping.streams:
        if stream.topic not in rec.topics:
            raise InputError(f"the mapping names topic {stream.topic}, which the recording "
                             f"{rec.path} lacks; its topics: {', '.join(rec.topics) or 'none'}",
                             path=mapping_path)
        info = rec.topics[stream.topic]
        rec.decoder(stream.topic)  # a type with no definition is an error here
        kind = short_type(info.msgtype)
        if stream.is_frames and kind not in ("sensor_msgs/Image", "sensor_msgs/CompressedImage"):
            raise InputError(f"stream {stream.name}: topic {stream.topic} holds {kind}, not "
                             "images; kind visuotactile takes sensor_msgs/Image or "
                             "CompressedImage (give another kind for samples)", path=mapping_path)
        if stream.is_events and kind != "dvs_msgs/EventArray":
            raise InputError(f"stream {stream.name}: topic {stream.topic} holds {kind}; kind "
                             "event_camera takes dvs_msgs/EventArray", path=mapping_path)
        if not (stream.is_frames or stream.is_events) and kind == "sensor_msgs/CompressedImage":
            raise InputError(f"stream {stream.name}: topic {stream.topic} holds compressed "
                             "images; map it with kind visuotactile (frames)", path=mapping_path)
        ref = stream.reference_topic
        if ref is not None:
            _check_reference_topic(rec, stream, ref, mapping_path)
        if stream.fields is not None:
            for path in stream.fields:
                check_path(rec, info.msgtype, path, stream.topic)


def _check_reference_topic(rec: RobotRecording, stream: TopicStream, ref: str,
                           mapping_path: Path) -> None:
    """The topic a frames stream takes its reference from exists, holds images, has a
    message and a definition."""
    if ref not in rec.topics:
        raise InputError(f"stream {stream.name}: the reference topic {ref} is not in the "
                         f"recording {rec.path}; its topics: {', '.join(rec.topics)}",
                         path=mapping_path)
    kind = short_type(rec.topics[ref].msgtype)
    if kind not in ("sensor_msgs/Image", "sensor_msgs/CompressedImage"):
        raise InputError(f"stream {stream.name}: the reference topic {ref} holds {kind}, not "
                         "images (sensor_msgs/Image or CompressedImage)", path=mapping_path)
    if rec.topics[ref].count == 0:
        raise InputError(f"stream {stream.name}: the reference topic {ref} has no messages; "
                         "give `reference: first` or a frame index", path=mapping_path)
    rec.decoder(ref)


def trial_spans(rec: RobotRecording, mapping: TopicMapping | None, options: RobotOptions,
                start_ns: int) -> tuple[list[TrialSpan], list[str]]:
    """The recording's trials (see :mod:`tactile_cli.ingest.robot_trials`) and notes."""
    marker = mapping.trials.marker if mapping is not None else None
    if options.trials_from is not None and marker is not None:
        raise InputError("the mapping cuts trials by `trials.marker` and `trials_from` gives "
                         "time ranges; use one of them", path=options.mapping)
    if options.trials_from is not None:
        return csv_trials(options.trials_from, rec, start_ns), []
    if marker is not None:
        return marker_trials(rec, marker, start_ns)
    return whole_recording(rec, start_ns), []


def first_log_ns(rec: RobotRecording) -> int:
    """Log time of the recording's first message (ns), 0 for an empty recording."""
    for _, t_ns, _ in rec.raw_messages():
        return t_ns
    return 0


# -- reading -------------------------------------------------------------------------------
@dataclass
class _Trial:
    span: TrialSpan
    writer: Any = None  # TrialWriter, made when the trial is opened


@dataclass
class _Rows:
    """A sampled stream's rows of one trial not yet written (at most one block of
    :data:`~tactile_cli.store.writer.SIGNAL_CHUNK_BYTES` of values), and the appender that
    takes each full block; a trial that ends within its first block is written in one
    piece."""

    values: list[Any] = field(default_factory=list)  # rows, or the messages' bytes
    t_ns: list[int] = field(default_factory=list)
    index: list[int] = field(default_factory=list)  # of the bytes' messages in the topic
    appender: Any = None  # SignalAppender, made when the first block is full


@dataclass
class _Stream:
    """What one mapped topic has gathered so far."""

    spec: TopicStream
    msgtype: str
    decode: Any
    use_header: bool | None = None  # decided on the first message
    rows: Any = None  # RowReader of sampled streams
    frame_id: str | None = None
    n: int = 0
    outside: int = 0
    late: int = 0
    stamps: dict[int, list[int]] = field(default_factory=dict)  # trial -> frame/event stamps
    rows_of: dict[int, _Rows] = field(default_factory=dict)  # trial -> sampled rows
    block_rows: int = 0  # rows per block of a sampled stream (from its channel count)
    frames: dict[int, Any] = field(default_factory=dict)  # trial -> FrameAppender or buffer
    events: dict[int, Any] = field(default_factory=dict)  # trial -> EventAppender
    size_hw: tuple[int, int] | None = None
    width_px: int | None = None
    height_px: int | None = None
    sub_us_events: int = 0
    sensor: str | None = None
    timing_all: list[np.ndarray] = field(default_factory=list)
    newest: int = -1  # the latest trial a message went to
    # reference topic of a frames stream: its first message and the latest one read so far,
    # as (index in the topic, raw bytes), in the recording being read
    ref_first: tuple[int, bytes] | None = None
    ref_latest: tuple[int, bytes] | None = None
    ref_seen: int = 0
    fast: Any = None  # RawRows: rows read from the bytes (robot_layouts)
    fast_checked: bool = False  # whether the first message of this recording decided it


def ingest_robot(inputs: Sequence[Path], options: RobotOptions, writer: StoreWriter,
                 progress: Progress) -> list[str]:
    """Add the trials of every input recording to ``writer`` (module docstring); returns
    the notes: per stream timing, topics left out, stamps that needed care."""
    if options.mapping is None:
        raise InputError("a robot recording needs a topic mapping to be ingested: pass "
                         "`mapping='topics.yaml'` (which topics become which streams; see "
                         "configs/rosbag_tactile_rig.yaml); `tactile info` lists the topics",
                         path=inputs[0])
    mapping = load_topic_mapping(options.mapping)
    writer.add_source(options.mapping)
    if options.trials_from is not None:
        writer.add_source(options.trials_from)
    streams: dict[str, _Stream] = {}
    notes: list[str] = []
    for path in inputs:
        notes += _ingest_one(path, mapping, options, writer, progress, streams)
    for st in streams.values():
        notes.append(_finish_sensor(st, mapping, options, writer))
    return notes


def _sources(writer: StoreWriter, path: Path) -> list[int]:
    if path.is_dir():
        return [writer.add_source(p) for p in sorted(path.iterdir()) if p.is_file()]
    return [writer.add_source(path)]


def _ingest_one(path: Path, mapping: TopicMapping, options: RobotOptions, writer: StoreWriter,
                progress: Progress, streams: dict[str, _Stream]) -> list[str]:
    notes: list[str] = []
    assert options.mapping is not None
    with RobotRecording(path) as rec:
        check_topics(rec, mapping, options.mapping)
        start_ns = first_log_ns(rec)
        spans, trial_notes = trial_spans(rec, mapping, options, start_ns)
        notes += trial_notes
        sources = _sources(writer, path)
        marker = mapping.trials.marker.topic if mapping.trials.marker else None
        refs: dict[str, list[_Stream]] = {}  # reference topic -> frames streams taking it
        left_out = [t for t in rec.topics
                    if t not in {s.topic for s in mapping.streams} and t != marker
                    and t not in {s.reference_topic for s in mapping.streams}]
        left_text = "; ".join(f"{t} ({short_type(rec.topics[t].msgtype)}, "
                              f"{rec.topics[t].count} messages)" for t in left_out)
        trials = []
        for span in spans:
            tw = writer.trial(span.name, labels={**mapping.trials.labels, **span.labels},
                              sources=sources, time_origin_unix_s=span.start_ns / 1e9,
                              recording=str(path), topics_left_out=left_text or "none")
            trials.append(_Trial(span, tw))
        if left_out:
            notes.append(f"{recording_name(path)}: topics not in the mapping, left out: "
                         f"{left_text}")
        starts = [s.start_ns for s in spans]  # increasing; bisect per message (numpy's
        # searchsorted costs ~20 us a call on one Python int, bisect well under 1 us)
        by_topic: dict[str, _Stream] = {}
        for spec in mapping.streams:
            st = streams.get(spec.name)
            if st is None:
                st = streams[spec.name] = _Stream(spec, rec.topics[spec.topic].msgtype,
                                                  rec.decoder(spec.topic))
            else:  # the next recording of a multi-recording ingest
                st.decode, st.newest = rec.decoder(spec.topic), -1
                st.fast, st.fast_checked = None, False  # checked again on this recording
            by_topic[spec.topic] = st
            st.ref_first = st.ref_latest = None
            st.ref_seen = 0
            if spec.reference_topic is not None:
                refs.setdefault(spec.reference_topic, []).append(st)
                for _, _, raw in rec.raw_messages({spec.reference_topic}):
                    st.ref_first = (0, raw)  # taken when no message precedes a trial
                    break
        progress.start(sum(rec.topics[s.topic].count for s in mapping.streams), "messages")
        for topic, log_ns, raw in rec.raw_messages(set(by_topic) | set(refs)):
            for taker in refs.get(topic, ()):
                taker.ref_latest = (taker.ref_seen, raw)
                taker.ref_seen += 1
            st = by_topic.get(topic)
            if st is None:
                continue
            fast = st.fast
            if fast is not None:  # a standard layout, its rows read from the bytes per block
                t_ns = fast.stamp(raw, st.n) if st.use_header else log_ns
                placed = _place(st, t_ns, rec, trials, starts, writer, options)
                if placed is not None:
                    _append_row(st, raw, t_ns, placed, rec, trials)
            else:
                _take(st, st.decode(raw), raw, log_ns, mapping, rec, trials, starts, writer,
                      options)
            progress.advance(1)
        progress.finish()
        for st in by_topic.values():
            for k in sorted(set(st.stamps) | set(st.rows_of) | set(st.frames)
                            | set(st.events)):
                _flush(st, k, trials, rec, writer, options)
            if st.outside:
                notes.append(f"{st.spec.name} ({st.spec.topic}): {st.outside} message(s) "
                             "outside every trial, left out")
            st.outside = 0
            if st.n == 0:
                notes.append(f"{st.spec.name} ({st.spec.topic}): no messages in {path}")
    return notes


def _stamp(st: _Stream, msg: Any, log_ns: int, mapping: TopicMapping) -> int:
    if st.use_header is False:  # decided on the first message: the log time
        return log_ns
    header = header_stamp_ns(msg)
    if st.use_header is None:
        wanted = (st.spec.time or mapping.time) == "header"
        st.use_header = wanted and header is not None and header != 0
        st.frame_id = frame_id(msg)
    return header if st.use_header and header is not None else log_ns


def _place(st: _Stream, t_ns: int, rec: RobotRecording, trials: list[_Trial],
           starts: list[int], writer: StoreWriter, options: RobotOptions
           ) -> tuple[int, int] | None:
    """(trial, index in the stream) of a message stamped ``t_ns``, or None (counted) when it
    falls outside every trial; trials before the one before it are written out."""
    if trials[0].span.takes_all:
        k = 0
    else:
        k = bisect.bisect_right(starts, t_ns) - 1
        if k < 0 or t_ns >= trials[k].span.end_ns:
            st.outside += 1
            return None
    index = st.n
    st.n += 1
    if k > st.newest:  # trials before the one before this message's are complete
        st.newest = k
        for done in [j for j in (set(st.stamps) | set(st.rows_of) | set(st.frames)
                                 | set(st.events)) if j < k - 1]:
            _flush(st, done, trials, rec, writer, options)
    return k, index


def _take(st: _Stream, msg: Any, raw: bytes, log_ns: int, mapping: TopicMapping,
          rec: RobotRecording, trials: list[_Trial], starts: list[int], writer: StoreWriter,
          options: RobotOptions) -> None:
    t_ns = _stamp(st, msg, log_ns, mapping)
    placed = _place(st, t_ns, rec, trials, starts, writer, options)
    if placed is None:
        return
    k, index = placed
    spec = st.spec
    kind = spec.kind
    if kind == "visuotactile":  # spec.is_frames, without a property call per message
        _take_frame(st, msg, t_ns, k, index, rec, trials, options)
    elif kind == "event_camera":  # spec.is_events
        _take_events(st, msg, k, rec, trials, writer)
    else:
        if st.rows is None:
            st.rows = row_reader(rec, spec.topic, st.msgtype, msg, spec.fields)
            _check_names(st, rec)
            st.block_rows = max(1, SIGNAL_CHUNK_BYTES // (4 * max(1, len(st.rows.channels))))
        if not st.fast_checked:
            st.fast, st.fast_checked = _raw_reader(st, rec, raw, msg), True
        # with a raw reader, this message's bytes (they gave the same row) like the later ones'
        _append_row(st, raw if st.fast is not None else st.rows.read(msg), t_ns, placed, rec,
                    trials)


def _raw_reader(st: _Stream, rec: RobotRecording, raw: bytes, msg: Any) -> Any:
    """The stream's reader of rows straight from the bytes (:mod:`.robot_layouts`), used for
    every message of this recording when the mapping takes the type's default values, the
    recording defines the type as the standard one, and this first message gives the same
    stamp and row both ways; else None, and the deserialiser reads every message."""
    if st.spec.fields is not None or not rec.is_standard(st.msgtype):
        return None
    layout = getattr(msg, "layout", None)
    offset = int(layout.data_offset) if layout is not None else 0
    fast = raw_rows(rec.serialisation, st.msgtype, offset, st.spec.topic, rec.path)
    if fast is None:
        return None
    try:
        stamp, row = fast.stamp(raw, 0), fast.row(raw, 0)
    except InputError:
        return None
    want = st.rows.read(msg)
    if (stamp != header_stamp_ns(msg) or row.dtype != want.dtype
            or not np.array_equal(row, want, equal_nan=True)):
        return None
    return fast


def _append_row(st: _Stream, row: Any, t_ns: int, placed: tuple[int, int],
                rec: RobotRecording, trials: list[_Trial]) -> None:
    """Add one sampled row (or, with a raw reader, the message's bytes, read when the block
    is written) to its trial's block, writing the block when it is full."""
    k, index = placed
    if not isinstance(row, np.ndarray):
        rows = st.rows_of.get(k)
        if rows is None:
            rows = st.rows_of[k] = _Rows()
        rows.values.append(row)
        rows.t_ns.append(t_ns)
        rows.index.append(index)
        if len(rows.t_ns) >= st.block_rows:
            _spill(st, rows, trials[k])
        return
    if len(row) != len(st.rows.channels):
        raise InputError(f"topic {st.spec.topic}, message {index}: {len(row)} values, but the "
                         f"first message gave {len(st.rows.channels)}; a stream keeps one "
                         "channel count", path=rec.path)
    rows = st.rows_of.get(k)
    if rows is None:
        rows = st.rows_of[k] = _Rows()
    rows.values.append(row)
    rows.t_ns.append(t_ns)
    if len(rows.t_ns) >= st.block_rows:
        _spill(st, rows, trials[k])


def _spill(st: _Stream, rows: _Rows, trial: _Trial) -> None:
    """Write the rows gathered for ``trial`` to its stream and forget them."""
    if not rows.t_ns:
        return
    if rows.appender is None:
        rows.appender = trial.writer.signal(st.spec.name, sensor=st.spec.name,
                                            n_channels=len(st.rows.channels))
    t_s = (np.asarray(rows.t_ns, dtype=np.int64) - trial.span.start_ns) / 1e9
    rows.appender.append(_block(st, rows), t_s)
    rows.values, rows.t_ns, rows.index = [], [], []


def _block(st: _Stream, rows: _Rows) -> np.ndarray:
    """(n_rows, n_channels) values of a block: rows as they are, or read from the messages'
    bytes by the stream's raw reader."""
    if rows.values and not isinstance(rows.values[0], np.ndarray):
        return st.fast.rows(rows.values, rows.index, len(st.rows.channels))
    return np.vstack(rows.values)


def _check_names(st: _Stream, rec: RobotRecording) -> None:
    spec, rows = st.spec, st.rows
    n = len(rows.channels)
    if spec.channels is not None:
        if len(spec.channels) != n:
            raise InputError(f"stream {spec.name}: `channels` lists {len(spec.channels)} names "
                             f"but topic {spec.topic} gives {n} values per message",
                             path=rec.path)
        rows.channels = list(spec.channels)
    if isinstance(spec.units, list):
        if len(spec.units) != n:
            raise InputError(f"stream {spec.name}: `units` lists {len(spec.units)} units but "
                             f"topic {spec.topic} gives {n} values per message", path=rec.path)
        rows.units = list(spec.units)
    elif isinstance(spec.units, str):
        rows.units = [spec.units] * n


def _take_frame(st: _Stream, msg: Any, t_ns: int, k: int, index: int, rec: RobotRecording,
                trials: list[_Trial], options: RobotOptions) -> None:
    if short_type(st.msgtype) == "sensor_msgs/CompressedImage":
        rgb = compressed_rgb(msg, st.spec.topic, index, rec)
    else:
        rgb = image_rgb(msg, st.spec.topic, index, rec)
    if st.size_hw is None:
        st.size_hw = (rgb.shape[0], rgb.shape[1])
    elif rgb.shape[:2] != st.size_hw:
        raise InputError(f"topic {st.spec.topic}, message {index}: a {rgb.shape[1]}x"
                         f"{rgb.shape[0]} px frame after {st.size_hw[1]}x{st.size_hw[0]} px "
                         "ones; a stream keeps one frame size", path=rec.path)
    state = st.frames.get(k)
    if state is None:  # the trial's first frame: its reference message is the latest one now
        state = st.frames[k] = {"pending": [], "times": [], "appender": None, "count": 0,
                                "last": None, "back": 0, "written": None,
                                "ref": st.ref_latest or st.ref_first}
    t_s = (t_ns - trials[k].span.start_ns) / 1e9
    went_back = state["last"] is not None and t_s < state["last"]
    state["last"] = t_s
    st.stamps.setdefault(k, []).append(t_ns)
    if went_back:
        state["back"] += 1
    if state["back"] and not options.sort_stamps:
        return  # counted; the trial fails with the count when it is flushed
    state["pending"].append(rgb)
    state["times"].append(t_s)
    state["count"] += 1
    ref = st.spec.reference
    ready = isinstance(ref, str) or state["count"] > (0 if ref == "first" else int(ref))
    if ready and len(state["pending"]) * rgb.nbytes >= FRAME_BATCH_BYTES:
        _write_frames(st, state, trials[k], rec, options, final=False)


def _topic_reference(st: _Stream, state: dict[str, Any], rec: RobotRecording) -> np.ndarray:
    """The (height, width, 3) uint8 reference frame a trial takes from the reference topic."""
    topic = st.spec.reference_topic
    assert topic is not None and state["ref"] is not None
    index, raw = state["ref"]
    msg = rec.decoder(topic)(raw)
    if short_type(rec.topics[topic].msgtype) == "sensor_msgs/CompressedImage":
        rgb = compressed_rgb(msg, topic, index, rec)
    else:
        rgb = image_rgb(msg, topic, index, rec)
    if rgb.shape[:2] != st.size_hw:
        assert st.size_hw is not None
        raise InputError(f"stream {st.spec.name}: the reference frame (topic {topic}, message "
                         f"{index}) is {rgb.shape[1]}x{rgb.shape[0]} px but the frames of "
                         f"{st.spec.topic} are {st.size_hw[1]}x{st.size_hw[0]} px; a reference "
                         "has the frames' size", path=rec.path)
    return rgb


def _write_frames(st: _Stream, state: dict[str, Any], trial: _Trial, rec: RobotRecording,
                  options: RobotOptions, *, final: bool) -> None:
    """Write the pending frames of one trial (in stamp order with ``sort_stamps``, keeping
    the later half back until the trial ends so that frames arriving late can still be
    sorted in)."""
    pending, times = state["pending"], state["times"]
    if not pending:
        return
    keep = 0
    if options.sort_stamps:
        order = np.argsort(np.asarray(times), kind="stable")
        pending, times = [pending[i] for i in order], [times[i] for i in order]
        keep = 0 if final else len(pending) // 2
    if state["appender"] is None:
        ref = st.spec.reference
        reference = (_topic_reference(st, state, rec) if st.spec.reference_topic is not None
                     else pending[0 if ref == "first" else int(ref)])
        state["appender"] = trial.writer.frames(st.spec.name, reference=reference)
    head, head_t = pending[:len(pending) - keep], times[:len(pending) - keep]
    if state["written"] is not None and head_t[0] < state["written"]:
        raise InputError(f"topic {st.spec.topic}, trial {trial.span.name}: a frame's stamp goes "
                         f"back {state['written'] - head_t[0]:.6f} s, behind frames already "
                         f"written; `sort_stamps=True` sorts frames within "
                         f"{max(1, FRAME_BATCH_BYTES // pending[0].nbytes // 2)} frames: map "
                         "the topic with `time: log`", path=rec.path)
    state["appender"].append(np.stack(head), np.asarray(head_t))
    state["written"] = head_t[-1]
    state["pending"], state["times"] = pending[len(head):], times[len(head):]


def _take_events(st: _Stream, msg: Any, k: int, rec: RobotRecording, trials: list[_Trial],
                 writer: StoreWriter) -> None:
    if st.sensor is None:
        width = st.spec.width_px or int(msg.width)
        height = st.spec.height_px or int(msg.height)
        if not (width and height):
            raise InputError(f"topic {st.spec.topic}: the EventArray gives no sensor size; give "
                             "`width_px` and `height_px` in the mapping", path=rec.path)
        st.width_px, st.height_px = width, height
        st.sensor = writer.add_sensor(
            st.spec.name, kind="event_camera", sample_rate_hz=0, width_px=width,
            height_px=height, description=st.spec.description or
            f"events of {st.spec.topic} ({short_type(st.msgtype)})",
            **_identity(st, writer))
    x, y, t_ns, p = event_columns(msg)
    st.sub_us_events += int(np.count_nonzero(t_ns % 1000))
    appender = st.events.get(k)
    if appender is None:
        appender = st.events[k] = trials[k].writer.events(st.sensor)
    appender.append(x, y, t_ns // 1000, p, source=rec.path, row_label=f"topic {st.spec.topic} "
                    "event")
    st.stamps.setdefault(k, []).append(int(t_ns[0]) if len(t_ns) else 0)


def _flush(st: _Stream, k: int, trials: list[_Trial], rec: RobotRecording, writer: StoreWriter,
           options: RobotOptions) -> None:
    """Write out what stream ``st`` gathered for trial ``k``."""
    spec, trial = st.spec, trials[k]
    origin = trial.span.start_ns
    if spec.is_frames:
        state = st.frames.pop(k)
        if state["back"] and not options.sort_stamps:
            raise InputError(f"stream {spec.name} (topic {spec.topic}): {state['back']} frame "
                             f"stamp(s) go back in trial {trial.span.name}; pass "
                             "`sort_stamps=True` to sort the frames by stamp, or map the topic "
                             "with `time: log`", path=rec.path)
        ref = spec.reference
        if (state["appender"] is None and spec.reference_topic is None
                and state["count"] <= (0 if ref == "first" else int(ref))):
            raise InputError(f"trial {trial.span.name}: topic {spec.topic} has "
                             f"{state['count']} frame(s), so there is no frame {spec.reference} "
                             "to take as the reference; lower `reference`", path=rec.path)
        _write_frames(st, state, trial, rec, options, final=True)
        st.late += state["back"]
        state["appender"].close()
        st.timing_all.append((np.asarray(st.stamps.pop(k), dtype=np.int64) - origin) / 1e9)
        return
    if spec.is_events:
        appender = st.events.pop(k)
        appender.close(t_origin_us=origin // 1000)
        st.stamps.pop(k, None)
        return
    rows = st.rows_of.pop(k)
    if rows.appender is None:  # the whole trial fits one block: written in one piece
        t_ns = np.asarray(rows.t_ns, dtype=np.int64)
        back = int(np.count_nonzero(np.diff(t_ns) < 0))
    else:
        _spill(st, rows, trial)
        back = rows.appender.back
    if back and not options.sort_stamps:
        raise InputError(f"stream {spec.name} (topic {spec.topic}): {back} stamp(s) go back "
                         f"in trial {trial.span.name}; pass `sort_stamps=True` to sort the "
                         "samples by stamp, or map the topic with `time: log`", path=rec.path)
    st.late += back
    if rows.appender is None:
        data = _block(st, rows)
        if back:
            order = np.argsort(t_ns, kind="stable")
            t_ns, data = t_ns[order], data[order]
        t_s = (t_ns - origin) / 1e9
        trial.writer.write_signal(spec.name, sensor=spec.name, data=data, t_s=t_s)
    else:
        t_s = rows.appender.close(sort=True)
    st.timing_all.append(t_s)


def _identity(st: _Stream, writer: StoreWriter) -> dict[str, Any]:
    """Sensor attributes of identity: topic, type, frame_id, serial, calibration."""
    spec = st.spec
    out: dict[str, Any] = {"topic": spec.topic, "message_type": st.msgtype}
    if st.frame_id:
        out["frame_id"] = st.frame_id
    if spec.serial:
        out["serial"] = spec.serial
    if spec.calibration is not None:
        path = spec.calibration
        writer.add_source(path)
        out["calibration_file"] = path.name
        out["calibration_sha256"] = sha256_of(path)
        if path.stat().st_size <= CALIBRATION_TEXT_BYTES:
            try:
                out["calibration_text"] = path.read_bytes().decode("utf-8")
            except UnicodeDecodeError:
                pass
    return out


def _finish_sensor(st: _Stream, mapping: TopicMapping, options: RobotOptions,
                   writer: StoreWriter) -> str:
    spec = st.spec
    tm = timing(st.timing_all)
    extra = {"jitter_s": tm.jitter_s, "gaps": tm.gaps, "longest_gap_s": tm.longest_gap_s}
    extra = {k: v for k, v in extra.items() if v is not None}
    rate = round(tm.rate_hz, 6) if tm.rate_hz else 0.0
    if spec.is_events:
        pass  # added at its first message (the event appender needs its size)
    elif spec.is_frames:
        if st.size_hw is None:
            writer.add_sensor(spec.name, kind="visuotactile", sample_rate_hz=rate,
                              description=spec.description, **_identity(st, writer))
        else:
            writer.add_sensor(spec.name, kind="visuotactile", sample_rate_hz=rate,
                              width_px=st.size_hw[1], height_px=st.size_hw[0],
                              description=spec.description or
                              f"frames of {spec.topic} ({short_type(st.msgtype)})",
                              **_identity(st, writer), **extra)
    else:
        rows = st.rows
        writer.add_sensor(spec.name, kind=spec.kind, sample_rate_hz=rate,
                          channel_names=rows.channels if rows else None,
                          channel_units=rows.units if rows else None,
                          description=spec.description or
                          f"{spec.topic} ({short_type(st.msgtype)})",
                          **_identity(st, writer), **extra)
    what = ("frames" if spec.is_frames else "event arrays" if spec.is_events else "samples")
    line = (f"{spec.name} ({spec.topic}): {st.n} {what}, "
            + (f"{tm.rate_hz:.6g} Hz median, jitter {tm.jitter_s:.3g} s" if tm.rate_hz
               else "no rate (fewer than two stamps)")
            + (f", {tm.gaps} gap(s) over {GAP_FACTOR:g}x the median interval (longest "
               f"{tm.longest_gap_s:.3g} s)" if tm.gaps else ", no gaps")
            + ("; time from header stamps" if st.use_header else "; time from log times"))
    if st.late:
        line += f"; {st.late} stamp(s) that went back were sorted (`sort_stamps=True`)"
    if st.sub_us_events:
        line += (f"; {st.sub_us_events} event stamp(s) had digits below the microsecond, "
                 "which the schema's integer microseconds drop")
    return line


# -- describe --------------------------------------------------------------------------------
def describe_robot(path: Path, options: RobotOptions, fmt: IngestFormat[Any]) -> RecordingSummary:
    """Every topic of the recording with its type, count, rate, jitter, span and bytes
    (log times), read-only; with a mapping, the streams and trials an ingest would make
    and the topics it would leave out."""
    mapping = None if options.mapping is None else load_topic_mapping(options.mapping)
    with RobotRecording(path) as rec:
        times: dict[str, list[int]] = {t: [] for t in rec.topics}
        sizes: dict[str, int] = dict.fromkeys(rec.topics, 0)
        for topic, t_ns, raw in rec.raw_messages():
            times[topic].append(t_ns)
            sizes[topic] += len(raw)
        start_ns = min((v[0] for v in times.values() if v), default=0)
        names = {}
        if mapping is not None:
            assert options.mapping is not None
            check_topics(rec, mapping, options.mapping)
            names = {s.topic: s.name for s in mapping.streams}
        spans, notes = trial_spans(rec, mapping, options, start_ns)
        streams = []
        for topic, info in rec.topics.items():
            t = np.asarray(times[topic], dtype=np.int64)
            rel_s = (t - t[0]) / 1e9 if len(t) else np.zeros(0)  # intervals exact in ns
            stats = stamp_stats(rel_s)
            tm = timing([rel_s])
            streams.append(StreamSummary(
                name=names.get(topic, topic), type=short_type(info.msgtype), count=len(t),
                unit="messages", readable=info.defined, rate_hz=stats.rate_hz,
                jitter_s=stats.jitter_s,
                t_first_s=float(t[0] / 1e9) if len(t) else None,
                t_last_s=float(t[-1] / 1e9) if len(t) else None,
                span_s=float((t[-1] - t[0]) / 1e9) if len(t) else None,
                size_bytes=sizes[topic], repeated_stamps=stats.n_repeated,
                out_of_order_stamps=stats.n_out_of_order,
                extra={"topic": topic, "message_type": info.msgtype, "gaps": tm.gaps,
                       "defined": info.defined}))
        trials = []
        for span in spans:
            end = span.end_ns
            counts = {}
            for topic in (names or rec.topics):
                t = np.asarray(times[topic], dtype=np.int64)
                counts[names.get(topic, topic)] = int(np.count_nonzero(
                    (t >= span.start_ns) & (t < end)))
            last = max((v[-1] for v in times.values() if v), default=span.start_ns)
            trials.append(TrialSummary(
                name=span.name, source=str(path), counts=counts,
                duration_s=(min(end, last) - span.start_ns) / 1e9 if end != OPEN_END_NS
                else (last - span.start_ns) / 1e9,
                labels={**(mapping.trials.labels if mapping else {}), **span.labels}))
        dropped = []
        if mapping is not None:
            marker = mapping.trials.marker.topic if mapping.trials.marker else None
            dropped = [f"topic {t} ({short_type(i.msgtype)}, {i.count} messages): not in the "
                       "mapping" for t, i in rec.topics.items() if t not in names and t != marker]
        else:
            notes.append("an ingest needs a topic mapping (`mapping='topics.yaml'`: which "
                         "topics become which streams; see configs/rosbag_tactile_rig.yaml)")
        undefined = [t for t, i in rec.topics.items() if not i.defined]
        if undefined:
            notes.append("no message definition for: " + ", ".join(
                f"{t} ({rec.topics[t].msgtype})" for t in undefined))
        notes.insert(0, f"{rec.storage}; rates and spans from log times")
        return RecordingSummary(file=str(path), format=fmt.name, title=fmt.title,
                                size_bytes=rec.size_bytes, streams=streams, trials=trials,
                                dropped=dropped, notes=notes,
                                ingest_options={"mapping": str(options.mapping or
                                                               "topics.yaml")})


class RosBagFormat(IngestFormat[RobotOptions]):
    """ROS 1 bags and ROS 2 bag folders, read by rosbags (module docstring)."""

    name = "rosbag"
    title = "ROS bag"
    summary = ("a ROS 1 bag (.bag) or a ROS 2 bag folder (metadata.yaml; sqlite3 or mcap "
               "storage), mapped topic by topic with `mapping`")
    suffixes = (BAG_SUFFIX,)
    Options = RobotOptions

    def sniff(self, path: Path) -> bool:
        try:
            return recording_kind(path) in ("ros1", "ros2") and (
                is_ros2_folder(path) or not path.is_dir())
        except OSError:
            return False

    def describe(self, path: Path, options: RobotOptions) -> RecordingSummary:
        return describe_robot(path, options, self)

    def read(self, inputs: Sequence[Path], options: RobotOptions, writer: StoreWriter,
             progress: Progress) -> list[str]:
        return ingest_robot(inputs, options, writer, progress)


class McapFormat(IngestFormat[RobotOptions]):
    """Standalone MCAP files of ROS 2 messages, read by mcap (module docstring)."""

    name = "mcap"
    title = "MCAP"
    summary = "a standalone MCAP file (.mcap) of ROS 2 messages, mapped with `mapping`"
    suffixes = (MCAP_SUFFIX,)
    Options = RobotOptions

    def sniff(self, path: Path) -> bool:
        try:
            return path.suffix.lower() == MCAP_SUFFIX and not path.is_dir()
        except OSError:
            return False

    def describe(self, path: Path, options: RobotOptions) -> RecordingSummary:
        return describe_robot(path, options, self)

    def read(self, inputs: Sequence[Path], options: RobotOptions, writer: StoreWriter,
             progress: Progress) -> list[str]:
        return ingest_robot(inputs, options, writer, progress)


ROSBAG = RosBagFormat()
MCAP = McapFormat()

__all__ = ["GAP_FACTOR", "MCAP", "ROSBAG", "McapFormat", "RobotOptions", "RosBagFormat",
           "Timing", "check_topics", "describe_robot", "ingest_robot", "timing",
           "trial_spans"]
