"""AEDAT4 files as iniVation cameras (DVXplorer, DAVIS) and DV software write them.

Decoding is done by the maintained ``aedat`` package (its Rust decoder handles the LZ4 and
Zstd packet compression); this module streams its packets into the store. One trial per
input file (named after the file stem) holds every stream of the file:

- the polarity-event stream: ``t`` in microseconds as recorded (absolute, with the
  camera's time offset applied by the recorder), ``x``/``y`` in pixels, and the ON/OFF flag
  stored as +1/-1; the sensor size is the file's (``--width``/``--height``, if given, must
  agree with it); the trial's time 0 is its first event (events attribute ``t_origin_us``);
- APS frames as the trial's image stream, IMU samples as the sampled stream ``imu`` and
  triggers as annotations (:mod:`tactile_cli.ingest.aedat4_streams`);
- the event sensor is named after the camera (the ``source`` attribute of the stream, e.g.
  ``DVXplorer_DXB00010``) unless ``--sensor`` names it; the IMU sensor is ``<camera>_imu``;
- a stream of a type the decoder does not read (``POSE``, ``BBOX``, ...) is an error, or,
  with ``skip_unknown=True``, left out with a note (:mod:`tactile_cli.ingest.aedat4_filter`);
- a file holds at most one event stream and at most one frame stream, since a trial holds
  one of each;
- a file without an event stream (a DAVIS recording saved with APS frames only, an IMU
  log) makes a trial without events: its time 0 is the earliest timestamp of its frames,
  IMU samples and triggers, recorded as the trial attribute ``t_origin_us``; the frames'
  sensor is an event camera of the frames' size named after the camera (or ``--sensor``);
  event-sensor options (``--width``/``--height``) are refused for such a file, and a file
  with neither events, frames nor IMU samples (triggers alone, or only unknown stream
  types) is refused naming the streams found.

Packets are gathered into chunks of ``Aedat4Options.chunk_events`` events before they are
checked and appended, so memory stays bounded (frames are appended one by one; IMU samples
and triggers, a few kB per second, are held until the file ends). Progress counts bytes.
"""

from __future__ import annotations

import os
import re
import struct
import sys
import tempfile
import xml.etree.ElementTree as ET
from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, BinaryIO

import numpy as np

from ..errors import InputError
from ..progress import Progress
from ..store.writer import EventAppender, StoreWriter, TrialWriter, safe_name
from .aedat4_filter import (
    KNOWN_TYPES,
    copy_without_streams,
    parse_io_header,
    stream_types,
    unknown_streams,
)
from .aedat4_streams import FrameCollector, ImuCollector, TriggerCollector
from .contract import FormatOptions, IngestFormat, RecordingSummary
from .events_table import DEFAULT_SENSOR, event_sensor

MAGIC = b"#!AER-DAT4.0\r\n"


class Aedat4Options(FormatOptions):
    """Options of the AEDAT4 format."""

    width_px: int | None = None
    """Event sensor width in px: checked against the file's own (which is used)."""
    height_px: int | None = None
    """Event sensor height in px: checked against the file's own (which is used)."""
    sensor_name: str | None = None
    """Name of the event sensor (default: the camera, e.g. ``DVXplorer_DXB00010``)."""
    chunk_events: int = 1 << 20
    """Events gathered before one check and append (memory stays bounded by it)."""
    skip_unknown: bool = False
    """Leave out streams of a type the decoder does not read (poses, bounding boxes, ...),
    with a note; without it such a file is refused."""


@dataclass(frozen=True)
class StreamInfo:
    """One output stream of an AEDAT4 file, as its header describes it."""

    stream_id: int
    type: str  # "events", "frame", "imus", "triggers"
    width_px: int | None = None
    height_px: int | None = None
    attrs: dict[str, str] = field(default_factory=dict)  # from the header's XML description

    @property
    def camera(self) -> str | None:
        return self.attrs.get("source")


