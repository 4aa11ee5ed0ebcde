"""`tactile info FILE` as text for people: a tactile HDF5 file's
:class:`~tactile_cli.store.reader.FileSummary` as lines and
:class:`~tactile_cli.text_table.TextTable` objects (sensors, trials, labels, splits)."""

from __future__ import annotations

from typing import TYPE_CHECKING

from ..text_table import TextTable, head_and_tail

if TYPE_CHECKING:
    from .reader import FileSummary

#: Trials listed in the trials table; a longer file shows the first and last halves.
MAX_TRIALS_SHOWN = 40


def _sensors(summary: FileSummary) -> TextTable:
    table = TextTable(["name", "kind", "streams", "rate (Hz)", "channels", "units", "geometry"],
                      title="Sensors", left=7)
    for s in summary.sensors:
        table.rows.append([s.name, s.kind, ", ".join(s.streams), f"{s.sample_rate_hz:g}",
                           s.channels_brief, ", ".join(s.units), s.geometry])
    return table


def _trials(summary: FileSummary) -> TextTable:
    table = TextTable(["trial", "duration (s)", "events", "streams (samples x channels)",
                       "frames", "annotations", "labels"], left=7,
                      title=f"Trials ({len(summary.trials)}, {summary.total_duration_s:.2f} s "
                      "in all)")
    shown = head_and_tail(summary.trials, MAX_TRIALS_SHOWN)
    for t in shown:
        table.rows.append([t.name, f"{t.duration_s:.3f}", f"{t.n_events:,}" if t.n_events else "",
                           ", ".join(f"{k} {v[0]}x{v[1]}" for k, v in t.streams.items()),
                           str(t.n_frames or ""), str(t.n_annotations or ""),
                           ", ".join(f"{k}={v}" for k, v in t.labels.items())])
    if len(shown) < len(summary.trials):
        table.caption = (f"{len(summary.trials) - len(shown)} trials not shown; the JSON "
                         "output lists all")
    return table


def _labels(summary: FileSummary) -> list[TextTable]:
    tables = []
    if summary.trial_labels:
        tables.append(TextTable(["label", "values"], title="Trial labels (trials per value)",
                                left=2, rows=[[lc.name, lc.brief()]
                                              for lc in summary.trial_labels]))
    if summary.sample_labels:
        tables.append(TextTable(["stream", "label", "values"], left=3,
                                title="Per-sample labels (samples per class)",
                                rows=[[lc.stream, lc.name, lc.brief()]
                                      for lc in summary.sample_labels]))
    return tables


def _splits(summary: FileSummary) -> str:
    splits = summary.splits
    if set(splits) <= {""}:
        return f"splits: none assigned ({len(summary.trials)} trials)"
    return "splits: " + ", ".join(f"{k or 'none'} {v:,}" for k, v in splits.items())


def file_blocks(summary: FileSummary) -> list[str | TextTable]:
    """The file line, the sensors, trials and label tables, and the splits line."""
    head = (f"{summary.file} schema {summary.schema_version}, written by tactile "
            f"{summary.tool_version} at {summary.created_utc}, {summary.n_sources} source "
            "file(s)")
    return [head, _sensors(summary), _trials(summary), *_labels(summary), _splits(summary)]


__all__ = ["MAX_TRIALS_SHOWN", "file_blocks"]
