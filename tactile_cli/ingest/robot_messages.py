"""ROS messages into arrays: images into RGB frames, arrays and known message types into
sample rows, field paths into values, event arrays into event columns.

The message objects are those of :mod:`tactile_cli.ingest.robot_recording` (rosbags'
generated dataclasses: nested messages as attributes, primitive arrays as numpy arrays).
A :class:`RowReader` is planned once per topic from its message *type* (so a field path that
does not exist is an error before any message is read) and then turns each message into one
(n_channels,) row; the per-message work is attribute access and ``numpy`` copies only.

Defaults per type (``fields`` in the mapping replaces them):

- ``std_msgs/*MultiArray``: ``data`` from ``layout.data_offset``, the layout's dimensions
  (label, size) as channel names (``row0_col1`` for dims ``row``, ``col``);
- ``geometry_msgs/WrenchStamped`` / ``Wrench``: ``force_x..z`` in N, ``torque_x..z`` in N m;
- ``sensor_msgs/Imu``: ``orientation_x..w`` (quaternion), ``angular_velocity_x..z`` in
  rad/s, ``linear_acceleration_x..z`` in m/s^2;
- ``sensor_msgs/JointState``: ``<joint>_position`` (rad), ``_velocity`` (rad/s),
  ``_effort`` (N m) for the arrays the first message fills;
- any other type with exactly one numeric array field, or only numeric scalar fields:
  those values, named by field path.

Images (``sensor_msgs/Image``) decode ``rgb8``, ``bgr8``, ``mono8`` (and ``rgba8``,
``bgra8``) to (height, width, 3) uint8 RGB frames; ``mono16``, ``16UC1`` and ``32FC1``
(depth, raw intensity) do not fit 8-bit frames without a choice of scale, so they are read
as samples instead (one channel per pixel, row-major ``y{row}_x{col}``, values exact).
``sensor_msgs/CompressedImage`` frames (JPEG, PNG) are decoded by Pillow.
"""

from __future__ import annotations

import io
import re
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..errors import InputError
from .robot_recording import RobotRecording, short_type

#: Image encodings decoded to 8-bit RGB frames: encoding -> (channels, channel order).
FRAME_ENCODINGS: dict[str, tuple[int, str]] = {
    "rgb8": (3, "rgb"), "bgr8": (3, "bgr"), "rgba8": (4, "rgb"), "bgra8": (4, "bgr"),
    "mono8": (1, "mono"), "8UC1": (1, "mono"), "8UC3": (3, "bgr"),
}
#: Image encodings read as samples (one channel per pixel), with their dtype.
SAMPLE_ENCODINGS: dict[str, str] = {"mono16": "u2", "16UC1": "u2", "32FC1": "f4",
                                    "mono8": "u1", "8UC1": "u1"}
#: Numeric ROS base types.
NUMERIC = {"bool", "byte", "char", "int8", "uint8", "int16", "uint16", "int32", "uint32",
           "int64", "uint64", "float32", "float64"}
_STEP = re.compile(r"([A-Za-z_]\w*)((?:\[(?:\d+|\*)\])*)")
_INDEX = re.compile(r"\[(\d+|\*)\]")

IMAGE_TYPES = ("sensor_msgs/Image",)
COMPRESSED_TYPES = ("sensor_msgs/CompressedImage",)
EVENT_TYPES = ("dvs_msgs/EventArray",)
WRENCH_FIELDS = [f"wrench.{g}.{a}" for g in ("force", "torque") for a in "xyz"]
IMU_FIELDS = ([f"orientation.{a}" for a in "xyzw"]
              + [f"angular_velocity.{a}" for a in "xyz"]
              + [f"linear_acceleration.{a}" for a in "xyz"])
IMU_UNITS = ["1"] * 4 + ["rad/s"] * 3 + ["m/s^2"] * 3


@dataclass
class RowReader:
    """Turns a message into one (n_channels,) float64 row.

    channels: the channel names; units: one unit per channel; read: message -> row.
    """

    channels: list[str]
    units: list[str]
    read: Callable[[Any], np.ndarray]


def header_stamp_ns(msg: Any) -> int | None:
    """The message header's stamp in ns, or None for a message without a header."""
    header = getattr(msg, "header", None)
    stamp = getattr(header, "stamp", None)
    if stamp is None:
        return None
    return int(stamp.sec) * 1_000_000_000 + int(stamp.nanosec)


def frame_id(msg: Any) -> str | None:
    """The header's ``frame_id`` (the sensor's identity in many drivers), or None."""
    value = getattr(getattr(msg, "header", None), "frame_id", None)
    return str(value) if value else None


