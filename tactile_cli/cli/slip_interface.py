"""`tactile slip-interface FILE --json`: where did it slip? (paper 004, Tables 4-6)."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from ._errors import Flag, run_guarded
from ._options import JsonOption
from ._output import print_result
from .progress import ProgressOption, RichProgress

FLAGS: dict[str, Flag] = {}


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
    plot: Annotated[Path | None, typer.Option(
        "--plot", help="Write the features against frequency, mean and 1 s.d. per slip type, as "
        "a PNG (like Fig. 12).", metavar="FILE")] = None,
    overwrite: Annotated[bool, typer.Option(help="Replace existing output files.")] = False,
    as_json: JsonOption = False,
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

    print_result(run_guarded(body, flags=FLAGS), as_json=as_json, width=130)
