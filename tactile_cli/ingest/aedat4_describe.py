"""What a raw AEDAT4 file holds, read without writing anything (``tactile info FILE.aedat4``).

:func:`describe_aedat4` lists the streams of the file: per stream its id, type, output
name (the header's ``originalOutputName``), camera, count (events, frames, IMU samples,
triggers), first and last timestamp (camera microseconds) and, for events and frames, the
size in px. The file is checked and decoded as ``tactile ingest`` does (layout first, then
every packet through the ``aedat`` decoder), so a damaged or cut file is the same one-line
:class:`~tactile_cli.errors.InputError` naming it. Streams of a type the decoder does not
read (``POSE``, ``BBOX``, ...) are listed from the header without a count. Other commands
read tactile HDF5 files only: the summary carries the hint to ingest the file.
"""

from __future__ import annotations

import tempfile
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import InputError
from .aedat4_filter import KNOWN_TYPES
from .contract import IngestFormat, RecordingSummary, StreamSummary, TrialSummary

MAGIC = b"#!AER-DAT4.0\r\n"

#: decoder stream type -> (header type identifier, what one item is called)
_TYPES: dict[str, tuple[str, str]] = {"events": ("EVTS", "events"), "frame": ("FRME", "frames"),
                                      "imus": ("IMUS", "IMU samples"),
                                      "triggers": ("TRIG", "triggers")}


@dataclass
class Aedat4Stream:
    """One stream of an AEDAT4 file. type: ``events``, ``frame``, ``imus``, ``triggers``,
    or the header's identifier (``POSE``) for a type the decoder does not read; count,
    t_first_us and t_last_us are None for those (and the times for an empty stream)."""

    stream_id: int
    type: str
    type_identifier: str
    name: str
    camera: str | None
    readable: bool
    count: int | None = None
    unit: str = ""  # what count counts: events, frames, IMU samples, triggers
    t_first_us: int | None = None
    t_last_us: int | None = None
    width_px: int | None = None
    height_px: int | None = None

    @property
    def span_s(self) -> float | None:
        """Seconds from the first to the last timestamp (None without timestamps)."""
        if self.t_first_us is None or self.t_last_us is None:
            return None
        return (self.t_last_us - self.t_first_us) * 1e-6

    @property
    def resolution(self) -> str:
        return f"{self.width_px}x{self.height_px} px" if self.width_px and self.height_px else ""

    def as_dict(self) -> dict[str, Any]:
        return {**asdict(self), "span_s": self.span_s}


@dataclass
class Aedat4Summary:
    """The streams of one raw AEDAT4 file and what to do with it."""

    file: str
    size_bytes: int
    streams: list[Aedat4Stream] = field(default_factory=list)

    @property
    def hint(self) -> str:
        return (f"a raw AEDAT4 recording, not a tactile HDF5 file: other commands need it "
                f"ingested (`tactile ingest {self.file} --out FILE.h5`)")

    def as_dict(self) -> dict[str, Any]:
        return {"file": self.file, "format": "aedat4", "size_bytes": self.size_bytes,
                "streams": [s.as_dict() for s in self.streams], "hint": self.hint}


def is_aedat4(path: str | Path) -> bool:
    """Whether ``path`` is a file named ``*.aedat4`` or starting with the AEDAT4 magic."""
    path = Path(path)
    if not path.is_file():
        return False
    if path.suffix.lower() == ".aedat4":
        return True
    try:
        with open(path, "rb") as f:
            return f.read(len(MAGIC)) == MAGIC
    except OSError:
        return False


def describe_aedat4(path: str | Path) -> Aedat4Summary:
    """The streams of the AEDAT4 file ``path`` (see the module docstring); reads it whole,
    writes nothing but a temporary copy when it has streams the decoder cannot read."""
    from .aedat4_filter import copy_without_streams, stream_types
    from .events_aedat4 import _header_attributes, check_layout

    path = Path(path)
    if not path.is_file():
        raise InputError("not a file (a folder?); give an .aedat4 file", path=path)
    check_layout(path)
    types = stream_types(path)
    unknown = {sid: kind for sid, kind in types.items() if kind not in KNOWN_TYPES}
    attrs = _header_attributes(path)
    streams: dict[int, Aedat4Stream] = {}
    if not unknown:
        _count(path, path, streams, attrs)
    elif len(unknown) < len(types):
        with tempfile.TemporaryDirectory(prefix="tactile-aedat4-") as tmp:
            readable = copy_without_streams(path, set(unknown), Path(tmp) / path.name)
            _count(path, readable, streams, attrs)
    for sid, kind in unknown.items():
        extra = attrs.get(sid, {})
        streams[sid] = Aedat4Stream(sid, kind or "(none)", kind, _name(extra, kind),
                                    extra.get("source"), readable=False)
    return Aedat4Summary(str(path), path.stat().st_size,
                         [streams[sid] for sid in sorted(streams)])