# -- type-level field paths -------------------------------------------------------------
def _parse(path: str) -> list[tuple[str, list[str]]]:
    """``taxels[*].z`` -> ``[("taxels", ["*"]), ("z", [])]``."""
    out = []
    for part in path.split("."):
        m = _STEP.fullmatch(part)
        if m is None:  # the mapping's validator checked the syntax already
            raise ValueError(path)
        out.append((m.group(1), _INDEX.findall(m.group(2))))
    return out


def check_path(rec: RobotRecording, msgtype: str, path: str, topic: str) -> None:
    """Check a field path against the message type's definition: each name a field of the
    type reached so far, ``[..]`` only on arrays, the end a number or array of numbers.
    InputError naming the path, the type and its fields otherwise."""
    current = msgtype
    steps = _parse(path)
    for k, (name, indices) in enumerate(steps):
        fields = dict(rec.fields_of(current))
        if name not in fields:
            raise InputError(f"field path {path!r} of topic {topic}: {short_type(current)} has no "
                             f"field {name!r} (its fields: {', '.join(fields)})",
                             path=rec.path)
        node = fields[name]
        for _ in indices:
            if node[0] not in (3, 4):  # Nodetype.ARRAY, Nodetype.SEQUENCE
                raise InputError(f"field path {path!r} of topic {topic}: {name} is not an "
                                 "array, so it takes no [index]", path=rec.path)
            node = node[1][0]
        last = k == len(steps) - 1
        if node[0] in (3, 4):
            if not last:
                raise InputError(f"field path {path!r} of topic {topic}: {name} is an array; "
                                 f"write {name}[*] or {name}[INDEX] before the next field",
                                 path=rec.path)
            node = node[1][0]
        if node[0] == 2:  # a nested message
            current = node[1]
            if last:
                raise InputError(f"field path {path!r} of topic {topic}: {name} is a "
                                 f"{short_type(current)} message, not a number; name one of its "
                                 f"fields ({', '.join(dict(rec.fields_of(current)))})",
                                 path=rec.path)
            if not rec.has_type(current):
                raise InputError(f"message type {current} (in {short_type(msgtype)}, topic "
                                 f"{topic}) has no definition in the recording", path=rec.path)
        elif not last:
            raise InputError(f"field path {path!r} of topic {topic}: {name} is a number and has "
                             "no fields", path=rec.path)
        elif node[1][0] not in NUMERIC:
            raise InputError(f"field path {path!r} of topic {topic}: {name} is a {node[1][0]}, "
                             "not a number", path=rec.path)


def _values(obj: Any, steps: Sequence[tuple[str, list[str]]]) -> list[Any]:
    """Every value a parsed path reaches in ``obj`` (arrays flattened in order)."""
    items = [obj]
    for name, indices in steps:
        items = [getattr(o, name) for o in items]
        for index in indices:
            if index == "*":
                items = [v for o in items for v in (o if not isinstance(o, bytes) else list(o))]
            else:
                items = [o[int(index)] for o in items]
    out: list[Any] = []
    for v in items:
        if isinstance(v, np.ndarray):
            out.extend(v.ravel().tolist())
        elif isinstance(v, list | tuple):
            out.extend(v)
        else:
            out.append(v)
    return out


def path_reader(paths: Sequence[str], first: Any) -> tuple[list[str], Callable[[Any], np.ndarray]]:
    """Channel names and a row reader for field paths; a path ending in an array (or
    with ``[*]``) gives one channel per element of the first message (``taxels[3].z``)."""
    parsed = [_parse(p) for p in paths]
    names: list[str] = []
    for path, steps in zip(paths, parsed, strict=True):
        n = len(_values(first, steps))
        if "*" in path or n != 1:
            stars = path.count("[*]")
            if stars == 1 and "[*]" in path:
                names.extend(path.replace("[*]", f"[{i}]") for i in range(n))
            else:
                names.extend(f"{path}[{i}]" for i in range(n))
        else:
            names.append(path)

    def read(msg: Any) -> np.ndarray:
        values: list[Any] = []
        for steps in parsed:
            values.extend(_values(msg, steps))
        return np.asarray(values, dtype=np.float64)

    return names, read


def _multiarray(first: Any) -> tuple[list[str], Callable[[Any], np.ndarray]]:
    dims = list(first.layout.dim)
    offset = int(first.layout.data_offset)
    n = len(first.data) - offset
    if dims and int(np.prod([d.size for d in dims])) == n:
        grids = np.indices([int(d.size) for d in dims]).reshape(len(dims), -1).T
        labels = [d.label or f"dim{k}" for k, d in enumerate(dims)]
        names = ["_".join(f"{lab}{i}" for lab, i in zip(labels, idx, strict=True))
                 for idx in grids]
    else:
        names = [f"data{i}" for i in range(n)]

    def read(msg: Any) -> np.ndarray:
        # float32, what the store keeps: one conversion (a copy: a view would keep the
        # message's whole chunk alive until the block is written)
        return np.array(msg.data[offset:], dtype=np.float32)

    return names, read


