"""`tactile perturb RUN... --data FILE... [--kinds noise,lowpass,drop,scale] [--threshold 0.9x]
[--out DIR] [--json]`

Also the body of `tactile evaluate --perturb` (:func:`perturb_and_print`).
"""

from __future__ import annotations

import sys
from pathlib import Path
from typing import Annotated, Any

import typer

from ..errors import InputError
from ._errors import Flag, run_guarded
from .compare import runs_and_files

#: How this command spells the library arguments its errors name (see ``_errors.to_flags``).
FLAGS: dict[str, Flag] = {
    "data_paths": "--data FILE",
    "split": "--split",
    "threshold": "--threshold",
    "out_dir": "--out",
}


def parse_threshold(text: str) -> tuple[float | None, float]:
    """``"0.9x"`` -> (None, 0.9): relative to the clean accuracy; ``"0.95"`` or ``"95%"``
    -> (0.95, 0.9): an absolute accuracy."""
    t = text.strip().lower()
    try:
        if t.endswith("x"):
            rel = float(t[:-1])
            if not 0 < rel <= 1:
                raise ValueError
            return None, rel
        value = float(t[:-1]) / 100 if t.endswith("%") else float(t)
    except ValueError:
        raise InputError(f"--threshold must be a factor of the clean accuracy like 0.9x or an "
                         f"accuracy like 0.95 or 95%, got {text!r}") from None
    if not 0 <= value <= 1:
        raise InputError(f"--threshold {text!r} is not an accuracy in [0, 1] (or 0-100 %)")
    return value, 0.9


def parse_levels(items: list[str] | None) -> dict[str, list[float]]:
    """``["noise=30,20,10", "scale=0.5,2"]`` -> {"noise": [30, 20, 10], "scale": [0.5, 2]}."""
    out: dict[str, list[float]] = {}
    for item in items or []:
        kind, sep, values = item.partition("=")
        try:
            if not sep or not kind.strip():
                raise ValueError
            out[kind.strip()] = [float(v) for v in values.split(",") if v.strip()]
        except ValueError:
            raise InputError(f"--levels takes KIND=V1,V2,... (e.g. noise=30,20,10), got "
                             f"{item!r}") from None
    return out


def perturb_and_print(
    runs: list[Path],
    files: list[Path],
    *,
    kinds: str = "noise,lowpass,drop,scale",
    levels: list[str] | None = None,
    threshold: str = "0.9x",
    split: str = "all",
    seed: int = 0,
    name: str | None = None,
    out: Path | None = None,
    as_json: bool = False,
    echo: bool = True,
    notes: bool = True,
) -> list[Any]:
    """Run :func:`tactile_cli.learn.perturb.perturb_evaluate` for every run (each writes
    RUN/perturb/<name>/), write the combined chart to ``out`` when given, print a table
    (or the JSON) when ``echo`` and the results' notes on stderr when ``notes``, and return
    the results. For use inside ``run_guarded``."""
    from rich.console import Console
    from rich.table import Table

    from ..learn.perturb import level_text, perturb_evaluate, write_perturbation_set
    from ..learn.runs import dumps

    if not runs:
        raise InputError("no run folder; give RUN")
    if not files:
        raise InputError("no data files; give --data FILE...")
    if out is not None:  # the chart is added to an existing folder; a file there is refused
        from ..store.outdir import check_output_folder

        check_output_folder(out, merge=True)
    absolute, relative = parse_threshold(threshold)
    level_map = parse_levels(levels)
    kind_list = [k for k in kinds.split(",") if k.strip()]
    err = Console(stderr=True)
    show = err.is_terminal and not as_json

    def on_level(kind: str, level: float, acc: float) -> None:
        if show:
            err.print(f"  {kind} {level:g}: accuracy {100 * acc:.2f} %")

    results = []
    for run in runs:
        if show:
            err.print(f"{run}:")
        results.append(perturb_evaluate(
            run, files, kind_list, level_map, absolute, relative_threshold=relative,
            split=split, seed=seed, name=name, on_level=on_level))  # type: ignore[arg-type]
    written = write_perturbation_set(results, out) if out is not None else None
    if notes:
        for r in results:
            for note in r.notes:
                print(f"tactile: warning: {note}", file=sys.stderr)
    if not echo:
        return results
    if as_json:
        payload: Any = [r.as_dict() for r in results]
        typer.echo(dumps(payload[0] if len(payload) == 1 else payload))
        return results
    console = Console(width=None if sys.stdout.isatty() else 140)
    for r in results:
        table = Table(title=f"{r.label} on {r.name}: clean accuracy "
                            f"{100 * r.clean_accuracy:.2f} %, threshold "
                            f"{100 * r.threshold:.2f} % ({r.threshold_rule})")
        for col in ("kind", "accuracy (%) by level", "direction",
                    "breaking point", "last level above"):
            table.add_column(col)
        for k in r.kinds:
            accs = ", ".join(f"{level_text(k, lv.level)}: {100 * lv.accuracy:.1f}"
                             for lv in k.levels)
            for i, b in enumerate(k.breaking):
                table.add_row(k.kind if i == 0 else "", accs if i == 0 else "", b.direction,
                              level_text(k, b.level) or "none", level_text(k, b.last_ok))
        console.print(table)
        typer.echo(f"wrote {r.out_dir}")
    if written is not None:
        typer.echo(f"wrote {written['png']}")
    return results


