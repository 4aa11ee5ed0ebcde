"""`tactile simulate digit-avoidance OUT --seed N`: the closed-loop slip-avoidance scene of
paper 002, sec. V (registered on the `simulate` sub-app in ``cli/__init__.py``)."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from ._errors import Flag, run_guarded
from ._options import JsonOption, OverwriteOption, SceneConfigOption, SeedOption
from ._output import print_result
from .progress import ProgressOption, RichProgress

FLAGS: dict[str, Flag] = {"objects": "--object"}


def digit_avoidance_command(
    out: Annotated[Path, typer.Argument(help="Output folder (created).", metavar="FOLDER",
                                        show_default=False)],
    config: SceneConfigOption = None,
    seed: SeedOption = 0,
    obj: Annotated[list[str] | None, typer.Option(
        "--object", help="Simulate this object (cable, box, fabric, hex_key_small, "
        "hex_key_medium, hex_key_large); repeatable, one trial each. Default: the config's.",
        metavar="NAME")] = None,
    interferences: Annotated[int | None, typer.Option(
        "--interferences", min=1, help="Override interferences (pushes per trial).")] = None,
    overwrite: OverwriteOption = False,
    as_json: JsonOption = False,
    progress: ProgressOption = None,
) -> None:
    """Simulate slip avoidance in a closed loop (Figs. 13-14): an object held on a DIGIT-like
    sensor is pushed at known times; a live monitor watches the frames' slip signal and the
    gripper obeys it (raise grip on slip, release 3 s after the last one; the release's own
    contact change is the second peak of each pair).

    Writes FOLDER/trials/<trial>/ (reference.png, frame_NNNN.png, timestamps.csv),
    FOLDER/trial_labels.csv (interference_s: the true push times), FOLDER/annotations.csv
    (interference and gripper_moving intervals), FOLDER/truth/<trial>.npz (height maps, depth,
    shift, gripper_moving per frame) and FOLDER/scene.json (config, optics, the live monitor's
    events).

    Then: tactile ingest FOLDER/trials --trial-labels FOLDER/trial_labels.csv --annotations
    FOLDER/annotations.csv --px-per-mm 16 --out avoid.h5; tactile monitor avoid.h5 (or
    tactile monitor FOLDER, which ingests the folder itself)
    """
    from ..visuotactile.avoidance import (
        AvoidanceConfig,
        load_avoidance_config,
        simulate_digit_avoidance,
    )

    def body():
        cfg = load_avoidance_config(config) if config is not None else AvoidanceConfig()
        cfg = cfg.with_overrides(objects=obj or None, interferences=interferences)
        with RichProgress(enabled=progress) as bar:
            return simulate_digit_avoidance(cfg, out, seed=seed, progress=bar,
                                            overwrite=overwrite)

    print_result(run_guarded(body, flags=FLAGS), as_json=as_json)
