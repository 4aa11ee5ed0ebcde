"""`tactile info RAW` as text for people: a raw recording's
:class:`~tactile_cli.ingest.contract.RecordingSummary` as lines and
:class:`~tactile_cli.text_table.TextTable` objects (streams, trials, what is left out,
notes and the hint)."""

from __future__ import annotations

from collections.abc import Callable
from typing import TYPE_CHECKING

from ..text_table import TextTable, fixed, head_and_tail

if TYPE_CHECKING:
    from .contract import RecordingSummary

#: Trials listed in the trials table; a longer recording shows the first and last halves.
MAX_TRIALS_SHOWN = 40


def _streams(summary: RecordingSummary) -> TextTable:
    table = TextTable(["stream", "type", "count", "rate (Hz)", "jitter (ms)", "first (s)",
                       "span (s)", "resolution", "channels", "stamps repeated / out of order"],
                      title="Streams", left=10)
    for s in summary.streams:
        count = f"{s.count:,} {s.unit}" if s.count is not None else "not readable"
        stamps = ("" if s.repeated_stamps is None and s.out_of_order_stamps is None
                  else f"{s.repeated_stamps or 0:,} / {s.out_of_order_stamps or 0:,}")
        channels = ", ".join(s.channels[:6]) + (f", ... ({len(s.channels)})"
                                                 if len(s.channels) > 6 else "")
        table.rows.append([s.name, s.type, count, fixed(s.rate_hz, "g"),
                           fixed(None if s.jitter_s is None else s.jitter_s * 1e3, ".3g"),
                           fixed(s.t_first_s, ".6f"), fixed(s.span_s, ".6f"), s.resolution,
                           channels, stamps])
    return table


def _trials(summary: RecordingSummary) -> TextTable:
    table = TextTable(["trial", "source", "items", "duration (s)", "labels"], left=5,
                      title=f"Trials ({len(summary.trials)})")
    shown = head_and_tail(summary.trials, MAX_TRIALS_SHOWN)
    for t in shown:
        table.rows.append([t.name, t.source, ", ".join(f"{k} {v:,}" for k, v in t.counts.items()),
                           fixed(t.duration_s, ".3f"),
                           ", ".join(f"{k}={v}" for k, v in t.labels.items())])
    if len(shown) < len(summary.trials):
        table.caption = (f"{len(summary.trials) - len(shown)} trials not shown; the JSON "
                         "output lists all")
    return table


def recording_blocks(summary: RecordingSummary,
                     spell: Callable[[str], str] = str) -> list[str | TextTable]:
    """A line, the streams, the trials, what is left out, the notes and the hint
    (``spell``: turns the Python option names of notes and hint into a front end's
    spelling, e.g. the CLI's flags)."""
    head = (f"{summary.file} {summary.title} recording, {summary.size_bytes:,} bytes, "
            f"{len(summary.streams)} stream(s), {len(summary.trials)} trial(s)")
    return [head, _streams(summary), _trials(summary),
            *(f"left out: {line}" for line in summary.dropped),
            *(f"note: {spell(line)}" for line in summary.notes), spell(summary.hint)]


__all__ = ["MAX_TRIALS_SHOWN", "recording_blocks"]
