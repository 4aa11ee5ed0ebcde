"""`tactile accumulate FILE`"""

from __future__ import annotations

import json
import math
import sys
from pathlib import Path
from typing import TYPE_CHECKING, Annotated

import typer
from rich.console import Console
from rich.table import Table

from ..vocabulary import BIN_S
from ._errors import Flag, run_guarded, seconds_as_ms
from .progress import ProgressOption, RichProgress

if TYPE_CHECKING:
    from ..events.recording import FileAccumulation

#: How this command spells the library arguments its errors name (see ``_errors.to_flags``).
FLAGS: dict[str, Flag] = {
    "bin_s": ("--bin-ms", seconds_as_ms),
    "smooth_bins": "--smooth",
    "out": "--out",
    "csv": "--csv",
    "plot": "--plot",
}


def _fmt_s(value: float | None) -> str:
    return "" if value is None or not math.isfinite(value) else f"{value:.3f}"


def _print(run: FileAccumulation, *, title: str, plot: Path | None) -> None:
    """One row per trial (with --segment: the regions found and the share of bins as
    annotated), the segmentation summary and the files written."""
    console = Console(width=None if sys.stdout.isatty() else 160)
    table = Table(title=title)
    columns = ["trial", "bins", "events", "positive", "negative", "outside"]
    if run.segmented:
        columns += ["status", "press (s)", "slip (s)", "release (s)", "bins as annotated"]
    for col in columns:
        table.add_column(col, justify="left" if col in ("trial", "status") else "right")
    for acc in run.trials:
        c = acc.counts
        row = [acc.trial, str(c.n_bins), f"{c.n_events:,}", f"{int(c.positive.sum()):,}",
               f"{int(c.negative.sum()):,}", f"{c.n_outside:,}"]
        if acc.segmentation is not None:
            seg, score = acc.segmentation, acc.score
            row += [seg.status, _fmt_s(seg.press_start_s), _fmt_s(seg.slip_start_s),
                    _fmt_s(seg.release_start_s),
                    "" if score is None else f"{100 * score.bin_accuracy:.1f} %"]
        table.add_row(*row)
    console.print(table)
    summary = run.summary()
    if run.skipped:
        console.print(f"skipped {len(run.skipped)} trial(s) without events")
    if run.segmented:
        statuses = ", ".join(f"{k} {v}" for k, v in sorted(summary["segmentation_status"]
                                                            .items()))
        line = f"segmentation: {statuses}"
        if summary["mean_bin_accuracy"] is not None:
            line += (f"; bins as annotated: mean {100 * summary['mean_bin_accuracy']:.2f} %,"
                     f" lowest {100 * summary['min_bin_accuracy']:.2f} %")
        console.print(line)
        for acc in run.trials:
            if acc.segmentation is not None and acc.segmentation.message:
                console.print(f"  {acc.trial}: {acc.segmentation.status}: "
                              f"{acc.segmentation.message}", highlight=False)
    for path in run.written:
        console.print(f"wrote {path}", highlight=False)
    if plot is not None:
        console.print(f"wrote {len(run.figures)} figure(s) to {plot}", highlight=False)


def accumulate_command(
    file: Annotated[
        Path, typer.Argument(help="A tactile HDF5 file with event trials.", metavar="FILE",
                             show_default=False)
    ],
    trial: Annotated[
        list[str] | None,
        typer.Option("--trial", "-t", help="Trial to accumulate; repeatable (default: every "
                     "trial with events).", metavar="TRIAL", show_default=False),
    ] = None,
    bin_ms: Annotated[
        float, typer.Option("--bin-ms", min=0.001, help="Bin width in ms (paper: 20).")
    ] = BIN_S * 1000,
    smooth: Annotated[
        int, typer.Option("--smooth", min=1, help="Moving-average window in bins (odd).")
    ] = 5,
    segment: Annotated[
        bool, typer.Option("--segment", help="Find the approach/press/slip/release regions.")
    ] = False,
    as_json: Annotated[bool, typer.Option("--json", help="Print the results as JSON.")] = False,
    csv_out: Annotated[
        Path | None,
        typer.Option("--csv", help="Write one row per bin (counts, smoothed net, actions).",
                     metavar="FILE", show_default=False),
    ] = None,
    out: Annotated[
        Path | None,
        typer.Option("--out", "-o", help="Write the count streams to a new HDF5 file.",
                     metavar="FILE", show_default=False),
    ] = None,
    plot: Annotated[
        Path | None,
        typer.Option("--plot", help="Folder for one Fig. 10-style PNG per trial (created).",
                     metavar="FOLDER", show_default=False),
    ] = None,
    overwrite: Annotated[bool, typer.Option(help="Replace existing --out/--csv files.")] = False,
    progress: ProgressOption = None,
) -> None:
    """Count events per polarity in fixed bins (20 ms), smooth the net count and, with
    --segment, find each trial's approach, press, slip and release regions (paper 000,
    sec. 4.2, Fig. 10). Prints one row per trial; with annotations in the file, the share
    of bins whose detected action matches them.
    """

    def body() -> None:
        # imported here: the library pulls in the FOS package, which `tactile --help` skips
        from ..events.recording import accumulate_file

        with RichProgress(enabled=progress) as bar:
            run = accumulate_file(file, trials=trial or None, bin_s=bin_ms / 1000.0,
                                  smooth_bins=smooth, segment=segment, out=out, csv=csv_out,
                                  plot=plot, overwrite=overwrite, progress=bar)
        if as_json:
            typer.echo(json.dumps(run.as_dict(), indent=2, allow_nan=False))
        else:
            _print(run, title=f"{file}: {bin_ms:g} ms bins, moving average of {smooth}",
                   plot=plot)

    run_guarded(body, flags=FLAGS)
