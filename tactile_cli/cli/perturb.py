"""`tactile perturb RUN... --data FILE... [--kinds noise,lowpass,drop,scale] [--threshold 0.9x]
[--out DIR] [--json]`"""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from ._errors import Flag, run_guarded
from ._options import data_files, runs_and_files
from ._output import echo_json, print_blocks, warn

#: How this command spells the library arguments its errors name (see ``_errors.to_flags``).
FLAGS: dict[str, Flag] = {"run_dirs": "RUN", "data_paths": "--data FILE...", "out_dir": "--out"}


def perturb_command(
    ctx: typer.Context,
    runs: Annotated[list[Path], typer.Argument(
        help="Run folder(s) written by `tactile train`. A path that is a file is taken as a data "
        "file (so `--data *.h5` works).", metavar="RUN", show_default=False)],
    data: Annotated[list[Path] | None, typer.Option(
        "--data", "-d", help="Tactile HDF5 file(s) to evaluate on (perturbed in memory; the "
        "files are never changed).", metavar="FILE", show_default=False)] = None,
    kinds: Annotated[str, typer.Option(
        help="Comma-separated: noise, lowpass, drop (events for event counts, samples "
        "otherwise), drop_events, drop_samples, scale.")] = "noise,lowpass,drop,scale",
    levels: Annotated[list[str] | None, typer.Option(
        "--levels", help="KIND=V1,V2,... (repeatable): noise SNR in dB, lowpass cut-off as a "
        "fraction of Nyquist, drop fraction, scale time factor.", metavar="KIND=V1,V2",
        show_default=False)] = None,
    threshold: Annotated[str, typer.Option(
        help="Accuracy below which a level is broken: a factor of the clean accuracy (0.9x) or "
        "an accuracy (0.95 or 95%).")] = "0.9x",
    split: Annotated[str, typer.Option(help="all or test (as `tactile evaluate`).")] = "all",
    seed: Annotated[int, typer.Option(help="Seed of the random perturbations.")] = 0,
    name: Annotated[str | None, typer.Option(
        help="Results folder RUN/perturb/<name> (default from the data file names).",
        show_default=False)] = None,
    out: Annotated[Path | None, typer.Option(
        "--out", "-o",
        help="Folder for the combined chart of all runs (perturb.png, .csv, .json).",
        metavar="FOLDER", show_default=False)] = None,
    as_json: Annotated[bool, typer.Option("--json", help="Print perturb.json to stdout.")
                       ] = False,
) -> None:
    """Re-evaluate runs on perturbed copies of the data (noise at several SNRs, low-pass
    cut-off halved step by step, dropped events or samples, time-scaled actions) and find
    the breaking point of each: the first level where accuracy falls below the threshold.
    Writes RUN/perturb/<name>/ (perturb.json, .csv, .png) for every run."""

    def body() -> None:
        import sys

        from ..learn.perturb import perturb_runs
        from ..learn.tables import perturbation_blocks

        run_dirs, files = runs_and_files([*runs, *data_files(None, ctx)], data)
        show = sys.stderr.isatty() and not as_json
        result = perturb_runs(
            run_dirs, files, kinds=kinds, levels=levels, threshold=threshold,
            split=split, seed=seed, name=name, out=out,  # type: ignore[arg-type]
            on_run=lambda run: print(f"{run}:", file=sys.stderr) if show else None,
            on_level=lambda kind, level, acc: print(
                f"  {kind} {level:g}: accuracy {100 * acc:.2f} %", file=sys.stderr)
            if show else None)
        warn(result.notes)
        if as_json:
            echo_json(result.as_dict())
            return
        print_blocks(perturbation_blocks(result.results), width=140)
        if result.chart is not None:
            typer.echo(f"wrote {result.chart['png']}")

    run_guarded(body, flags=FLAGS)