def _name(attrs: dict[str, str], fallback: str) -> str:
    return attrs.get("originalOutputName") or fallback


def _count(path: Path, readable: Path, streams: dict[int, Aedat4Stream],
           attrs: dict[int, dict[str, str]]) -> None:
    """Fill ``streams`` with the readable streams of ``readable`` (errors name ``path``)."""
    from .events_aedat4 import _packets, read_streams

    for sid, info in read_streams(readable).items():
        ident, unit = _TYPES.get(info.type, (info.type, "items"))
        sized = info.type in ("events", "frame") and info.width_px and info.height_px
        streams[sid] = Aedat4Stream(sid, info.type, ident, _name(attrs.get(sid, {}), info.type),
                                    info.camera, readable=True, count=0, unit=unit,
                                    width_px=int(info.width_px) if sized else None,
                                    height_px=int(info.height_px) if sized else None)
    n_events = [0]
    for packet in _packets(readable, events_read=lambda: n_events[0], path=path):
        stream = streams.get(int(packet.get("stream_id", -1)))
        if stream is None:
            continue
        if "frame" in packet:
            t = np.array([int(packet["frame"]["t"])], dtype=np.int64)
        else:
            rows = packet.get(stream.type)
            if rows is None or not len(rows):
                continue
            t = np.asarray(rows["t"], dtype=np.int64)
            if stream.type == "events":
                n_events[0] += len(t)
        stream.count = (stream.count or 0) + len(t)
        lo, hi = int(t.min()), int(t.max())
        stream.t_first_us = lo if stream.t_first_us is None else min(stream.t_first_us, lo)
        stream.t_last_us = hi if stream.t_last_us is None else max(stream.t_last_us, hi)


def recording_summary(summary: Aedat4Summary, fmt: IngestFormat) -> RecordingSummary:
    """The AEDAT4 summary in the shape every format's ``describe`` returns (the AEDAT4
    fields ``stream_id``, ``type_identifier``, ``camera``, ``t_first_us`` and ``t_last_us``
    kept beside the common ones)."""
    streams, dropped = [], []
    for s in summary.streams:
        streams.append(StreamSummary(
            name=s.name, type=s.type, count=s.count, unit=s.unit, readable=s.readable,
            t_first_s=None if s.t_first_us is None else s.t_first_us * 1e-6,
            t_last_s=None if s.t_last_us is None else s.t_last_us * 1e-6, span_s=s.span_s,
            width_px=s.width_px, height_px=s.height_px,
            extra={"stream_id": s.stream_id, "type_identifier": s.type_identifier,
                   "camera": s.camera, "t_first_us": s.t_first_us, "t_last_us": s.t_last_us}))
        if not s.readable:
            dropped.append(f"stream {s.stream_id} {s.name!r} of type {s.type_identifier!r}: the "
                           "decoder does not read it; an ingest refuses the file unless "
                           "`skip_unknown=True` leaves it out")
    readable = [s for s in summary.streams if s.readable]
    spans = [s.span_s for s in readable if s.span_s is not None]
    path = Path(summary.file)
    trial = TrialSummary(name=path.stem, source=summary.file,
                         counts={s.name: int(s.count or 0) for s in readable},
                         duration_s=max(spans) if spans else None)
    return RecordingSummary(file=summary.file, format=fmt.name, title=fmt.title,
                            size_bytes=summary.size_bytes, streams=streams, trials=[trial],
                            dropped=dropped)


__all__ = ["Aedat4Stream", "Aedat4Summary", "describe_aedat4", "is_aedat4",
           "recording_summary"]
