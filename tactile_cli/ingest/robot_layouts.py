"""Rows of a few standard message types read straight from their serialised bytes.

rosbags' generated deserialisers build one object per message and per nested message
(header, stamp, vectors), about 30 us a message on this project's 2-core machine; a
tactile rig's 1 kHz taxel arrays and wrenches then spend more time there than in reading
the bag. For the fixed layouts that carry most of such a rig's messages, the row a stream
keeps is read here from the bytes: a block of messages that share one layout (the same
length, frame id length and array layout, as a driver's messages do) is one ``numpy`` view
of their joined bytes, and any other message is one ``struct.unpack_from`` and one
``numpy.frombuffer``:

- ``std_msgs/{Float32,Float64,Int8..Int64,UInt8..UInt64}MultiArray``: the values after the
  layout, from the first message's ``data_offset``, as float32;
- ``geometry_msgs/WrenchStamped`` and ``Wrench``: force x, y, z and torque x, y, z, float64;
- ``sensor_msgs/Imu``: orientation x, y, z, w, angular velocity and linear acceleration,
  float64 (the covariances skipped).

Both serialisations are read: ROS 1 (little-endian, packed) and CDR (ROS 2 bags and MCAP
files: either byte order, as the 4-byte encapsulation header says; each value aligned to its
size, counted from the end of that header). The rows and stamps are those of
:func:`tactile_cli.ingest.robot_messages.row_reader` on the deserialised message, value for
value; :mod:`tactile_cli.ingest.robot_bag` uses :class:`RawRows` only for a topic mapped
with its type's default values (no ``fields``), whose type the recording defines as the
standard one, and only after the topic's first message gave the same stamp and row both
ways (frame ids and labels are skipped, not decoded). A message whose bytes do not fit its
layout (cut short, bytes after its end, which rosbags refuses too, a bad CDR header) is a
:class:`~tactile_cli.errors.InputError` naming the topic and the message, as for a damaged
file.
"""

from __future__ import annotations

import struct
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..errors import InputError
from .robot_recording import short_type

#: Element types of the standard multi-arrays (ROS names the numeric array types alike in
#: both generations; Byte and Char arrays are left to the deserialiser).
MULTIARRAY_DTYPES = {
    "Float32": "f4", "Float64": "f8", "Int8": "i1", "UInt8": "u1", "Int16": "i2",
    "UInt16": "u2", "Int32": "i4", "UInt32": "u4", "Int64": "i8", "UInt64": "u8",
}
#: Types with a reader here (ROS 1 spelling).
RAW_TYPES = frozenset({f"std_msgs/{k}MultiArray" for k in MULTIARRAY_DTYPES}
                      | {"geometry_msgs/WrenchStamped", "geometry_msgs/Wrench",
                         "sensor_msgs/Imu"})
#: Indices of the default Imu values among its 37 float64 (orientation 4, covariance 9,
#: angular velocity 3, covariance 9, linear acceleration 3, covariance 9).
_IMU_PICK = np.array([0, 1, 2, 3, 13, 14, 15, 25, 26, 27])
_U32 = {"<": struct.Struct("<I"), ">": struct.Struct(">I")}
_HEADER = {"ros1": struct.Struct("<4xIII"),  # seq; stamp sec, nsec; frame_id's length
           "<": struct.Struct("<4xiII"), ">": struct.Struct(">4xiII")}  # CDR, after 4 bytes
_STRING_LENGTH = (12, 16)  # bytes of the header's frame_id length, in both serialisations


class _Short(Exception):
    """A message's bytes do not fit its layout (too few, too many, a bad CDR header)."""


def _cdr_order(raw: bytes) -> str:
    """``<`` or ``>`` from a CDR encapsulation header (0x0001 little-, 0x0000 big-endian)."""
    if len(raw) < 4 or raw[0] != 0 or raw[1] > 1:
        raise _Short
    return "<" if raw[1] else ">"


def _align(pos: int, size: int) -> int:
    """``pos`` rounded up to a multiple of ``size`` counted from byte 4 (CDR alignment)."""
    return pos + (-(pos - 4) % size)


@dataclass(frozen=True)
class _Where:
    """Where a message's values sit: byte order, first byte, count, and the byte ranges that
    messages must share for their values to sit at the same place."""

    order: str
    pos: int
    count: int
    same: tuple[tuple[int, int], ...]


def _multiarray_ros1(raw: bytes) -> _Where:
    u32 = _U32["<"].unpack_from
    (ndim,) = u32(raw, 0)
    pos = 4
    for _ in range(ndim):  # label (length, bytes), size, stride
        pos += 12 + u32(raw, pos)[0]
    (count,) = u32(raw, pos + 4)  # after data_offset
    return _Where("<", pos + 8, count, ((0, pos + 8),))


def _multiarray_cdr(size: int) -> Callable[[bytes], _Where]:
    def where(raw: bytes) -> _Where:
        order = _cdr_order(raw)
        u32 = _U32[order].unpack_from
        (ndim,) = u32(raw, 4)
        pos = 8
        for _ in range(ndim):  # label (aligned length, bytes with NUL), size, stride
            pos = _align(pos, 4)
            pos += 4 + u32(raw, pos)[0]
            pos = _align(pos, 4) + 8
        pos = _align(_align(pos, 4) + 4, 4)  # after data_offset
        (count,) = u32(raw, pos)
        start = _align(pos + 4, size)
        return _Where(order, start, count, ((0, start),))

    return where


