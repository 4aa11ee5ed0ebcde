"""`tactile slip-interface FILE --json`: where did it slip? (paper 004, Tables 4-6)."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Annotated

import typer

from ._errors import Flag, run_guarded
from .progress import ProgressOption, RichProgress

FLAGS: dict[str, Flag] = {"folds": "--folds", "out": "--out", "plot": "--plot",
                          "config": "--config"}


def slip_interface_command(
    file: Annotated[Path, typer.Argument(help="Tactile HDF5 file of taxel-array trials "
                                         "(tactile simulate taxel-slip).", metavar="FILE",
                                         show_default=False)],
    config: Annotated[Path | None, typer.Option(
        "--config", "-c", help="Feature config YAML (see configs/taxel_features.yaml); "
        "default: the built-in defaults.", metavar="CONFIG")] = None,
    folds: Annotated[int | None, typer.Option("--folds", min=2, help="Override folds "
                                              "(outer cross-validation folds).")] = None,
    out: Annotated[Path | None, typer.Option("--out", "-o", help="Also write the result as "
                                             "JSON (with provenance) to this file.",
                                             metavar="FILE")] = None,
    plot: Annotated[Path | None, typer.Option("--plot", help="Write the features against "
                                              "frequency, mean and 1 s.d. per slip type, "
                                              "as a PNG (like Fig. 12).", metavar="FILE")
                    ] = None,
    overwrite: Annotated[bool, typer.Option(help="Replace existing output files.")] = False,
    as_json: Annotated[bool, typer.Option("--json", help="Print the result as JSON.")] = False,
    progress: ProgressOption = None,
) -> None:
    """Classify the slip interface (object/hand or object/world) of every trial with a
    Gaussian naive Bayes on the power ratio Gamma, single-finger G2 or multi-finger G2,
    10-fold cross-validated per trial: over the full spectrum, and on the best band
    (f, w) chosen inside each training set by an inner cross-validation (nested, the
    headline; the optimistic best band chosen on all trials is reported beside it).
    Contact estimation and the noise-floor gate apply first."""
    from ..taxel import slip_interface_file

    def body():
        with RichProgress(enabled=progress) as bar:
            return slip_interface_file(file, config=config, folds=folds, out=out, plot=plot,
                                       overwrite=overwrite, progress=bar)

    result = run_guarded(body, flags=FLAGS)
    summary = result.as_dict()
    if as_json:
        typer.echo(json.dumps(summary, indent=2))
        return
    from rich.console import Console
    from rich.table import Table

    table = Table(title=f"slip interface, {result.folds}-fold CV per trial "
                  f"({', '.join(result.datasets)})")
    for col in ("preset", "feature", "trials", "decided", "full spectrum",
                "best band (nested)", "best band (optimistic)", "(f, w) Hz"):
        table.add_column(col, justify="right")
    for s in result.scores:
        f, w = s.optimistic_band_hz
        table.add_row(s.preset, s.feature, str(s.n_trials), str(s.n_decided),
                      f"{100 * s.full_spectrum:.1f} %", f"{100 * s.nested_best_band:.1f} %",
                      f"{100 * s.optimistic_best_band:.1f} %", f"({f:.4g}, {w:.4g})")
    Console(width=130).print(table)
    typer.echo(f"nested best band >= 85 %: {summary['nested_at_least_85']} of "
               f"{summary['n_combinations']} preset x feature combinations")
