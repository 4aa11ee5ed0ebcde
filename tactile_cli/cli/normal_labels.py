"""`tactile normal-labels CALIB.h5 --out PIXELS.h5 [--json]`: the calibration pixel table
of the normal MLP from ball-bearing presses (paper 002, sec. II-B)."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Annotated

import typer

from ._errors import Flag, run_guarded
from .progress import ProgressOption, RichProgress

FLAGS: dict[str, Flag] = {
    "out": "--out",
    "flat_per_press": "--flat-per-press",
    "seed": "--seed",
    "overwrite": "--overwrite",
    "plot_dir": "--plot",
}


def normal_labels_command(
    calibration: Annotated[
        Path, typer.Argument(help="Ingested ball-bearing presses (one trial each, labels "
                             "ball_radius_mm, sensor attribute px_per_mm).", metavar="FILE",
                             show_default=False)
    ],
    out: Annotated[
        Path, typer.Option("--out", "-o", help="Output pixel table (tactile HDF5).",
                           metavar="FILE", show_default=False)
    ],
    flat_per_press: Annotated[
        int, typer.Option("--flat-per-press", min=0, help="Flat pixels (outside the contact "
                          "circle) kept per press, drawn at random; the rest are left out and "
                          "counted in the output.")
    ] = 3000,
    seed: Annotated[int, typer.Option(min=0, help="Seed of the flat-pixel subsample.")] = 0,
    plot: Annotated[
        Path | None, typer.Option("--plot", help="Also write FOLDER/circles.png: every press "
                                  "with its fitted circle (and the scene's true one).",
                                  metavar="FOLDER", show_default=False)
    ] = None,
    overwrite: Annotated[bool, typer.Option(help="Replace an existing output file (and "
                                            "--plot folder).")] = False,
    as_json: Annotated[bool, typer.Option("--json", help="Print the summary as JSON.")] = False,
    progress: ProgressOption = None,
) -> None:
    """Find the ball's contact circle in every calibration press (colour difference from the
    reference, robust circle fit), label every pixel inside with the sphere's normal (eqs.
    5-8) and (0, 0, 1) outside, and write the table x, y, dR, dG, dB, R, G, B -> nx, ny, nz
    (stream `pixels`, one trial per press) for `tactile train configs/train_mlp_normals.yaml`.
    Prints per press the circle and, for simulated presses, its error against the truth."""

    def body() -> None:
        from ..visuotactile.calibrate import write_normal_labels

        with RichProgress(enabled=progress) as bar:
            result = write_normal_labels(calibration, out, flat_per_press=flat_per_press,
                                         seed=seed, overwrite=overwrite, progress=bar,
                                         plot_dir=plot)
        summary = result.as_dict()
        if as_json:
            typer.echo(json.dumps(summary, indent=2))
            return
        for row in summary["presses"]:
            err = ("" if row["centre_error_px"] is None else
                   f"  error: centre {row['centre_error_px']:.2f} px, radius "
                   f"{row['radius_error_px']:+.2f} px")
            if row["status"] != "ok":
                typer.echo(f"{row['trial']}: not labelled: {row['status']}")
                continue
            typer.echo(f"{row['trial']}: circle ({row['centre_x_px']:.1f}, "
                       f"{row['centre_y_px']:.1f}) r {row['radius_px']:.1f} px, "
                       f"{row['n_contact']} contact + {row['n_flat']} flat px{err}")
        typer.echo(f"wrote {summary['out']}: {summary['n_pixels']:,} pixels from "
                   f"{summary['n_labelled']} of {summary['n_presses']} presses "
                   f"({summary['n_contact_pixels']:,} in contact; {summary['n_flat_left_out']:,}"
                   f" flat pixels left out, --flat-per-press {summary['flat_per_press']}); "
                   f"px_per_mm {summary['px_per_mm']:g}")
        for key in ("centre_error_px", "radius_error_px"):
            stats = summary[key]
            if stats is not None:
                typer.echo(f"circle {key.replace('_px', '').replace('_', ' ')} against the "
                           f"scene truth: median {stats['median']:.2f} px, max "
                           f"{stats['max']:.2f} px (n={stats['n']})")

    run_guarded(body, flags=FLAGS)
