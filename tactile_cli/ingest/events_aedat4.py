"""AEDAT4 event files as iniVation cameras (DVXplorer, DAVIS) and DV software write them.

Decoding is done by the maintained ``aedat`` package (its Rust decoder handles the LZ4 and
Zstd packet compression); this module streams its packets into the store. One trial per
input file (named after the file stem) holds the file's polarity-event stream: ``t`` in
microseconds as recorded (absolute, with the camera's time offset applied by the
recorder), ``x``/``y`` in pixels, and the ON/OFF flag stored as +1/-1.

What is ingested and what is not:

- the event stream, with the sensor size written in the file (``--width``/``--height``, if
  given, must agree with it);
- the sensor is named after the camera (the ``source`` attribute of the stream, e.g.
  ``DVXplorer_DXB00010``) unless ``--sensor`` names it;
- the trial's time 0 is its first event (events attribute ``t_origin_us``);
- IMU, trigger and frame streams are ignored (their packets are skipped);
- a file with several event streams is refused, since a trial holds one event stream.

Packets are gathered into chunks of ``IngestOptions.chunk_events`` events before they are
checked and appended, so memory stays bounded. Progress counts bytes of the file.
"""

from __future__ import annotations

import re
import struct
import xml.etree.ElementTree as ET
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, BinaryIO

import aedat
import numpy as np

from ..errors import InputError
from ..progress import Progress
from ..store.writer import EventAppender, StoreWriter
from . import IngestOptions
from .events_table import DEFAULT_SENSOR, event_sensor

MAGIC = b"#!AER-DAT4.0\r\n"


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


def ingest_aedat4(inputs: list[Path], writer: StoreWriter, options: IngestOptions,
                  progress: Progress) -> None:
    """Add one trial per AEDAT4 file: its polarity events, chunk by chunk."""
    for path in inputs:
        if not path.is_file():
            raise InputError("not a file (a folder?); give .aedat4 files", path=path)
    progress.start(sum(p.stat().st_size for p in inputs), "AEDAT4 events")
    for path in inputs:
        _ingest_file(path, writer, options, progress)
    progress.finish()


def read_streams(path: Path) -> dict[int, StreamInfo]:
    """The streams of an AEDAT4 file: decoder's stream table plus the header's attributes."""
    decoder = _open(path)
    attrs = _header_attributes(path)
    streams = {}
    for sid, info in decoder.id_to_stream().items():
        streams[int(sid)] = StreamInfo(int(sid), str(info.get("type")), info.get("width"),
                                       info.get("height"), attrs.get(int(sid), {}))
    return streams


def _ingest_file(path: Path, writer: StoreWriter, options: IngestOptions,
                 progress: Progress) -> None:
    streams = read_streams(path)
    event_streams = [s for s in streams.values() if s.type == "events"]
    if not event_streams:
        found = ", ".join(sorted({s.type for s in streams.values()})) or "no streams"
        raise InputError(f"no event stream in the file (found: {found})", path=path)
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
    name = options.sensor_name or stream.camera or DEFAULT_SENSOR
    described = f"iniVation {stream.camera}" if stream.camera else "AEDAT4 event camera"
    sensor = event_sensor(writer, name, width_px=width, height_px=height, source=path,
                          description=f"{described}, AEDAT4 event stream {stream.stream_id}")
    source = writer.add_source(path)
    events = writer.trial(path.stem, sources=[source]).events(sensor)
    gather = _Gather(events, path, max(1, options.chunk_events))
    with open(path, "rb") as raw:
        sizes = _packet_sizes(raw)
        progress.advance(next(sizes, 0))  # the file header
        for packet in _packets(path, events_read=gather.seen):
            progress.advance(next(sizes, 0))
            if packet.get("stream_id") == stream.stream_id and "events" in packet:
                gather.add(packet["events"])  # IMU, trigger and frame packets are skipped
    gather.flush()
    # camera clocks count from an arbitrary epoch: the trial starts at its first event
    if events.close(t_origin_us=events.t_first) == 0:
        raise InputError(f"event stream {stream.stream_id} holds no events", path=path)


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


def _open(path: Path) -> Any:
    try:
        return aedat.Decoder(path)
    except (RuntimeError, OSError, ValueError) as exc:
        raise InputError(f"not a readable AEDAT4 file ({exc})", path=path) from None


def _packets(path: Path, *, events_read: Callable[[], int]) -> Iterator[dict[str, Any]]:
    """The decoder's packets; a decoding error becomes an InputError naming the file."""
    decoder = _open(path)
    while True:
        try:
            packet = next(decoder)
        except StopIteration:
            return
        except (RuntimeError, OSError, ValueError) as exc:
            raise InputError(f"AEDAT4 file is truncated or corrupt after {events_read()} events "
                             f"(decoder: {exc})", path=path) from None
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


__all__ = ["ingest_aedat4", "read_streams", "StreamInfo"]
