"""`tactile simulate marker-events --out DIR`: simulated recordings with their ground truth."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Annotated

import typer

from ..errors import InputError
from ._errors import Flag, run_guarded
from .progress import RichProgress

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
    progress: Annotated[
        bool | None,
        typer.Option(
            "--progress/--no-progress",
            help="Show a progress bar (default: when stderr is a terminal).",
            show_default=False,
        ),
    ] = None,
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
        from ..scene import SceneConfig, load_scene_config, simulate_marker_events

        cfg = load_scene_config(config) if config is not None else SceneConfig()
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
    progress: Annotated[
        bool | None,
        typer.Option("--progress/--no-progress",
                     help="Show a progress bar (default: when stderr is a terminal).",
                     show_default=False),
    ] = None,
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