def _numeric_fields(rec: RobotRecording, msgtype: str) -> list[str]:
    """The default field paths of a type: its one numeric array, else its numeric scalars."""
    arrays, scalars = [], []
    for name, node in rec.fields_of(msgtype):
        if node[0] == 1 and node[1][0] in NUMERIC:
            scalars.append(name)
        elif node[0] in (3, 4) and node[1][0][0] == 1 and node[1][0][1][0] in NUMERIC:
            arrays.append(name)
    if len(arrays) == 1:
        return [arrays[0]]
    if not arrays and scalars:
        return scalars
    return []


def row_reader(rec: RobotRecording, topic: str, msgtype: str, first: Any,
               fields: Sequence[str] | None) -> RowReader:
    """Plan the row reader of ``topic`` from its type and first message (module docstring);
    units default to the type's (or none)."""
    kind = short_type(msgtype)
    if fields is not None:
        for path in fields:
            check_path(rec, msgtype, path, topic)
        names, read = path_reader(fields, first)
        return RowReader(names, [""] * len(names), read)
    if kind.startswith("std_msgs/") and kind.endswith("MultiArray"):
        names, read = _multiarray(first)
        return RowReader(names, [""] * len(names), read)
    if kind in ("geometry_msgs/WrenchStamped", "geometry_msgs/Wrench"):
        stamped = kind.endswith("Stamped")

        def read_wrench(msg: Any) -> np.ndarray:  # the hot path: attributes, no path walk
            w = msg.wrench if stamped else msg
            f, t = w.force, w.torque
            return np.array([f.x, f.y, f.z, t.x, t.y, t.z], dtype=np.float64)

        return RowReader([p[7:].replace(".", "_") for p in WRENCH_FIELDS],
                         ["N"] * 3 + ["N m"] * 3, read_wrench)
    if kind == "sensor_msgs/Imu":
        def read_imu(msg: Any) -> np.ndarray:
            q, a, v = msg.orientation, msg.angular_velocity, msg.linear_acceleration
            return np.array([q.x, q.y, q.z, q.w, a.x, a.y, a.z, v.x, v.y, v.z], dtype=np.float64)

        return RowReader([p.replace(".", "_") for p in IMU_FIELDS], list(IMU_UNITS), read_imu)
    if kind == "sensor_msgs/JointState":
        return _joint_state(first, topic, rec)
    if kind in IMAGE_TYPES:
        return _image_samples(first, topic, rec)
    default = _numeric_fields(rec, msgtype)
    if not default:
        raise InputError(f"topic {topic} ({kind}) has no default layout of values; list the "
                         "values to read with `fields:` (e.g. [wrench.force.x, taxels[*].z])",
                         path=rec.path)
    names, read = path_reader(default, first)
    return RowReader(names, [""] * len(names), read)


def _joint_state(first: Any, topic: str, rec: RobotRecording) -> RowReader:
    joints = [str(n) for n in first.name]
    parts = [(f, u) for f, u in (("position", "rad"), ("velocity", "rad/s"), ("effort", "N m"))
             if len(getattr(first, f)) == len(joints) and joints]
    if not parts:
        raise InputError(f"topic {topic}: the first JointState names no joints with values",
                         path=rec.path)
    names = [f"{j}_{f}" for f, _ in parts for j in joints]
    units = [u for _, u in parts for _ in joints]

    def read(msg: Any) -> np.ndarray:
        if list(msg.name) != joints:
            raise InputError(f"topic {topic}: a JointState names joints {list(msg.name)}, not "
                             f"{joints} like the first one; ingest one joint set per stream",
                             path=rec.path)
        return np.concatenate([np.asarray(getattr(msg, f), dtype=np.float64) for f, _ in parts])

    return RowReader(names, units, read)


def _image_samples(first: Any, topic: str, rec: RobotRecording) -> RowReader:
    encoding = str(first.encoding)
    if encoding not in SAMPLE_ENCODINGS:
        raise InputError(f"topic {topic}: {encoding} images are read as frames (map the topic "
                         f"with kind visuotactile); as samples tactile reads "
                         f"{', '.join(SAMPLE_ENCODINGS)}", path=rec.path)
    h, w = int(first.height), int(first.width)
    names = [f"y{r}_x{c}" for r in range(h) for c in range(w)]

    def read(msg: Any) -> np.ndarray:
        return image_values(msg, topic, rec).ravel().astype(np.float64)

    return RowReader(names, [""] * len(names), read)


