"""`tactile info FILE`"""

from __future__ import annotations

import json
import sys
from pathlib import Path
from typing import Annotated

import typer
from rich.console import Console
from rich.table import Table

from ..store.reader import FileSummary, summarize
from ._errors import run_guarded

#: Trials listed in the trials table; a longer file shows the first and last halves.
MAX_TRIALS_SHOWN = 40


def info_command(
    file: Annotated[Path, typer.Argument(help="A tactile HDF5 file (or a raw AEDAT4 file).",
                                         metavar="FILE", show_default=False)],
    as_json: Annotated[bool, typer.Option(
        "--json", help="Print the summary as JSON (every channel name and label value).")
    ] = False,
) -> None:
    """Print sensors (streams, rate, channels, units), trials, trial labels (trials per
    value), per-sample labels (samples per class) and splits of a tactile HDF5 file: what a
    train config names. Labels with many values are summarised; --json lists everything.
    A raw .aedat4 recording is read without writing anything: its streams (type, name,
    count, time span, size); other commands need it ingested first."""

    def body() -> None:
        from ..ingest.aedat4_describe import is_aedat4

        if is_aedat4(file):
            _aedat4(file, as_json)
            return
        summary = summarize(file)  # every read failure is one InputError naming the path
        if as_json:
            typer.echo(json.dumps(summary.as_dict(), indent=2))
            return
        console = Console(width=None if sys.stdout.isatty() else 150)
        console.print(
            f"[bold]{summary.file}[/] schema {summary.schema_version}, written by "
            f"tactile {summary.tool_version} at {summary.created_utc}, "
            f"{summary.n_sources} source file(s)", highlight=False
        )
        for table in (_sensors(summary), _trials(summary), *_labels(summary)):
            console.print(table)
        console.print(_splits(summary), highlight=False)

    run_guarded(body)


def _aedat4(file: Path, as_json: bool) -> None:
    from ..ingest.aedat4_describe import describe_aedat4

    summary = describe_aedat4(file)  # a damaged file is one InputError naming it
    if as_json:
        typer.echo(json.dumps(summary.as_dict(), indent=2))
        return
    console = Console(width=None if sys.stdout.isatty() else 150)
    console.print(f"[bold]{summary.file}[/] AEDAT4 recording, {summary.size_bytes:,} bytes, "
                  f"{len(summary.streams)} stream(s)", highlight=False)
    table = Table(title="Streams")
    for col in ("id", "type", "name", "camera", "count", "first t (us)", "span (s)",
                "resolution"):
        table.add_column(col)
    for s in summary.streams:
        count = f"{s.count:,} {s.unit}" if s.count is not None else "not readable"
        span = s.span_s
        table.add_row(str(s.stream_id), s.type, s.name, s.camera or "", count,
                      "" if s.t_first_us is None else str(s.t_first_us),
                      "" if span is None else f"{span:.6f}", s.resolution)
    console.print(table)
    console.print(summary.hint, highlight=False, soft_wrap=True)


def _sensors(summary: FileSummary) -> Table:
    table = Table(title="Sensors")
    for col in ("name", "kind", "streams", "rate (Hz)", "channels", "units", "geometry"):
        table.add_column(col)
    for s in summary.sensors:
        table.add_row(s.name, s.kind, ", ".join(s.streams), f"{s.sample_rate_hz:g}",
                      s.channels_brief, ", ".join(s.units), s.geometry)
    return table


def _trials(summary: FileSummary) -> Table:
    table = Table(title=f"Trials ({len(summary.trials)}, {summary.total_duration_s:.2f} s in all)")
    for col in ("trial", "duration (s)", "events", "streams (samples x channels)", "frames",
                "annotations", "labels"):
        table.add_column(col)
    trials = summary.trials
    half = MAX_TRIALS_SHOWN // 2
    shown = trials if len(trials) <= MAX_TRIALS_SHOWN else trials[:half] + trials[-half:]
    for t in shown:
        table.add_row(t.name, f"{t.duration_s:.3f}", f"{t.n_events:,}" if t.n_events else "",
                      ", ".join(f"{k} {v[0]}x{v[1]}" for k, v in t.streams.items()),
                      str(t.n_frames or ""), str(t.n_annotations or ""),
                      ", ".join(f"{k}={v}" for k, v in t.labels.items()))
    if len(shown) < len(trials):
        table.caption = f"{len(trials) - len(shown)} trials not shown; use --json for all"
    return table


def _labels(summary: FileSummary) -> list[Table]:
    tables = []
    trial_labels = summary.trial_labels
    if trial_labels:
        table = Table(title="Trial labels (trials per value)")
        table.add_column("label")
        table.add_column("values")
        for lc in trial_labels:
            table.add_row(lc.name, lc.brief())
        tables.append(table)
    if summary.sample_labels:
        table = Table(title="Per-sample labels (samples per class)")
        for col in ("stream", "label", "values"):
            table.add_column(col)
        for lc in summary.sample_labels:
            table.add_row(lc.stream, lc.name, lc.brief())
        tables.append(table)
    return tables


def _splits(summary: FileSummary) -> str:
    splits = summary.splits
    if set(splits) <= {""}:
        return f"splits: none assigned ({len(summary.trials)} trials)"
    return "splits: " + ", ".join(f"{k or 'none'} {v:,}" for k, v in splits.items())