def ingest_aedat4(inputs: Sequence[Path], options: Aedat4Options, writer: StoreWriter,
                  progress: Progress) -> list[str]:
    """Add one trial per AEDAT4 file with all its streams; returns one note per stream
    skipped (``options.skip_unknown``)."""
    for path in inputs:
        if not path.is_file():
            raise InputError("not a file (a folder?); give .aedat4 files", path=path)
    progress.start(sum(p.stat().st_size for p in inputs), "AEDAT4 streams")
    notes: list[str] = []
    for path in inputs:
        notes += _ingest_file(path, writer, options, progress)
    progress.finish()
    return notes


def read_streams(path: Path) -> dict[int, StreamInfo]:
    """The streams of an AEDAT4 file: decoder's stream table plus the header's attributes."""
    decoder = _open(path)
    attrs = _header_attributes(path)
    streams = {}
    for sid, info in decoder.id_to_stream().items():
        streams[int(sid)] = StreamInfo(int(sid), str(info.get("type")), info.get("width"),
                                       info.get("height"), attrs.get(int(sid), {}))
    return streams


def _ingest_file(path: Path, writer: StoreWriter, options: Aedat4Options,
                 progress: Progress) -> list[str]:
    check_layout(path)
    types = stream_types(path)
    if types and not any(kind in KNOWN_TYPES for kind in types.values()):
        raise InputError(f"no stream tactile reads in the file (found: {_found(types)}); "
                         f"tactile reads {', '.join(KNOWN_TYPES.values())}", path=path)
    unknown = unknown_streams(path)
    if unknown and not options.skip_unknown:
        sid, kind = min(unknown.items())
        raise InputError(f"stream {sid} has type {kind or '(none)'!r}, which the AEDAT4 decoder "
                         f"does not read (it reads {', '.join(KNOWN_TYPES)}); pass "
                         "`skip_unknown=True` to ingest the other streams", path=path)
    if not unknown:
        _ingest_streams(path, path, writer, options, progress)
        return []
    with tempfile.TemporaryDirectory(prefix="tactile-aedat4-") as tmp:
        readable = copy_without_streams(path, set(unknown), Path(tmp) / path.name)
        _ingest_streams(path, readable, writer, options, progress)
    return [f"{path}: skipped stream {sid} of type {kind or '(none)'!r} (not readable)"
            for sid, kind in sorted(unknown.items())]


def _found(types: dict[int, str]) -> str:
    """``stream 0 'POSE', stream 1 'BBOX'`` (or ``no streams``) for messages."""
    return ", ".join(f"stream {sid} {kind or '(none)'!r}"
                     for sid, kind in sorted(types.items())) or "no streams"


def _stream_kinds(streams: dict[int, StreamInfo]) -> str:
    return ", ".join(sorted({s.type for s in streams.values()})) or "no streams"


def _event_stream(path: Path, streams: dict[int, StreamInfo],
                  options: Aedat4Options) -> tuple[StreamInfo, int, int] | None:
    """The file's one event stream and its sensor size (width, height) in px; None when
    the file has no event stream."""
    event_streams = [s for s in streams.values() if s.type == "events"]
    frame_streams = [s for s in streams.values() if s.type == "frame"]
    if len(frame_streams) > 1:
        raise InputError(f"{len(frame_streams)} frame streams in one file; a trial holds one "
                         "image stream: export each camera to its own file", path=path)
    if not event_streams:
        return None
    if len(event_streams) > 1:
        raise InputError(f"{len(event_streams)} event streams in one file; a trial holds one "
                         "event stream: export each camera to its own file", path=path)
    stream = event_streams[0]
    if not stream.width_px or not stream.height_px:
        raise InputError(f"event stream {stream.stream_id} does not state its sensor size",
                         path=path)
    width, height = int(stream.width_px), int(stream.height_px)
    for flag, given, found in (("`width_px`", options.width_px, width),
                               ("`height_px`", options.height_px, height)):
        if given is not None and given != found:
            raise InputError(f"{flag} {given} disagrees with the file's sensor size "
                             f"{width}x{height} px; omit {flag} for AEDAT4 files", path=path)
    return stream, width, height


