"""`tactile info FILE`"""

from __future__ import annotations

import json
import sys
from pathlib import Path
from typing import Annotated

import typer
from rich.console import Console
from rich.table import Table

from ..store.reader import summarize
from ._errors import run_guarded


def info_command(
    file: Annotated[Path, typer.Argument(help="A tactile HDF5 file.", show_default=False)],
    as_json: Annotated[bool, typer.Option("--json", help="Print the summary as JSON.")] = False,
) -> None:
    """Print sensors, trials, label counts and durations of a tactile HDF5 file."""

    def body() -> None:
        summary = summarize(file)  # every read failure is one InputError naming the path
        if as_json:
            typer.echo(json.dumps(summary.as_dict(), indent=2))
            return
        console = Console(width=None if sys.stdout.isatty() else 150)
        console.print(
            f"[bold]{summary.file}[/] schema {summary.schema_version}, written by "
            f"tactile {summary.tool_version} at {summary.created_utc}, "
            f"{summary.n_sources} source file(s)"
        )
        sensors = Table(title="Sensors")
        for col in ("name", "kind", "rate (Hz)", "channels", "geometry", "units"):
            sensors.add_column(col)
        for s in summary.sensors:
            sensors.add_row(
                s.name,
                s.kind,
                f"{s.sample_rate_hz:g}",
                str(s.n_channels),
                s.geometry,
                ", ".join(s.units),
            )
        console.print(sensors)
        trials = Table(
            title=f"Trials ({len(summary.trials)}, {summary.total_duration_s:.2f} s in all)"
        )
        for col in (
            "trial",
            "duration (s)",
            "events",
            "streams (samples x channels)",
            "frames",
            "labels",
        ):
            trials.add_column(col)
        shown = (
            summary.trials
            if len(summary.trials) <= 40
            else summary.trials[:20] + summary.trials[-20:]
        )
        for t in shown:
            streams = ", ".join(f"{k} {v[0]}x{v[1]}" for k, v in t.streams.items())
            labels = ", ".join(f"{k}={v}" for k, v in t.labels.items())
            trials.add_row(
                t.name,
                f"{t.duration_s:.3f}",
                f"{t.n_events:,}" if t.n_events else "",
                streams,
                str(t.n_frames or ""),
                labels,
            )
        if len(shown) < len(summary.trials):
            trials.caption = (
                f"{len(summary.trials) - len(shown)} trials not shown; use --json for all"
            )
        console.print(trials)
        counts = Table(title="Label counts (trials)")
        counts.add_column("label")
        counts.add_column("values")
        for key, values in summary.label_counts.items():
            counts.add_row(key, ", ".join(f"{v}: {n}" for v, n in values.items()))
        console.print(counts)

    run_guarded(body)