def _float64s(serialisation: str, stamped: bool, count: int) -> Callable[[bytes], _Where]:
    """Where ``count`` float64 sit after an optional Header."""
    def where(raw: bytes) -> _Where:
        if serialisation == "ros1":
            if not stamped:
                return _Where("<", 0, count, ())
            n = _HEADER["ros1"].unpack_from(raw, 0)[2]
            return _Where("<", 16 + n, count, (_STRING_LENGTH,))
        order = _cdr_order(raw)
        if not stamped:
            return _Where(order, 4, count, ((0, 4),))
        n = _HEADER[order].unpack_from(raw, 0)[2]
        return _Where(order, _align(16 + n, 8), count, ((0, 4), _STRING_LENGTH))

    return where


class RawRows:
    """The rows (and header stamps) of one topic's messages, read from their bytes.

    serialisation: ``"ros1"`` or ``"cdr"``; msgtype: one of :data:`RAW_TYPES` (either
    spelling); offset: the multi-array's ``data_offset`` of the topic's first message (the
    deserialised reader takes that one for every message); topic, path: for errors.
    """

    def __init__(self, serialisation: str, msgtype: str, offset: int, topic: str, path: Path):
        kind = short_type(msgtype)
        self.topic, self.path, self.serialisation = topic, path, serialisation
        # bytes allowed after the values: none in ROS 1; CDR may pad to 4 bytes (as rosbags)
        self.slack = 0 if serialisation == "ros1" else 3
        self.stamped = kind in ("geometry_msgs/WrenchStamped", "sensor_msgs/Imu")
        self.pick: np.ndarray | slice
        if kind.endswith("MultiArray"):
            self.dtype = MULTIARRAY_DTYPES[kind[len("std_msgs/"):-len("MultiArray")]]
            size = np.dtype(self.dtype).itemsize
            self.where = (_multiarray_ros1 if serialisation == "ros1"
                          else _multiarray_cdr(size))
            self.pick, self.out = slice(offset, None), np.dtype(np.float32)
        else:
            imu = kind == "sensor_msgs/Imu"
            self.dtype = "f8"
            self.where = _float64s(serialisation, kind.endswith("Stamped") or imu,
                                   37 if imu else 6)
            self.pick = _IMU_PICK if imu else slice(None)
            self.out = np.dtype(np.float64)

    def _short(self, raw: bytes, index: int) -> InputError:
        return InputError(f"topic {self.topic}, message {index}: {len(raw)} bytes do not fit "
                          "the message's layout; the file is damaged or was cut short: "
                          "re-index it or record it again", path=self.path)

    def stamp(self, raw: bytes, index: int) -> int | None:
        """The header stamp in ns (None for a type without a header)."""
        if not self.stamped:
            return None
        try:
            order = "ros1" if self.serialisation == "ros1" else _cdr_order(raw)
            sec, nsec, _ = _HEADER[order].unpack_from(raw, 0)
        except (_Short, struct.error):
            raise self._short(raw, index) from None
        return sec * 1_000_000_000 + nsec

    def row(self, raw: bytes, index: int) -> np.ndarray:
        """One message's (n_values,) row."""
        try:
            w = self.where(raw)
            values = np.frombuffer(raw, w.order + self.dtype, w.count, w.pos)
            if len(raw) - (w.pos + values.nbytes) > self.slack:
                raise _Short
        except (_Short, struct.error, ValueError):
            raise self._short(raw, index) from None
        return values[self.pick].astype(self.out)

    def rows(self, raws: Sequence[bytes], indices: Sequence[int], n_values: int) -> np.ndarray:
        """(len(raws), n_values) rows of messages ``raws`` (their indices in the topic in
        ``indices``, for errors); one view of their joined bytes when they share the first
        one's layout, else one message at a time. InputError naming the message when one
        gives another number of values."""
        first = raws[0]
        try:
            w = self.where(first)
        except (_Short, struct.error):
            raise self._short(first, indices[0]) from None
        length = len(first)
        end = w.pos + w.count * np.dtype(self.dtype).itemsize
        if 0 <= length - end <= self.slack and all(len(r) == length for r in raws):
            block = np.frombuffer(b"".join(raws), np.uint8).reshape(len(raws), length)
            if all((block[:, a:b] == block[0, a:b]).all() for a, b in w.same):
                values = block[:, w.pos:end].copy().view(w.order + self.dtype)
                out = values[:, self.pick].astype(self.out)
                if out.shape[1] != n_values:
                    self._count_error(indices[0], out.shape[1], n_values)
                return out
        rows = []
        for raw, index in zip(raws, indices, strict=True):
            row = self.row(raw, index)
            if len(row) != n_values:
                self._count_error(index, len(row), n_values)
            rows.append(row)
        return np.vstack(rows)

    def _count_error(self, index: int, got: int, want: int) -> None:
        raise InputError(f"topic {self.topic}, message {index}: {got} values, but the first "
                         f"message gave {want}; a stream keeps one channel count",
                         path=self.path)


def raw_rows(serialisation: str, msgtype: str, offset: int, topic: str,
             path: Path) -> RawRows | None:
    """The :class:`RawRows` of ``msgtype``, or None when the type has no reader here."""
    if short_type(msgtype) not in RAW_TYPES:
        return None
    return RawRows(serialisation, msgtype, offset, topic, path)


__all__ = ["MULTIARRAY_DTYPES", "RAW_TYPES", "RawRows", "raw_rows"]