def _ingest_streams(path: Path, readable: Path, writer: StoreWriter, options: Aedat4Options,
                    progress: Progress) -> None:
    """Ingest ``path`` (as named in messages and sources) by decoding ``readable`` (the
    file itself, or its copy without unknown streams)."""
    streams = read_streams(readable)
    found = _event_stream(path, streams, options)
    if found is None:
        _ingest_without_events(path, readable, streams, writer, options, progress)
        return
    stream, width, height = found
    name = options.sensor_name or stream.camera or DEFAULT_SENSOR
    described = f"iniVation {stream.camera}" if stream.camera else "AEDAT4 event camera"
    sensor = event_sensor(writer, name, width_px=width, height_px=height, source=path,
                          description=f"{described}, AEDAT4 event stream {stream.stream_id}")
    origin_us = _first_event_us(path, readable, stream.stream_id)
    source = writer.add_source(path)
    trial = writer.trial(path.stem, sources=[source])
    events = trial.events(sensor)
    gather = _Gather(events, path, max(1, options.chunk_events))
    frames = {s.stream_id: FrameCollector(trial, _frame_sensor(writer, sensor, s, path), path,
                                          s.stream_id, origin_us)
              for s in streams.values() if s.type == "frame"}
    imus = {s.stream_id: ImuCollector(path, s.stream_id)
            for s in streams.values() if s.type == "imus"}
    triggers = TriggerCollector()
    _read_packets(path, readable, progress, gather.seen, {stream.stream_id: gather.add}, frames,
                  imus, triggers)
    gather.flush()
    # camera clocks count from an arbitrary epoch: the trial starts at its first event
    if events.close(t_origin_us=origin_us) == 0:
        raise InputError(f"event stream {stream.stream_id} holds no events", path=path)
    for collector in frames.values():
        collector.close()
    _write_imus(writer, trial, imus, sensor, stream.camera or sensor, origin_us)
    marks = triggers.annotations(origin_us)
    if marks:
        trial.set_annotations(marks)


def _read_packets(path: Path, readable: Path, progress: Progress,
                  events_read: Callable[[], int], events: dict[int, Callable[[np.ndarray], None]],
                  frames: dict[int, FrameCollector], imus: dict[int, ImuCollector],
                  triggers: TriggerCollector) -> None:
    """One pass over the packets of ``readable``, each handed to its stream's collector."""
    with open(readable, "rb") as raw:
        sizes = _packet_sizes(raw)
        progress.advance(next(sizes, 0))  # the file header
        for packet in _packets(readable, events_read=events_read, path=path):
            progress.advance(next(sizes, 0))
            sid = packet.get("stream_id")
            if sid in events and "events" in packet:
                events[sid](packet["events"])
            elif sid in frames and "frame" in packet:
                frames[sid].add(packet["frame"])
            elif sid in imus and "imus" in packet:
                imus[sid].add(packet["imus"])
            elif "triggers" in packet:
                triggers.add(packet["triggers"])


def _write_imus(writer: StoreWriter, trial: TrialWriter, imus: dict[int, ImuCollector],
                sensor: str, camera: str, origin_us: int) -> int:
    """Write each IMU stream as ``imu`` (``imu_<id>`` when there are several), sensor
    ``<sensor>_imu``; returns the samples written."""
    n = 0
    for sid, imu in imus.items():
        suffix = "" if len(imus) == 1 else f"_{sid}"
        n += imu.write(writer, trial, stream=f"imu{suffix}", sensor=f"{sensor}_imu{suffix}",
                       camera=camera, origin_us=origin_us)
    return n