def image_values(msg: Any, topic: str, rec: RobotRecording) -> np.ndarray:
    """(height, width) values of a one-channel image (mono8, mono16, 16UC1, 32FC1), exact."""
    encoding = str(msg.encoding)
    dtype = np.dtype(SAMPLE_ENCODINGS[encoding]).newbyteorder(">" if msg.is_bigendian else "<")
    h, w, step = int(msg.height), int(msg.width), int(msg.step)
    data = np.asarray(msg.data, dtype=np.uint8)
    if len(data) < h * step or step < w * dtype.itemsize:
        raise InputError(f"topic {topic}: an image of {len(data)} bytes is too short for "
                         f"{w}x{h} px {encoding} (step {step})", path=rec.path)
    rows = data[:h * step].reshape(h, step)[:, :w * dtype.itemsize]
    return rows.copy().view(dtype).reshape(h, w)


def image_rgb(msg: Any, topic: str, index: int, rec: RobotRecording) -> np.ndarray:
    """(height, width, 3) uint8 RGB of a ``sensor_msgs/Image`` with an 8-bit encoding."""
    encoding = str(msg.encoding)
    if encoding not in FRAME_ENCODINGS:
        raise InputError(f"topic {topic}, message {index}: {encoding} images do not fit 8-bit "
                         f"frames; map the topic with a sampled kind (e.g. pressure) to keep "
                         f"the values exactly (frames read: {', '.join(FRAME_ENCODINGS)})",
                         path=rec.path)
    n, order = FRAME_ENCODINGS[encoding]
    h, w, step = int(msg.height), int(msg.width), int(msg.step)
    data = np.asarray(msg.data, dtype=np.uint8)
    if len(data) < h * step or step < w * n:
        raise InputError(f"topic {topic}, message {index}: {len(data)} bytes are too short for "
                         f"a {w}x{h} px {encoding} image (step {step})", path=rec.path)
    pixels = data[:h * step].reshape(h, step)[:, :w * n].reshape(h, w, n)
    if order == "mono":
        return np.repeat(pixels, 3, axis=2)
    rgb = pixels[..., :3]
    return np.ascontiguousarray(rgb[..., ::-1] if order == "bgr" else rgb)


def compressed_rgb(msg: Any, topic: str, index: int, rec: RobotRecording) -> np.ndarray:
    """(height, width, 3) uint8 RGB of a ``sensor_msgs/CompressedImage`` (JPEG, PNG)."""
    from PIL import Image, UnidentifiedImageError

    data = bytes(np.asarray(msg.data, dtype=np.uint8))
    try:
        with Image.open(io.BytesIO(data)) as im:
            if im.mode == "F" or im.mode.startswith("I"):
                raise InputError(f"topic {topic}, message {index}: a 16-bit or float image "
                                 f"(mode {im.mode}) does not fit 8-bit frames", path=rec.path)
            return np.asarray(im.convert("RGB"), dtype=np.uint8)
    except UnidentifiedImageError:
        raise InputError(f"topic {topic}, message {index}: the {msg.format or 'compressed'} "
                         "frame cannot be decoded (not a JPEG or PNG Pillow reads)",
                         path=rec.path) from None
    except (OSError, SyntaxError, ValueError) as exc:
        detail = " ".join(str(exc).split())
        raise InputError(f"topic {topic}, message {index}: the {msg.format or 'compressed'} "
                         f"frame cannot be decoded ({detail})", path=rec.path) from None


def event_columns(msg: Any) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """x, y (px), t (int64 ns) and p (-1/+1) of a ``dvs_msgs/EventArray``."""
    events = msg.events
    n = len(events)
    x = np.fromiter((e.x for e in events), dtype=np.int64, count=n)
    y = np.fromiter((e.y for e in events), dtype=np.int64, count=n)
    t = np.fromiter((int(e.ts.sec) * 1_000_000_000 + int(e.ts.nanosec) for e in events),
                    dtype=np.int64, count=n)
    p = np.fromiter((1 if e.polarity else -1 for e in events), dtype=np.int8, count=n)
    return x, y, t, p


__all__ = ["COMPRESSED_TYPES", "EVENT_TYPES", "FRAME_ENCODINGS", "IMAGE_TYPES",
           "SAMPLE_ENCODINGS", "RowReader", "check_path", "compressed_rgb", "event_columns",
           "frame_id", "header_stamp_ns", "image_rgb", "image_values", "path_reader",
           "row_reader"]
