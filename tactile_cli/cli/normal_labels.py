"""`tactile normal-labels CALIB.h5 --out PIXELS.h5 [--json]`: the calibration pixel table
of the normal MLP from ball-bearing presses (paper 002, sec. II-B)."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from ._errors import Flag, run_guarded
from ._options import JsonOption
from ._output import print_result
from .progress import ProgressOption, RichProgress

FLAGS: dict[str, Flag] = {"plot_dir": "--plot"}


def normal_labels_command(
    calibration: Annotated[Path, typer.Argument(
        help="Ingested ball-bearing presses (one trial each, labels ball_radius_mm, sensor "
        "attribute px_per_mm).", metavar="FILE", show_default=False)],
    out: Annotated[Path, typer.Option(
        "--out", "-o", help="Output pixel table (tactile HDF5).", metavar="FILE",
        show_default=False)],
    flat_per_press: Annotated[int, typer.Option(
        "--flat-per-press", min=0, help="Flat pixels (outside the contact circle) kept per "
        "press, drawn at random; the rest are left out and counted in the output.")] = 3000,
    seed: Annotated[int, typer.Option(min=0, help="Seed of the flat-pixel subsample.")] = 0,
    plot: Annotated[Path | None, typer.Option(
        "--plot", help="Also write FOLDER/circles.png: every press with its fitted circle (and "
        "the scene's true one).", metavar="FOLDER", show_default=False)] = None,
    overwrite: Annotated[bool, typer.Option(help="Replace an existing output file (and "
                                            "--plot folder).")] = False,
    as_json: JsonOption = False,
    progress: ProgressOption = None,
) -> None:
    """Find the ball's contact circle in every calibration press (colour difference from the
    reference, robust circle fit), label every pixel inside with the sphere's normal (eqs.
    5-8) and (0, 0, 1) outside, and write the table x, y, dR, dG, dB, R, G, B -> nx, ny, nz
    (stream `pixels`, one trial per press) for `tactile train configs/train_mlp_normals.yaml`.
    Prints per press the circle and, for simulated presses, its error against the truth."""

    from ..visuotactile.calibrate import write_normal_labels

    def body():
        with RichProgress(enabled=progress) as bar:
            return write_normal_labels(calibration, out, flat_per_press=flat_per_press,
                                       seed=seed, overwrite=overwrite, progress=bar,
                                       plot_dir=plot)

    print_result(run_guarded(body, flags=FLAGS), as_json=as_json)