def _ingest_without_events(path: Path, readable: Path, streams: dict[int, StreamInfo],
                           writer: StoreWriter, options: Aedat4Options,
                           progress: Progress) -> None:
    """A trial from a file without an event stream: its frames, IMU samples and triggers,
    time 0 at the earliest of their timestamps (trial attribute ``t_origin_us``)."""
    kinds = _stream_kinds(streams)
    if not any(s.type in ("frame", "imus") for s in streams.values()):
        raise InputError(f"no event, frame or IMU stream in the file (found: {kinds}); a trial "
                         "needs one (triggers only mark times in them)", path=path)
    given = [f"`{k}`" for k in ("width_px", "height_px") if getattr(options, k) is not None]
    if given:
        verb = "set" if len(given) > 1 else "sets"
        raise InputError(f"{' and '.join(given)} {verb} the size of an event sensor, but the file "
                         f"has no event stream (found: {kinds}); omit "
                         f"{'them' if len(given) > 1 else 'it'}", path=path)
    camera = next((s.camera for _, s in sorted(streams.items()) if s.camera), None)
    sensor = safe_name(options.sensor_name or camera or DEFAULT_SENSOR)
    origin_us = _earliest_us(path, readable, streams)
    source = writer.add_source(path)
    trial = writer.trial(path.stem, sources=[source], t_origin_us=origin_us)
    frames = {s.stream_id: FrameCollector(trial, _aps_sensor(writer, sensor, camera, s, path),
                                          path, s.stream_id, origin_us)
              for s in streams.values() if s.type == "frame"}
    imus = {s.stream_id: ImuCollector(path, s.stream_id)
            for s in streams.values() if s.type == "imus"}
    triggers = TriggerCollector()
    _read_packets(path, readable, progress, lambda: 0, {}, frames, imus, triggers)
    n = sum(collector.close() for collector in frames.values())
    n += _write_imus(writer, trial, imus, sensor, camera or sensor, origin_us)
    if n == 0:
        raise InputError(f"the file's streams ({kinds}) hold no frames and no IMU samples",
                         path=path)
    marks = triggers.annotations(origin_us)
    if marks:
        trial.set_annotations(marks)


def _aps_sensor(writer: StoreWriter, name: str, camera: str | None, frames: StreamInfo,
                path: Path) -> str:
    """The sensor of APS frames in a file without events: an event camera of their size."""
    if not frames.width_px or not frames.height_px:
        raise InputError(f"frame stream {frames.stream_id} does not state its size", path=path)
    described = f"iniVation {camera}" if camera else "AEDAT4 camera"
    return event_sensor(writer, name, width_px=int(frames.width_px),
                        height_px=int(frames.height_px), source=path,
                        description=f"{described}, APS frames of AEDAT4 frame stream "
                        f"{frames.stream_id} (the file has no event stream)")


def _earliest_us(path: Path, readable: Path, streams: dict[int, StreamInfo]) -> int:
    """The earliest timestamp of the frames, IMU samples and triggers of a file without
    events (its trial's time 0), decoded ahead of the main pass as for the first event."""
    first: int | None = None
    for packet in _packets(readable, events_read=lambda: 0, path=path):
        times: list[int] = []
        if "frame" in packet:
            times.append(int(packet["frame"]["t"]))
        for key in ("imus", "triggers"):
            rows = packet.get(key)
            if rows is not None and len(rows):
                times.append(int(np.min(np.asarray(rows["t"], dtype=np.int64))))
        if times:
            first = min(times) if first is None else min(first, *times)
    if first is None:
        raise InputError(f"the file's streams ({_stream_kinds(streams)}) hold no frames and no "
                         "IMU samples", path=path)
    return first


def _frame_sensor(writer: StoreWriter, event_sensor_name: str, frames: StreamInfo,
                  path: Path) -> str:
    """The sensor of the APS frames: the event sensor when the sizes agree (DAVIS),
    else an event-camera sensor ``<camera>_aps`` of the frames' size."""
    attrs = writer.h5["sensors"][event_sensor_name].attrs
    size = (frames.width_px, frames.height_px)
    if size == (int(attrs["width_px"]), int(attrs["height_px"])):
        return event_sensor_name
    if not all(size):
        raise InputError(f"frame stream {frames.stream_id} does not state its size", path=path)
    return event_sensor(writer, f"{event_sensor_name}_aps", width_px=int(size[0]),
                        height_px=int(size[1]), source=path,
                        description=f"APS frames of {event_sensor_name} "
                        f"(AEDAT4 frame stream {frames.stream_id})")


def _first_event_us(path: Path, readable: Path, stream_id: int) -> int:
    """The first event's timestamp (the trial's time 0), decoded ahead of the main pass so
    frames, IMU samples and triggers recorded before it get their times as they stream."""
    for packet in _packets(readable, events_read=lambda: 0, path=path):
        if packet.get("stream_id") == stream_id and len(packet.get("events", ())):
            return int(packet["events"]["t"][0])
    raise InputError(f"event stream {stream_id} holds no events", path=path)