def perturb_command(
    ctx: typer.Context,
    runs: Annotated[
        list[Path], typer.Argument(help="Run folder(s) written by `tactile train`. A path that "
                                   "is a file is taken as a data file (so `--data *.h5` "
                                   "works).", metavar="RUN", show_default=False)],
    data: Annotated[
        list[Path] | None,
        typer.Option("--data", "-d", help="Tactile HDF5 file(s) to evaluate on (perturbed in "
                     "memory; the files are never changed).", metavar="FILE",
                     show_default=False),
    ] = None,
    kinds: Annotated[
        str, typer.Option(help="Comma-separated: noise, lowpass, drop (events for event "
                          "counts, samples otherwise), drop_events, drop_samples, scale.")
    ] = "noise,lowpass,drop,scale",
    levels: Annotated[
        list[str] | None,
        typer.Option("--levels", help="KIND=V1,V2,... (repeatable): noise SNR in dB, lowpass "
                     "cut-off as a fraction of Nyquist, drop fraction, scale time factor.",
                     metavar="KIND=V1,V2", show_default=False),
    ] = None,
    threshold: Annotated[
        str, typer.Option(help="Accuracy below which a level is broken: a factor of the clean "
                          "accuracy (0.9x) or an accuracy (0.95 or 95%).")
    ] = "0.9x",
    split: Annotated[str, typer.Option(help="all or test (as `tactile evaluate`).")] = "all",
    seed: Annotated[int, typer.Option(help="Seed of the random perturbations.")] = 0,
    name: Annotated[
        str | None,
        typer.Option(help="Results folder RUN/perturb/<name> (default from the data file "
                     "names).", show_default=False),
    ] = None,
    out: Annotated[
        Path | None,
        typer.Option("--out", "-o", help="Folder for the combined chart of all runs "
                     "(perturb.png, .csv, .json).", metavar="FOLDER", show_default=False),
    ] = None,
    as_json: Annotated[bool, typer.Option("--json", help="Print perturb.json to stdout.")
                       ] = False,
) -> None:
    """Re-evaluate runs on perturbed copies of the data (noise at several SNRs, low-pass
    cut-off halved step by step, dropped events or samples, time-scaled actions) and find
    the breaking point of each: the first level where accuracy falls below the threshold.
    Writes RUN/perturb/<name>/ (perturb.json, .csv, .png) for every run."""

    def body() -> None:
        extra = [Path(a) for a in ctx.args]
        for a in ctx.args:
            if a.startswith("-"):
                raise InputError(f"unknown option {a!r}; see --help")
        run_dirs, files = runs_and_files([*runs, *extra], data)
        perturb_and_print(run_dirs, files, kinds=kinds, levels=levels, threshold=threshold,
                          split=split, seed=seed, name=name, out=out, as_json=as_json)

    run_guarded(body, flags=FLAGS)
