"""The trials of a robot recording: the whole recording, the spans a marker topic opens and
closes, or the time ranges of a CSV (``trials_from``).

- **Whole recording** (default): one trial named after the recording (the bag's stem, the
  ROS 2 bag folder's name), its time 0 at the recording's first logged message.
- **Marker topic** (``trials.marker`` in the mapping): a ``std_msgs/Bool`` opens a trial
  with ``true`` and closes it with ``false``; a ``std_msgs/String`` opens one with the
  ``start`` value (``start:NAME`` also names it) and closes it with the ``stop`` value. A
  trial still open at the end closes after the last message; an open while a trial is open
  closes the one before. Trials are named ``<recording>_<k>`` (k from 1) unless named.
- **CSV of time ranges** (``trials_from``): columns ``start_s`` and ``end_s`` (seconds from
  the recording's first logged message), optional ``trial`` (the name); every other column
  is a label of that trial (numbers as numbers).

Each trial's time 0 is its start; the times are on the recording's log clock (ns since the
Unix epoch for ROS), so a message belongs to the trial whose ``[start, end)`` holds its stamp.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

from ..config_file import read_text
from ..errors import InputError
from .csv_records import csv_records
from .robot_recording import RobotRecording, short_type
from .topic_mapping import Marker

#: The end of a trial that runs to the end of the recording.
OPEN_END_NS = 2**63 - 1


@dataclass
class TrialSpan:
    """One trial: name, [start_ns, end_ns) on the recording's clock, labels; takes_all: the
    whole recording (every message belongs, even one stamped before the first log time)."""

    name: str
    start_ns: int
    end_ns: int
    labels: dict[str, str | int | float] = field(default_factory=dict)
    takes_all: bool = False


def recording_name(path: Path) -> str:
    """The trial name of a whole recording: the file's stem or the bag folder's name."""
    return path.resolve().name if path.is_dir() else path.stem


def whole_recording(rec: RobotRecording, start_ns: int) -> list[TrialSpan]:
    return [TrialSpan(recording_name(rec.path), start_ns, OPEN_END_NS, takes_all=True)]


def marker_trials(rec: RobotRecording, marker: Marker, start_ns: int) -> tuple[list[TrialSpan],
                                                                                 list[str]]:
    """The trials a marker topic opens and closes, and notes on stray markers."""
    if marker.topic not in rec.topics:
        raise InputError(f"the marker topic {marker.topic} is not in the recording (topics: "
                         f"{', '.join(rec.topics)})", path=rec.path)
    msgtype = short_type(rec.topics[marker.topic].msgtype)
    if msgtype not in ("std_msgs/String", "std_msgs/Bool"):
        raise InputError(f"the marker topic {marker.topic} holds {msgtype}; a marker is a "
                         "std_msgs/String or std_msgs/Bool", path=rec.path)
    decode = rec.decoder(marker.topic)
    base = recording_name(rec.path)
    spans: list[TrialSpan] = []
    open_at: tuple[int, str | None] | None = None
    stray = 0
    for _, t_ns, raw in rec.raw_messages([marker.topic]):
        value = decode(raw).data
        if msgtype == "std_msgs/Bool":
            opens, closes, name = bool(value), not bool(value), None
        else:
            text = str(value).strip()
            opens = text == marker.start or text.startswith(marker.start + ":")
            name = (text.split(":", 1)[1].strip() or None) if opens and ":" in text else None
            closes = text == marker.stop
        if opens:
            if open_at is not None:
                spans.append(_span(base, len(spans), open_at, t_ns))
            open_at = (t_ns, name)
        elif closes:
            if open_at is None:
                stray += 1
                continue
            spans.append(_span(base, len(spans), open_at, t_ns))
            open_at = None
        else:
            stray += 1
    if open_at is not None:
        spans.append(_span(base, len(spans), open_at, OPEN_END_NS))
    notes = []
    if stray:
        notes.append(f"marker topic {marker.topic}: {stray} message(s) neither opened a trial "
                     "nor closed an open one (ignored)")
    if not spans:
        raise InputError(f"the marker topic {marker.topic} opens no trial ({msgtype}: "
                         + ("true opens, false closes" if msgtype == "std_msgs/Bool" else
                            f"{marker.start!r} opens, {marker.stop!r} closes") + ")",
                         path=rec.path)
    return spans, notes


def _span(base: str, k: int, open_at: tuple[int, str | None], end_ns: int) -> TrialSpan:
    start, name = open_at
    return TrialSpan(name or f"{base}_{k + 1}", start, end_ns)


def csv_trials(path: Path, rec: RobotRecording, start_ns: int) -> list[TrialSpan]:
    """The trials of a CSV of time ranges (module docstring)."""
    rows = [(line, cells) for line, cells in csv_records(read_text(path, "trial ranges"), path)
            if cells and any(c.strip() for c in cells)]
    if not rows:
        raise InputError("is empty; write a header start_s,end_s[,trial,...] and one row per "
                         "trial", path=path)
    header = [c.strip() for c in rows[0][1]]
    for needed in ("start_s", "end_s"):
        if needed not in header:
            raise InputError(f"has no {needed} column (header: {','.join(header)}); the columns "
                             "are start_s,end_s (seconds from the recording's first message), "
                             "optional trial, then labels", path=path, where="line 1")
    base = recording_name(rec.path)
    spans = []
    for k, (line, cells) in enumerate(rows[1:]):
        if len(cells) != len(header):
            raise InputError(f"has {len(cells)} columns, expected {len(header)} like the header",
                             path=path, where=f"line {line}")
        row = dict(zip(header, (c.strip() for c in cells), strict=True))
        try:
            start_s, end_s = float(row.pop("start_s")), float(row.pop("end_s"))
        except ValueError:
            raise InputError("start_s and end_s must be numbers of seconds", path=path,
                             where=f"line {line}") from None
        if not end_s > start_s:
            raise InputError(f"end_s ({end_s}) must be after start_s ({start_s})", path=path,
                             where=f"line {line}")
        name = row.pop("trial", "") or f"{base}_{k + 1}"
        labels = {key: _number_or_text(v) for key, v in row.items()}
        spans.append(TrialSpan(name, start_ns + round(start_s * 1e9),
                               start_ns + round(end_s * 1e9), labels))
    spans.sort(key=lambda s: s.start_ns)
    for a, b in zip(spans, spans[1:], strict=False):
        if b.start_ns < a.end_ns:
            raise InputError(f"trials {a.name} and {b.name} overlap; give each message one trial",
                             path=path)
    if not spans:
        raise InputError("has a header but no trial rows", path=path)
    return spans


def _number_or_text(value: str) -> str | int | float:
    for cast in (int, float):
        try:
            return cast(value)
        except ValueError:
            pass
    return value


__all__ = ["OPEN_END_NS", "TrialSpan", "csv_trials", "marker_trials", "recording_name",
           "whole_recording"]