class _Gather:
    """Collects decoder packets (about a thousand events each) into blocks of at least
    ``chunk`` events, so the appender's checks and copies run on large arrays."""

    def __init__(self, events: EventAppender, path: Path, chunk: int):
        self.events = events
        self.path = path
        self.chunk = chunk
        self.pending: list[np.ndarray] = []
        self.n_pending = 0
        self.n_done = 0

    def seen(self) -> int:
        return self.n_done + self.n_pending

    def add(self, packet: np.ndarray) -> None:
        """packet: (k,) structured events with fields t (uint64 us), x, y (uint16 px) and
        p (bool, True for ON)."""
        self.pending.append(packet)
        self.n_pending += len(packet)
        if self.n_pending >= self.chunk:
            self.flush()

    def flush(self) -> None:
        if not self.pending:
            return
        block = np.concatenate(self.pending) if len(self.pending) > 1 else self.pending[0]
        p = np.where(block["p"], np.int8(1), np.int8(-1))  # ON -> +1, OFF -> -1
        self.events.append(block["x"], block["y"], block["t"], p, source=self.path,
                           first_row=self.n_done, row_label="event")
        self.n_done += len(block)
        self.pending, self.n_pending = [], 0


def _decoder_error(exc: BaseException) -> bool:
    """Whether ``exc`` is the decoder refusing the file: its Rust panics reach Python as
    ``pyo3_runtime.PanicException``, a BaseException subclass that cannot be imported."""
    if isinstance(exc, (KeyboardInterrupt, SystemExit, GeneratorExit)):
        return False
    return (isinstance(exc, (RuntimeError, OSError, ValueError))
            or type(exc).__name__ == "PanicException")


def _one_line(exc: BaseException) -> str:
    text = " ".join(str(exc).split())
    return text[:200] or type(exc).__name__


@contextmanager
def _stderr_to_nothing() -> Iterator[None]:
    """Silence file descriptor 2 for a moment: a Rust panic in the decoder prints its message
    (and a backtrace) there before it reaches Python as an exception, which we report."""
    sys.stderr.flush()
    saved = os.dup(2)
    try:
        with open(os.devnull, "wb") as null:
            os.dup2(null.fileno(), 2)
        yield
    finally:
        os.dup2(saved, 2)
        os.close(saved)


def _open(readable: Path, path: Path | None = None) -> Any:
    """A decoder of ``readable``; its refusal is an InputError naming ``path``."""
    import aedat  # the Rust decoder, imported when a file is read (not by `tactile --help`)

    path = readable if path is None else path
    try:
        with _stderr_to_nothing():
            return aedat.Decoder(readable)
    except BaseException as exc:
        if not _decoder_error(exc):
            raise
        raise InputError(f"not a readable AEDAT4 file ({_one_line(exc)})", path=path) from None


def _packets(readable: Path, *, events_read: Callable[[], int],
             path: Path | None = None) -> Iterator[dict[str, Any]]:
    """The decoder's packets of ``readable``; a decoding error becomes an InputError naming
    ``path`` (default ``readable``)."""
    path = readable if path is None else path
    decoder = _open(readable, path)
    while True:
        try:
            packet = next(decoder)
        except StopIteration:
            return
        except BaseException as exc:
            if not _decoder_error(exc):
                raise
            raise InputError(f"AEDAT4 file is truncated or corrupt after {events_read()} events "
                             f"(decoder: {_one_line(exc)})", path=path) from None
        yield packet


def _packet_sizes(f: BinaryIO) -> Iterator[int]:
    """File bytes of each packet in order (header + payload), read from the 8-byte packet
    headers alone, so progress can count bytes; stops quietly at anything unexpected
    (the file data table at the end, or a damaged file the decoder will report)."""
    size = f.seek(0, 2)
    f.seek(0)
    if f.read(len(MAGIC)) != MAGIC:
        return
    head = f.read(4)
    if len(head) < 4:
        return
    (header_len,) = struct.unpack("<I", head)
    pos = len(MAGIC) + 4 + header_len
    yield pos  # the file header first
    while pos + 8 <= size:
        f.seek(pos)
        stream_id, n_bytes = struct.unpack("<iI", f.read(8))
        if stream_id < 0 or pos + 8 + n_bytes > size:
            return
        pos += 8 + n_bytes
        yield 8 + n_bytes


