"""`tactile simulate digit-press OUT`: the DIGIT-like scene of paper 002 (registered in
``cli/__init__.py``)."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from ..errors import InputError
from ._errors import Flag, run_guarded
from ._options import JsonOption, OverwriteOption, SceneConfigOption
from ._output import print_result
from .progress import ProgressOption, RichProgress

FLAGS: dict[str, Flag] = {"presses": "--calibration-presses", "per_object": "--trials"}


def digit_press_command(
    out_arg: Annotated[Path | None, typer.Argument(
        help="Output folder (created).", metavar="FOLDER", show_default=False)] = None,
    out: Annotated[Path | None, typer.Option(
        "--out", "-o", help="Output folder (same as OUT).", metavar="FOLDER", show_default=False
    )] = None,
    config: SceneConfigOption = None,
    seed: Annotated[int, typer.Option(min=0, help="Random seed; fixes every output byte "
                                      "and this unit's lighting.")] = 0,
    calibration_presses: Annotated[int | None, typer.Option(
        "--calibration-presses", min=0, help="Override calibration.presses (ball-bearing presses)."
    )] = None,
    trials: Annotated[int | None, typer.Option(
        "--trials", min=0, help="Override trials.per_object: trials per object (the first holds "
        "still, the others slip; 0: calibration presses only).")] = None,
    objects: Annotated[str | None, typer.Option(
        "--objects", help="Override trials.objects, comma-separated (cable, box, fabric, "
        "hex_key_small, hex_key_medium, hex_key_large).", metavar="NAMES")] = None,
    overwrite: OverwriteOption = False,
    as_json: JsonOption = False,
    progress: ProgressOption = None,
) -> None:
    """Simulate paper 002's DIGIT: ball-bearing calibration presses and objects (cable, box
    face, fabric, hex keys) held for >= 1.2 s and then slipping (+x, -x, +y, -y, z, rot) or
    held still, as 320x240 RGB frames under uneven, position-dependent LED lighting with
    camera noise; the height maps behind every frame are stored.

    Writes OUT/calibration/ball_NN/ and OUT/trials/<object>_NN/ (reference.png,
    frame_0000.png ..., trials also timestamps.csv at 30 Hz), OUT/calibration_labels.csv,
    OUT/trial_labels.csv (object, slip, direction, slip_onset_s), OUT/truth/<trial>.npz
    (height_mm per frame) and OUT/scene.json.

    Ingest: tactile ingest OUT/calibration --trial-labels OUT/calibration_labels.csv
    --px-per-mm 16 --out calib.h5 (and the same for OUT/trials with OUT/trial_labels.csv);
    then tactile normal-labels calib.h5 --out pixels.h5.
    """

    from ..visuotactile.config import DigitSceneConfig, load_digit_scene_config
    from ..visuotactile.simulate import simulate_digit_press

    def body():
        if (out_arg is None) == (out is None):
            raise InputError("give the output folder once: OUT or --out"
                             + (", not both" if out_arg is not None else ""))
        cfg = load_digit_scene_config(config) if config is not None else DigitSceneConfig()
        cfg = cfg.with_overrides(presses=calibration_presses, per_object=trials, objects=None
                                 if objects is None else [s.strip() for s in objects.split(",")
                                                          if s.strip()])
        with RichProgress(enabled=progress) as bar:
            return simulate_digit_press(cfg, out_arg or out, seed=seed, progress=bar,
                                        overwrite=overwrite)

    print_result(run_guarded(body, flags=FLAGS), as_json=as_json)
