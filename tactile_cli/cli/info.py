"""`tactile info FILE` (a tactile HDF5 file) and `tactile info RAW` (a raw recording of any
format `tactile ingest` reads, described read-only)"""

from __future__ import annotations

import json
import sys
from pathlib import Path
from typing import TYPE_CHECKING, Annotated

import typer
from rich.console import Console
from rich.table import Table

from ..ingest import describe_recording, parse_options, raw_format
from ..store.reader import FileSummary, summarize
from ._errors import Flag, run_guarded, to_flags
from ._ingest_flags import OPTION_FLAGS

if TYPE_CHECKING:
    from ..ingest import RecordingSummary

#: Trials listed in the trials table; a longer file shows the first and last halves.
MAX_TRIALS_SHOWN = 40
#: How this command spells the library arguments its errors name.
FLAGS: dict[str, Flag] = {"format": "--format", "mapping": "--mapping", "options": "--option",
                          "json": "--json"}


def info_command(
    file: Annotated[Path, typer.Argument(
        help="A tactile HDF5 file, or a raw recording of any format tactile ingest reads "
        "(a file or a folder).", metavar="FILE", show_default=False)],
    fmt: Annotated[str, typer.Option(
        "--format", "-f", help="Raw recordings: their format (default auto: told from the "
        "input; see tactile ingest --help).", metavar="NAME")] = "auto",
    mapping: Annotated[Path | None, typer.Option(
        help="Raw sensor CSVs: the YAML mapping to describe them with (streams, rates, "
        "stamps, columns left out); without it their columns are listed.", metavar="FILE")
    ] = None,
    option: Annotated[list[str] | None, typer.Option(
        "--option", "-O", help="Raw recordings: a format option by its name, KEY=VALUE "
        "(repeatable; see tactile ingest --help).", metavar="KEY=VALUE")] = None,
    as_json: Annotated[bool, typer.Option(
        "--json", help="Print the summary as JSON (every channel name and label value).")
    ] = False,
) -> None:
    """Print sensors (streams, rate, channels, units), trials, trial labels (trials per
    value), per-sample labels (samples per class) and splits of a tactile HDF5 file: what a
    train config names. Labels with many values are summarised; --json lists everything.
    A raw recording of any format tactile ingest reads (AEDAT4, event CSV/NPY, accelerometer
    tree, sensor CSVs with --mapping, image folders) is read without writing anything: its
    streams (type, count, rate and jitter, time span, size, repeated or out-of-order
    stamps), the trials an ingest would make and what it would leave out; other commands
    need it ingested first. A run folder (tactile train's output) is summarised: family,
    input, heads, data and the sensor unit, frame size and px_per_mm it was calibrated
    on."""

    def body() -> None:
        from ..learn.sensor_unit import is_run_folder

        if is_run_folder(file):
            from ..learn.sensor_unit import run_summary

            run = run_summary(file)
            typer.echo(json.dumps(run.as_dict(), indent=2) if as_json
                       else "\n".join(run.summary_lines()))
            return
        options = parse_options(option or [], {"mapping": mapping})
        if fmt != "auto" or options or raw_format(file) is not None:
            _raw(describe_recording(file, format=fmt, options=options), as_json)
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

    run_guarded(body, flags=FLAGS)


def _raw(summary: RecordingSummary, as_json: bool) -> None:
    """A raw recording's summary: a line, the streams, the trials, what is left out, notes."""
    if as_json:
        data = summary.as_dict()
        data["hint"] = _flags(summary.hint)
        typer.echo(json.dumps(data, indent=2))
        return
    console = Console(width=None if sys.stdout.isatty() else 150)
    console.print(f"[bold]{summary.file}[/] {summary.title} recording, "
                  f"{summary.size_bytes:,} bytes, {len(summary.streams)} stream(s), "
                  f"{len(summary.trials)} trial(s)", highlight=False)
    table = Table(title="Streams")
    for col in ("stream", "type", "count", "rate (Hz)", "jitter (ms)", "first (s)",
                "span (s)", "resolution", "channels", "stamps repeated / out of order"):
        table.add_column(col)
    for s in summary.streams:
        count = f"{s.count:,} {s.unit}" if s.count is not None else "not readable"
        stamps = ("" if s.repeated_stamps is None and s.out_of_order_stamps is None
                  else f"{s.repeated_stamps or 0:,} / {s.out_of_order_stamps or 0:,}")
        channels = ", ".join(s.channels[:6]) + (f", ... ({len(s.channels)})"
                                                 if len(s.channels) > 6 else "")
        table.add_row(s.name, s.type, count, _num(s.rate_hz, "g"),
                      _num(None if s.jitter_s is None else s.jitter_s * 1e3, ".3g"),
                      _num(s.t_first_s, ".6f"), _num(s.span_s, ".6f"), s.resolution, channels,
                      stamps)
    console.print(table)
    trials = Table(title=f"Trials ({len(summary.trials)})")
    for col in ("trial", "source", "items", "duration (s)", "labels"):
        trials.add_column(col)
    half = MAX_TRIALS_SHOWN // 2
    shown = (summary.trials if len(summary.trials) <= MAX_TRIALS_SHOWN
             else summary.trials[:half] + summary.trials[-half:])
    for t in shown:
        trials.add_row(t.name, t.source, ", ".join(f"{k} {v:,}" for k, v in t.counts.items()),
                       _num(t.duration_s, ".3f"),
                       ", ".join(f"{k}={v}" for k, v in t.labels.items()))
    if len(shown) < len(summary.trials):
        trials.caption = f"{len(summary.trials) - len(shown)} trials not shown; use --json for all"
    console.print(trials)
    for line in summary.dropped:
        console.print(f"left out: {line}", highlight=False, soft_wrap=True)
    for line in summary.notes:
        console.print(f"note: {_flags(line)}", highlight=False, soft_wrap=True)
    console.print(_flags(summary.hint), highlight=False, soft_wrap=True)


def _num(value: float | None, spec: str) -> str:
    return "" if value is None else format(value, spec)


def _flags(text: str) -> str:
    """A library note with the format options it names spelt as ``tactile ingest`` flags."""
    return to_flags(text, {"format": "--format", **OPTION_FLAGS})


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