#: IOHeader ``compression`` values (dv-processing ``CompressionType``).
_COMPRESSION = {0: "none", 1: "lz4", 2: "lz4", 3: "zstd", 4: "zstd"}


def check_layout(path: Path) -> None:
    """Refuse a file whose bytes the packets and the file data table do not account for
    exactly: a file cut short (inside a packet or inside the closing data table) or one with
    bytes after its end. The decoder reads packets until the data, or the file, ends, so it
    reports neither. Reads the 8-byte packet headers and the table's frame headers only."""
    try:
        with open(path, "rb") as f:
            problem = _layout_problem(f)
    except OSError as exc:
        raise InputError(f"cannot read the AEDAT4 file ({_one_line(exc)})", path=path) from None
    if problem is not None:
        raise InputError(f"{problem}; re-export or re-copy the recording", path=path)


def _layout_problem(f: BinaryIO) -> str | None:
    size = f.seek(0, 2)
    f.seek(0)
    if f.read(len(MAGIC)) != MAGIC:
        return "not a readable AEDAT4 file (wrong magic number: no #!AER-DAT4.0 at its start)"
    head = f.read(4)
    if len(head) < 4:
        return "AEDAT4 file is cut short inside its header"
    (header_len,) = struct.unpack("<I", head)
    start = len(MAGIC) + 4 + header_len
    if start > size:
        return f"AEDAT4 file is cut short inside its header ({size} bytes, header ends at {start})"
    try:
        compression, table_pos, info = parse_io_header(f.read(header_len))
    except (struct.error, ValueError):
        return "AEDAT4 file header is damaged (its IOHeader cannot be parsed)"
    try:  # checked here: the decoder panics (or aborts the process) on some damaged headers
        ET.fromstring(info.decode("utf-8"))
    except (UnicodeDecodeError, ET.ParseError) as exc:
        return f"AEDAT4 file header is damaged (its XML description: {_one_line(exc)})"
    if table_pos >= 0 and not start <= table_pos <= size:
        return (f"AEDAT4 header puts the file data table at byte {table_pos}, outside the "
                f"file's packets (bytes {start}..{size}): the file is cut short or damaged")
    end = table_pos if table_pos >= 0 else size
    pos = start
    while pos < end:
        f.seek(pos)
        head = f.read(8)
        if len(head) < 8 or pos + 8 > end:
            return f"AEDAT4 file is cut short or damaged inside the packet at byte {pos}"
        stream_id, n_bytes = struct.unpack("<iI", head)
        if stream_id < 0 or pos + 8 + n_bytes > end:
            return (f"AEDAT4 file is cut short or damaged: the packet at byte {pos} runs past "
                    f"{'the file data table' if table_pos >= 0 else 'the end of the file'} "
                    f"(byte {end})")
        pos += 8 + n_bytes
    if table_pos < 0:
        return None
    kind = _COMPRESSION.get(compression)
    if kind is None:
        return f"AEDAT4 header names an unknown compression ({compression})"
    f.seek(table_pos)
    length = _frame_length(kind, f.read(size - table_pos))
    if length is None:
        return (f"the file data table at byte {table_pos} is damaged or cut short (the file "
                f"ends at byte {size})")
    if table_pos + length < size:
        return (f"{size - table_pos - length} bytes after the end of the file data table "
                f"(byte {table_pos + length}): trailing garbage, or two files joined")
    return None


def _frame_length(kind: str, buf: bytes) -> int | None:
    """Bytes of the one compressed frame (or size-prefixed flatbuffer) at the start of
    ``buf``, from its headers and block sizes alone; None when it is damaged or runs past
    the end of ``buf``."""
    try:
        if kind == "none":
            n = 4 + struct.unpack_from("<I", buf, 0)[0]
        elif kind == "lz4":
            n = _lz4_frame_length(buf)
        else:
            n = _zstd_frame_length(buf)
    except struct.error:
        return None
    return n if n is not None and n <= len(buf) else None


