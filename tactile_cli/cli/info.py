"""`tactile info FILE` (a tactile HDF5 file) and `tactile info RAW` (a raw recording of any
format `tactile ingest` reads, described read-only)"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Annotated

import typer

from ..ingest import describe_recording, parse_options, raw_format
from ..ingest.summary_text import recording_blocks
from ..store.reader import summarize
from ..store.summary_text import file_blocks
from ._errors import Flag, run_guarded, to_flags
from ._ingest_flags import OPTION_FLAGS
from ._output import print_blocks

#: How this command spells the library arguments its errors name.
FLAGS: dict[str, Flag] = {
    "format": "--format", "mapping": "--mapping", "options": "--option", "json": "--json",
}


def info_command(
    file: Annotated[Path, typer.Argument(
        help="A tactile HDF5 file, or a raw recording of any format tactile ingest reads "
        "(a file or a folder).", metavar="FILE", show_default=False)],
    fmt: Annotated[str, typer.Option(
        "--format", "-f", help="Raw recordings: their format (default auto: told from the "
        "input; see tactile ingest --help).", metavar="NAME")] = "auto",
    mapping: Annotated[Path | None, typer.Option(
        help="Raw sensor CSVs: the YAML mapping to describe them with (streams, rates, stamps, "
        "columns left out); without it their columns are listed.", metavar="FILE")] = None,
    option: Annotated[list[str] | None, typer.Option(
        "--option", "-O", help="Raw recordings: a format option by its name, KEY=VALUE "
        "(repeatable; see tactile ingest --help).", metavar="KEY=VALUE")] = None,
    as_json: Annotated[bool, typer.Option(
        "--json", help="Print the summary as JSON (every channel name and label value).")] = False,
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
    on; a seed-spread folder by its config, seeds, protocol and each figure's mean, SD and
    range over the seeds."""

    def body() -> None:
        from ..learn.seed_spread import is_spread_folder
        from ..learn.sensor_unit import is_run_folder

        if is_spread_folder(file):
            from ..learn.seed_spread import spread_lines

            record, lines = spread_lines(file)
            typer.echo(json.dumps(record, indent=2) if as_json else "\n".join(lines))
            return
        if is_run_folder(file):
            from ..learn.sensor_unit import run_summary

            run = run_summary(file)
            typer.echo(json.dumps(run.as_dict(), indent=2) if as_json
                       else "\n".join(run.summary_lines()))
            return
        options = parse_options(option or [], {"mapping": mapping})
        if fmt != "auto" or options or raw_format(file) is not None:
            raw = describe_recording(file, format=fmt, options=options)
            if as_json:
                typer.echo(json.dumps({**raw.as_dict(), "hint": _flags(raw.hint)}, indent=2))
            else:
                print_blocks(recording_blocks(raw, spell=_flags), width=150)
            return
        summary = summarize(file)  # every read failure is one InputError naming the path
        if as_json:
            typer.echo(json.dumps(summary.as_dict(), indent=2))
        else:
            print_blocks(file_blocks(summary), width=150)

    run_guarded(body, flags=FLAGS)


def _flags(text: str) -> str:
    """A library note with the format options it names spelt as ``tactile ingest`` flags."""
    return to_flags(text, {"format": "--format", **OPTION_FLAGS})
