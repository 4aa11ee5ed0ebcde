"""`tactile simulate <scene>`: simulated recordings with their ground truth."""

from __future__ import annotations

import json
from collections.abc import Callable
from pathlib import Path
from typing import Annotated, Any

import typer

from ..errors import InputError
from ._errors import Flag, run_guarded
from ._options import JsonOption, OverwriteOption, SeedOption
from ._options import SceneConfigOption as ConfigOption
from ._output import print_result
from .progress import ProgressOption, RichProgress

#: How these commands spell the library arguments their errors name (each adds its own).
FLAGS: dict[str, Flag] = {}

app = typer.Typer(
    name="simulate",
    help="Simulated sensor recordings with their ground truth.",
    no_args_is_help=True,
    add_completion=False,
    context_settings={"help_option_names": ["-h", "--help"]},
)

def run_scene(simulate: Callable[[Any], Any], *, as_json: bool, progress: bool | None,
              flags: dict[str, Flag]) -> Any:
    """Run ``simulate(progress_bar)`` guarded; print its result (JSON, or its summary)."""

    def body() -> Any:
        with RichProgress(enabled=progress) as bar:
            return simulate(bar)

    result = run_guarded(body, flags={**FLAGS, **flags})
    if hasattr(result, "summary_lines"):
        print_result(result, as_json=as_json)
    return result


def _parse_levels(text: str | None) -> list[int] | None:
    """``"1,6,12"`` or ``"1-3,12"`` -> ``[1, 6, 12]`` / ``[1, 2, 3, 12]``."""
    if text is None:
        return None
    levels: list[int] = []
    for part in text.split(","):
        lo, sep, hi = part.strip().partition("-")
        try:
            levels.extend(range(int(lo), int(hi) + 1) if sep else [int(lo)])
        except ValueError:
            raise InputError(f"--levels {text!r} must list force levels like 1,6,12 or "
                             "1-3,12") from None
    return levels


@app.command("marker-events")
def marker_events_command(
    out: Annotated[Path, typer.Option("--out", "-o", help="Output folder (created).",
                                      show_default=False, metavar="FOLDER")],
    config: ConfigOption = None,
    seed: SeedOption = 0,
    groups: Annotated[int | None, typer.Option(min=1, help="Override trials.groups (trial "
                                               "groups).")] = None,
    levels: Annotated[str | None, typer.Option(help="Override trials.levels: force levels to "
                                               "simulate, e.g. 1,6,12 or 1-3.")] = None,
    overwrite: OverwriteOption = False,
    as_json: JsonOption = False,
    progress: ProgressOption = None,
) -> None:
    """Simulate the paper's event-based marker sensor: approach, press, slip, release trials.

    Writes DIR/<trial>.npy (events: t in us from the trial start, x, y, p), DIR/trials.csv
    (ground truth per trial, and its origin: columns origin=simulated and dataset),
    DIR/annotations.csv (the four action regions) and
    DIR/scene.json (config, seed, sensor geometry, ROIs).

    Ingest: tactile ingest DIR/*.npy --width 640 --height 480 --annotations
    DIR/annotations.csv --trial-labels DIR/trials.csv --out scene.h5
    """
    from ..scene import MarkerSceneConfig, load_marker_scene_config, simulate_marker_events

    def simulate(bar: Any) -> Any:
        cfg = load_marker_scene_config(config) if config is not None else MarkerSceneConfig()
        if groups is not None or levels is not None:
            cfg = cfg.with_overrides(groups=groups, levels=_parse_levels(levels))
        return simulate_marker_events(cfg, out, seed=seed, progress=bar, overwrite=overwrite)

    r = run_scene(simulate, as_json=as_json, progress=progress, flags={"groups": "--groups"})
    s = r.as_dict()
    typer.echo(json.dumps(s, indent=2) if as_json else
               f"marker events -> {r.out_dir} (seed {r.seed}): {s['n_trials']} trials, "
               f"{s['n_events']:,} events ({s['n_positive']:,} positive, {s['n_negative']:,} "
               f"negative), {s['duration_s']:.2f} trial seconds, simulated in "
               f"{s['elapsed_s']:.2f} s")