def _lz4_frame_length(buf: bytes) -> int | None:
    if buf[:4] != b"\x04\x22\x4d\x18" or len(buf) < 7:
        return None
    flg = buf[4]
    if flg >> 6 != 1:
        return None
    pos = 6 + (8 if flg & 0x08 else 0) + (4 if flg & 0x01 else 0) + 1  # FLG BD [size] [dict] HC
    while True:
        (block,) = struct.unpack_from("<I", buf, pos)
        pos += 4
        if block == 0:  # end mark
            return pos + (4 if flg & 0x04 else 0)
        pos += (block & 0x7FFFFFFF) + (4 if flg & 0x10 else 0)
        if pos > len(buf):
            return None


def _zstd_frame_length(buf: bytes) -> int | None:
    if buf[:4] != b"\x28\xb5\x2f\xfd" or len(buf) < 5:
        return None
    fhd = buf[4]
    single = (fhd >> 5) & 1
    fcs = (1 if single else 0, 2, 4, 8)[fhd >> 6]
    pos = 5 + (0 if single else 1) + (0, 1, 2, 4)[fhd & 3] + fcs
    while True:
        if pos + 3 > len(buf):
            return None
        header = int.from_bytes(buf[pos:pos + 3], "little")
        kind = (header >> 1) & 3
        if kind == 3:
            return None
        pos += 3 + (1 if kind == 1 else header >> 3)
        if header & 1:  # last block
            return pos + (4 if fhd & 0x04 else 0)
        if pos > len(buf):
            return None


def _header_attributes(path: Path) -> dict[int, dict[str, str]]:
    """Per stream id, the attributes of the XML description in the file header
    (``source``, ``originalOutputName``, ``compression``, ...); empty when absent."""
    try:
        with open(path, "rb") as f:
            if f.read(len(MAGIC)) != MAGIC:
                return {}
            (header_len,) = struct.unpack("<I", f.read(4))
            header = f.read(min(header_len, 1 << 20))
        match = re.search(rb"<dv.*?</dv>", header, re.DOTALL)
        if match is None:
            return {}
        root = ET.fromstring(match.group(0).decode("utf-8", errors="replace"))
    except (OSError, struct.error, ET.ParseError):
        return {}  # the name is a nicety; the decoder reports a broken file
    out: dict[int, dict[str, str]] = {}
    for node in root.iter("node"):
        parts = [p for p in (node.get("path") or "").split("/") if p]
        if len(parts) >= 2 and parts[-2] == "outInfo" and parts[-1].isdigit():
            values = out.setdefault(int(parts[-1]), {})
            for holder in (node, node.find("node[@name='info']")):
                if holder is None:
                    continue
                for attr in holder.findall("attr"):
                    if attr.get("key") and attr.text is not None:
                        values[attr.get("key")] = attr.text  # type: ignore[index]
    return out


class Aedat4Format(IngestFormat[Aedat4Options]):
    """AEDAT4 recordings of iniVation cameras, one trial per file (see the module docstring)."""

    name = "aedat4"
    title = "AEDAT4"
    summary = ("AEDAT4 files of iniVation cameras (DVXplorer, DAVIS): events, APS frames, IMU "
               "samples and triggers, one trial per file")
    suffixes = (".aedat4",)
    Options = Aedat4Options

    def sniff(self, path: Path) -> bool:
        if path.suffix.lower() == ".aedat4":
            return not path.is_dir()
        try:
            with open(path, "rb") as f:
                return f.read(len(MAGIC)) == MAGIC
        except OSError:
            return False

    def describe(self, path: Path, options: Aedat4Options) -> RecordingSummary:
        from .aedat4_describe import describe_aedat4, recording_summary

        return recording_summary(describe_aedat4(path), self)

    def read(self, inputs: Sequence[Path], options: Aedat4Options, writer: StoreWriter,
             progress: Progress) -> list[str]:
        return ingest_aedat4(inputs, options, writer, progress)


AEDAT4 = Aedat4Format()

__all__ = ["AEDAT4", "Aedat4Format", "Aedat4Options", "ingest_aedat4", "read_streams",
           "check_layout", "StreamInfo"]
