"""`tactile accumulate` results as text for people: one row per trial (with segmentation:
the regions found and the share of bins as annotated), the segmentation summary and the
files written, as :class:`~tactile_cli.text_table.TextTable` and lines."""

from __future__ import annotations

import math
from pathlib import Path
from typing import TYPE_CHECKING

from ..text_table import TextTable

if TYPE_CHECKING:
    from .recording import FileAccumulation


def _seconds(value: float | None) -> str:
    return "" if value is None or not math.isfinite(value) else f"{value:.3f}"


def accumulation_blocks(run: FileAccumulation, *, title: str,
                        plot: Path | None = None) -> list[str | TextTable]:
    """The trials table, skipped trials, the segmentation lines and what was written
    (``plot``: the figure folder named in the last line)."""
    columns = ["trial", "bins", "events", "positive", "negative", "outside"]
    if run.segmented:
        columns += ["status", "press (s)", "slip (s)", "release (s)", "bins as annotated"]
    table = TextTable(columns, title=title, text=(6,) if run.segmented else ())
    for acc in run.trials:
        c = acc.counts
        row = [acc.trial, str(c.n_bins), f"{c.n_events:,}", f"{int(c.positive.sum()):,}",
               f"{int(c.negative.sum()):,}", f"{c.n_outside:,}"]
        if acc.segmentation is not None:
            seg, score = acc.segmentation, acc.score
            row += [seg.status, _seconds(seg.press_start_s), _seconds(seg.slip_start_s),
                    _seconds(seg.release_start_s),
                    "" if score is None else f"{100 * score.bin_accuracy:.1f} %"]
        table.rows.append(row)
    blocks: list[str | TextTable] = [table]
    summary = run.summary()
    if run.skipped:
        blocks.append(f"skipped {len(run.skipped)} trial(s) without events")
    if run.segmented:
        statuses = ", ".join(f"{k} {v}" for k, v in sorted(summary["segmentation_status"]
                                                            .items()))
        line = f"segmentation: {statuses}"
        if summary["mean_bin_accuracy"] is not None:
            line += (f"; bins as annotated: mean {100 * summary['mean_bin_accuracy']:.2f} %,"
                     f" lowest {100 * summary['min_bin_accuracy']:.2f} %")
        blocks.append(line)
        blocks += [f"  {acc.trial}: {acc.segmentation.status}: {acc.segmentation.message}"
                   for acc in run.trials
                   if acc.segmentation is not None and acc.segmentation.message]
    blocks += [f"wrote {path}" for path in run.written]
    if plot is not None:
        blocks.append(f"wrote {len(run.figures)} figure(s) to {plot}")
    return blocks


__all__ = ["accumulation_blocks"]