@app.command("vibro-slip")
def vibro_slip_command(
    out: Annotated[Path, typer.Option("--out", "-o", help="Output folder: the CSV tree "
                                      "(created).", show_default=False, metavar="FOLDER")],
    config: ConfigOption = None,
    seed: SeedOption = 0,
    duration: Annotated[float | None, typer.Option(
        "--duration", min=0.0, help="Override duration_s: seconds per recording (36 "
        "recordings by default).")] = None,
    overwrite: OverwriteOption = False,
    as_json: JsonOption = False,
    progress: ProgressOption = None,
) -> None:
    """Simulate paper 001's slip-slide rig: accelerometer fingertips on 3 textures x 4
    angles x 3 motor speeds, as the paper's CSV tree.

    Writes DIR/<texture>/<angle>/<rps>/data.csv (L_x..R_z as a fraction of +-5 g, v_slip,
    v_slide in m/s, 8 kHz) and DIR/scene.json (config, seed, ground truth per recording).

    Ingest: tactile ingest DIR --format accel-tree --out scene.h5; then
    tactile accel-prepare scene.h5 --out prepared.h5 for the training configs.
    """
    from ..accel import VibroSceneConfig, load_vibro_config, simulate_vibro_slip

    def simulate(bar: Any) -> Any:
        cfg = load_vibro_config(config) if config is not None else VibroSceneConfig()
        return simulate_vibro_slip(cfg.with_duration(duration), out, seed=seed, progress=bar,
                                   overwrite=overwrite)

    run_scene(simulate, as_json=as_json, progress=progress, flags={"duration_s": "--duration"})


@app.command("vibrotouch")
def vibrotouch_command(
    out: Annotated[Path, typer.Option("--out", "-o", help="Output tactile HDF5 file.",
                                      show_default=False, metavar="FILE")],
    config: ConfigOption = None,
    seed: SeedOption = 0,
    contact_trials: Annotated[int | None, typer.Option(
        "--contact-trials", min=0, help="Override contact_trials (gripper-object trials).")] = None,
    touch_trials: Annotated[int | None, typer.Option(
        "--touch-trials", min=0, help="Override touch_trials (trials of 5 human touches).")] = None,
    overwrite: OverwriteOption = False,
    as_json: JsonOption = False,
    progress: ProgressOption = None,
) -> None:
    """Simulate paper 003's VibroTouch bench: an ERM near 130 Hz in one fingertip, an
    accelerometer (2.5 kHz) in the other, a force sensor (1 kHz); the gripper closes on an
    object at 0.01 mm/s (contact trials) or holds it at 1 N while a human presses it
    (touch trials). The accelerometer hears the lumped model of `tactile vibro-model`.

    Writes one tactile HDF5 file: streams accel (a_x, g) and force (f_y, f_z, N), trial
    labels origin=simulated, dataset, scenario, contact_s (the true contact), annotations
    calibration, contact and touch. Then: tactile detect-contact FILE.
    """
    from ..vibro import VibroTouchSceneConfig, load_vibrotouch_config, simulate_vibrotouch

    def simulate(bar: Any) -> Any:
        cfg = load_vibrotouch_config(config) if config is not None else VibroTouchSceneConfig()
        cfg = cfg.with_overrides(contact_trials=contact_trials, touch_trials=touch_trials)
        return simulate_vibrotouch(cfg, out, seed=seed, progress=bar, overwrite=overwrite,
                                   sources=[config] if config is not None else ())

    run_scene(simulate, as_json=as_json, progress=progress,
              flags={"contact_trials": "--contact-trials", "touch_trials": "--touch-trials"})


@app.command("taxel-slip")
def taxel_slip_command(
    out: Annotated[Path, typer.Option("--out", "-o", help="Output tactile HDF5 file.",
                                      show_default=False, metavar="FILE")],
    config: ConfigOption = None,
    seed: SeedOption = 0,
    preset: Annotated[list[str] | None, typer.Option(
        "--preset", help="Simulate only this sensor (biotac, capacitive, pvdf); repeatable. "
        "Default: the config's presets.", metavar="PRESET")] = None,
    trials: Annotated[int | None, typer.Option(
        "--trials", min=1, help="Override trials_per_class (trials per preset and slip "
        "type).")] = None,
    overwrite: OverwriteOption = False,
    as_json: JsonOption = False,
    progress: ProgressOption = None,
) -> None:
    """Simulate paper 004's slip experiments: object/hand slip (independent stick-slip at
    every contact) and object/world slip (one source through each taxel's linear path) on
    a BioTac-like array (19 electrodes at 100 Hz, sequential, plus 4.4 kHz pressure), a
    capacitive array (12 taxels at 300 Hz, sequential) and PVDF strips (8 at 3.125 kHz,
    simultaneous), two fingers each, textures, grip forces and speeds varying by trial.

    Writes one tactile HDF5 file: streams <preset>_f0, <preset>_f1 (and biotac_pressure),
    trial labels origin=simulated, dataset, preset, slip (hand/world), texture, grip_n,
    speed_cm_s, annotations rest and slip. Then: tactile slip-interface FILE.
    """
    from ..taxel import TaxelSceneConfig, load_taxel_scene_config, simulate_taxel_slip

    def simulate(bar: Any) -> Any:
        cfg = load_taxel_scene_config(config) if config is not None else TaxelSceneConfig()
        cfg = cfg.with_overrides(presets=preset, trials_per_class=trials)
        return simulate_taxel_slip(cfg, out, seed=seed, progress=bar, overwrite=overwrite)

    run_scene(simulate, as_json=as_json, progress=progress,
              flags={"presets": "--preset", "trials_per_class": "--trials"})

