"""`tactile simulate marker-events --out DIR`: simulated recordings with their ground truth."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Annotated

import typer

from ..errors import InputError
from ._errors import Flag, run_guarded
from .progress import ProgressOption, RichProgress

#: How this command spells the library arguments its errors name (see ``_errors.to_flags``).
FLAGS: dict[str, Flag] = {
    "seed": "--seed",
}

app = typer.Typer(
    name="simulate",
    help="Simulated sensor recordings with their ground truth.",
    no_args_is_help=True,
    add_completion=False,
    context_settings={"help_option_names": ["-h", "--help"]},
)


def _parse_levels(text: str) -> list[int]:
    """``"1,6,12"`` or ``"1-3,12"`` -> ``[1, 6, 12]`` / ``[1, 2, 3, 12]``."""
    levels: list[int] = []
    for part in text.split(","):
        lo, sep, hi = part.strip().partition("-")
        try:
            values = range(int(lo), int(hi) + 1) if sep else [int(lo)]
        except ValueError:
            raise InputError(f"--levels {text!r} must list force levels like 1,6,12 or "
                             "1-3,12") from None
        levels.extend(values)
    return levels


@app.command("marker-events")
def marker_events_command(
    out: Annotated[
        Path, typer.Option("--out", "-o", help="Output folder (created).", show_default=False,
                           metavar="FOLDER")
    ],
    config: Annotated[
        Path | None,
        typer.Option(
            "--config",
            "-c",
            help="Scene config YAML (see configs/scene_marker_events.yaml); default: the "
            "built-in defaults, which that file repeats.",
            metavar="CONFIG",
        ),
    ] = None,
    seed: Annotated[int, typer.Option(min=0, help="Random seed; fixes every output byte.")] = 0,
    groups: Annotated[
        int | None, typer.Option(min=1, help="Override trials.groups (trial groups).")
    ] = None,
    levels: Annotated[
        str | None,
        typer.Option(help="Override trials.levels: force levels to simulate, e.g. 1,6,12 or 1-3."),
    ] = None,
    overwrite: Annotated[
        bool, typer.Option(help="Replace an existing non-empty output folder.")
    ] = False,
    as_json: Annotated[bool, typer.Option("--json", help="Print the summary as JSON.")] = False,
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

    def body() -> None:
        from ..scene import MarkerSceneConfig, load_marker_scene_config, simulate_marker_events

        cfg = load_marker_scene_config(config) if config is not None else MarkerSceneConfig()
        if groups is not None or levels is not None:
            cfg = cfg.with_overrides(
                groups=groups, levels=None if levels is None else _parse_levels(levels))
        with RichProgress(enabled=progress) as bar:
            result = simulate_marker_events(cfg, out, seed=seed, progress=bar,
                                            overwrite=overwrite)
        if as_json:
            typer.echo(json.dumps(result.as_dict(), indent=2))
            return
        from rich.console import Console
        from rich.table import Table

        table = Table(title=f"marker events -> {result.out_dir} (seed {result.seed})")
        for col in ("trials", "events", "positive", "negative", "trial seconds",
                    "simulated in (s)"):
            table.add_column(col, justify="right")
        summary = result.as_dict()
        table.add_row(str(summary["n_trials"]), f"{summary['n_events']:,}",
                      f"{summary['n_positive']:,}", f"{summary['n_negative']:,}",
                      f"{summary['duration_s']:.2f}", f"{summary['elapsed_s']:.2f}")
        Console(width=120).print(table)

    run_guarded(body, flags=FLAGS)


@app.command("vibro-slip")
def vibro_slip_command(
    out: Annotated[
        Path, typer.Option("--out", "-o", help="Output folder: the CSV tree (created).",
                           show_default=False, metavar="FOLDER")
    ],
    config: Annotated[
        Path | None,
        typer.Option("--config", "-c", help="Scene config YAML (see "
                     "configs/scene_vibro_slip.yaml); default: the built-in defaults.",
                     metavar="CONFIG"),
    ] = None,
    seed: Annotated[int, typer.Option(min=0, help="Random seed; fixes every output byte.")] = 0,
    duration: Annotated[
        float | None,
        typer.Option("--duration", min=0.0, help="Override duration_s: seconds per recording "
                     "(36 recordings by default)."),
    ] = None,
    overwrite: Annotated[
        bool, typer.Option(help="Replace an existing non-empty output folder.")
    ] = False,
    as_json: Annotated[bool, typer.Option("--json", help="Print the summary as JSON.")] = False,
    progress: ProgressOption = None,
) -> None:
    """Simulate paper 001's slip-slide rig: accelerometer fingertips on 3 textures x 4
    angles x 3 motor speeds, as the paper's CSV tree.

    Writes DIR/<texture>/<angle>/<rps>/data.csv (L_x..R_z as a fraction of +-5 g, v_slip,
    v_slide in m/s, 8 kHz) and DIR/scene.json (config, seed, ground truth per recording).

    Ingest: tactile ingest DIR --format accel-tree --out scene.h5; then
    tactile accel-prepare scene.h5 --out prepared.h5 for the training configs.
    """

    def body() -> None:
        from ..accel import VibroSceneConfig, load_vibro_config, simulate_vibro_slip

        cfg = load_vibro_config(config) if config is not None else VibroSceneConfig()
        if duration is not None:
            if not duration > 0:
                raise InputError(f"--duration (={duration}) must be positive")
            cfg = cfg.with_duration(duration)
        with RichProgress(enabled=progress) as bar:
            result = simulate_vibro_slip(cfg, out, seed=seed, progress=bar,
                                         overwrite=overwrite)
        summary = result.as_dict()
        if as_json:
            typer.echo(json.dumps(summary, indent=2))
            return
        typer.echo(f"vibro-slip -> {result.out_dir} (seed {result.seed}): "
                   f"{summary['n_recordings']} recordings, {summary['duration_s']:.1f} s in "
                   f"all, simulated in {summary['elapsed_s']:.1f} s")

    run_guarded(body, flags=FLAGS)


@app.command("vibrotouch")
def vibrotouch_command(
    out: Annotated[
        Path, typer.Option("--out", "-o", help="Output tactile HDF5 file.", show_default=False,
                           metavar="FILE")
    ],
    config: Annotated[
        Path | None,
        typer.Option("--config", "-c", help="Scene config YAML (see "
                     "configs/scene_vibrotouch.yaml); default: the built-in defaults.",
                     metavar="CONFIG"),
    ] = None,
    seed: Annotated[int, typer.Option(min=0, help="Random seed; fixes every sample.")] = 0,
    contact_trials: Annotated[
        int | None, typer.Option("--contact-trials", min=0,
                                 help="Override contact_trials (gripper-object trials).")
    ] = None,
    touch_trials: Annotated[
        int | None, typer.Option("--touch-trials", min=0,
                                 help="Override touch_trials (trials of 5 human touches).")
    ] = None,
    overwrite: Annotated[bool, typer.Option(help="Replace an existing output file.")] = False,
    as_json: Annotated[bool, typer.Option("--json", help="Print the summary as JSON.")] = False,
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

    def body() -> None:
        from ..vibro import SceneConfig, load_scene_config, simulate_vibrotouch

        cfg = load_scene_config(config) if config is not None else SceneConfig()
        if contact_trials is not None or touch_trials is not None:
            update = {k: v for k, v in (("contact_trials", contact_trials),
                                        ("touch_trials", touch_trials)) if v is not None}
            try:
                cfg = SceneConfig.model_validate({**cfg.model_dump(), **update})
            except ValueError as exc:
                raise InputError(str(exc).splitlines()[-1].strip()) from None
        with RichProgress(enabled=progress) as bar:
            result = simulate_vibrotouch(cfg, out, seed=seed, progress=bar,
                                         overwrite=overwrite,
                                         sources=[config] if config is not None else ())
        summary = result.as_dict()
        if as_json:
            typer.echo(json.dumps(summary, indent=2))
            return
        scen = [t["scenario"] for t in summary["trials"]]
        typer.echo(f"vibrotouch -> {result.out} (seed {result.seed}): "
                   f"{scen.count('contact')} contact and {scen.count('touch')} touch trials, "
                   f"{summary['duration_s']:.1f} s in all, simulated in "
                   f"{summary['elapsed_s']:.1f} s")

    run_guarded(body, flags=FLAGS)


@app.command("taxel-slip")
def taxel_slip_command(
    out: Annotated[
        Path, typer.Option("--out", "-o", help="Output tactile HDF5 file.", show_default=False,
                           metavar="FILE")
    ],
    config: Annotated[
        Path | None,
        typer.Option("--config", "-c", help="Scene config YAML (see "
                     "configs/scene_taxel_slip.yaml); default: the built-in defaults.",
                     metavar="CONFIG"),
    ] = None,
    seed: Annotated[int, typer.Option(min=0, help="Random seed; fixes every sample.")] = 0,
    preset: Annotated[
        list[str] | None,
        typer.Option("--preset", help="Simulate only this sensor (biotac, capacitive, pvdf); "
                     "repeatable. Default: the config's presets.", metavar="PRESET"),
    ] = None,
    trials: Annotated[
        int | None, typer.Option("--trials", min=1, help="Override trials_per_class (trials "
                                 "per preset and slip type).")
    ] = None,
    overwrite: Annotated[bool, typer.Option(help="Replace an existing output file.")] = False,
    as_json: Annotated[bool, typer.Option("--json", help="Print the summary as JSON.")] = False,
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

    def body() -> None:
        from ..taxel import SceneConfig, load_scene_config, simulate_taxel_slip

        cfg = load_scene_config(config) if config is not None else SceneConfig()
        update: dict[str, object] = {}
        if preset:
            from ..taxel.config import PRESET_NAMES

            unknown = [p for p in preset if p not in PRESET_NAMES]
            if unknown:
                raise InputError(f"--preset {unknown[0]!r} is not one of "
                                 f"{', '.join(PRESET_NAMES)}")
            update["presets"] = tuple(dict.fromkeys(preset))
        if trials is not None:
            update["trials_per_class"] = trials
        if update:
            try:
                cfg = SceneConfig.model_validate({**cfg.model_dump(), **update})
            except ValueError as exc:
                raise InputError(str(exc).splitlines()[1].strip()) from None
        with RichProgress(enabled=progress) as bar:
            result = simulate_taxel_slip(cfg, out, seed=seed, progress=bar,
                                         overwrite=overwrite)
        summary = result.as_dict()
        if as_json:
            typer.echo(json.dumps(summary, indent=2))
            return
        typer.echo(f"taxel-slip -> {result.out} (seed {result.seed}): "
                   f"{summary['n_trials']} trials ("
                   + ", ".join(f"{p} {c['hand']}+{c['world']}" for p, c in
                               result.counts.items())
                   + f" hand+world), simulated in {summary['elapsed_s']:.1f} s")

    run_guarded(body, flags=FLAGS)


# paper 002's scene lives in its own module (registered here, one insertion)
from .simulate_digit_press import digit_press_command  # noqa: E402

app.command("digit-press")(digit_press_command)

from .simulate_avoidance import digit_avoidance_command  # noqa: E402

app.command("digit-avoidance")(digit_avoidance_command)
