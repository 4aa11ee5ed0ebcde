"""`tactile synth --out FILE [--fits FILE.h5] [--centroids ROIS.yaml]`"""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from ._errors import Flag, run_guarded, seconds_as_ms
from ._options import OverwriteOption
from .progress import ProgressOption, RichProgress

#: How this command spells the library arguments its errors name (see ``_errors.to_flags``).
FLAGS: dict[str, Flag] = {"bin_s": ("--bin-ms", seconds_as_ms)}


def synth_command(
    out: Annotated[Path, typer.Option("--out", "-o", help="Output HDF5 file.", metavar="FILE",
                                      show_default=False)],
    fits: Annotated[Path | None, typer.Option(
        help="Tactile file with /derived/fits/fos_press and fos_slip (from `tactile fit-fos`): "
        "parameters are drawn per force level from its converged fits. Without it, from the "
        "config's fos section (the paper's values).", metavar="FILE", show_default=False)] = None,
    centroids: Annotated[Path | None, typer.Option(
        help="ROI config (configs/rois_marker_scene.yaml or a scene's scene.json): also write "
             "each trial's model-based ROI centroid trajectories as the stream roi_centroids "
             "(the config's centroids section; paper 000, sec. 5.2).",
        metavar="FILE", show_default=False)] = None,
    n: Annotated[int, typer.Option("--n", min=1, help="Number of trials.")] = 500,
    seed: Annotated[int, typer.Option(min=0, help="Random seed (same seed, same trials).")] = 0,
    config: Annotated[Path | None, typer.Option(
        "--config", "-c", help="Synth config YAML (see configs/synth_fos.yaml); default: the "
        "built-in defaults, which that file repeats.", metavar="FILE", show_default=False)] = None,
    bin_ms: Annotated[float | None, typer.Option(
        min=0.001, help="Bin width in ms; overrides the config's bin_s.",
        show_default=False)] = None,
    overwrite: OverwriteOption = False,
    progress: ProgressOption = None,
) -> None:
    """Model-based training trajectories (paper 000, sec. 5.1): random approach, press, slip
    and release trials of net event counts per bin from the first-order-system model, with
    FOS parameters drawn per force level, random timings, initial conditions and counting
    noise; per-bin action labels and the force level in the schema."""

    def body() -> None:
        from ..synth import synthesize

        with RichProgress(enabled=progress) as bar:
            result = synthesize(out, n=n, seed=seed, config=config,
                                bin_s=None if bin_ms is None else bin_ms / 1000, fits=fits,
                                overwrite=overwrite, progress=bar, centroids=centroids)
        source = f"fits in {fits}" if fits is not None else "the config's fos section"
        extra = "" if centroids is None else f", ROI centroids from {centroids}"
        typer.echo(f"wrote {result.path}: {result.n} trials, parameters from {source}{extra}")

    run_guarded(body, flags=FLAGS)
