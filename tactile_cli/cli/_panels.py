"""`tactile --help` as a table of contents: the commands in help panels, in the order of a
typical workflow (data in, methods, learning, then one panel per sensor chain with its
paper), and each command's help ending with a one-line example (taken from `make demo`).

:func:`arrange` applies :data:`PANELS` to the app once every command is registered;
tests/cli/test_panels.py checks that every command has a row and that every flag an
example uses is an option of its command.
"""

from __future__ import annotations

import typer

#: panel -> (command, example) rows, in the order `tactile --help` lists them
PANELS: dict[str, list[tuple[str, str]]] = {
    "Data in and out": [
        ("samples", "tactile samples raw --seed 0"),
        ("ingest", "tactile ingest raw/events.csv --width 640 --height 480 --out events.h5"),
        ("info", "tactile info events.h5"),
        ("validate", "tactile validate events.h5"),
        ("plot", "tactile plot events.h5 --out quicklook --max-trials 2"),
    ],
    "Learning and evaluation": [
        ("train", "tactile train configs/train_lstm_actions.yaml --data synth.h5 --out runs/lstm"),
        ("evaluate", "tactile evaluate runs/lstm --data scene_test.h5"),
        ("compare", "tactile compare runs/lstm runs/mlp --out compare"),
        ("perturb", "tactile perturb runs/lstm runs/mlp --data scene_test.h5 --out perturb"),
        ("sweep", "tactile sweep configs/sweep_vibro.yaml --data prepared0.h5 --eval-data "
                  "prepared1.h5 --out sweep"),
        ("seed-spread", "tactile seed-spread configs/train_mlp_actions.yaml --data synth.h5 "
                        "--cv 5 --seeds 0-4 --out spread"),
        ("export", "tactile export runs/lstm --out lstm.onnx"),
        ("report", "tactile report runs/lstm runs/mlp --data scene_test.h5 --out report"),
    ],
    "Methods on any stream": [
        ("fit-fos", "tactile fit-fos scene.h5 --plot fits --csv fits.csv"),
        ("features", "tactile features spectral taxel.h5 --out features.h5"),
        ("simulate", "tactile simulate marker-events --out scene --seed 0"),
    ],
    "Event-camera marker skin (paper 000)": [
        ("accumulate", "tactile accumulate scene.h5 --segment --plot counts"),
        ("grade", "tactile grade scene.h5 --plot grade"),
        ("synth", "tactile synth --fits scene.h5 --centroids scene/scene.json --n 240 --out "
                  "synth.h5"),
        ("frames", "tactile frames scene.h5 --rois scene/scene.json --window-ms 100 --out frames"),
        ("centroids", "tactile centroids scene.h5 --rois scene/scene.json --out centroids.h5"),
        ("slip-rate", "tactile slip-rate scene.h5 --rois scene/scene.json --plot slip"),
    ],
    "Accelerometer fingertips (paper 001)": [
        ("accel-prepare", "tactile accel-prepare accel.h5 --out prepared.h5 --segment-s 0.5"),
        ("detect-delay", "tactile detect-delay runs/cnn2d --data prepared.h5"),
    ],
    "DIGIT/GelSight cameras (paper 002)": [
        ("normal-labels", "tactile normal-labels calib.h5 --out pixels.h5 --plot calibration"),
        ("heightmap", "tactile heightmap trials.h5 --model runs/normals --out heights.h5"),
        ("slip-signal", "tactile slip-signal trials.h5 --source intensity --plot slip"),
        ("slip-imprint", "tactile slip-imprint lifts.h5 --plot imprint.png"),
        ("monitor", "tactile monitor avoid --plot monitor"),
    ],
    "Active vibration (paper 003)": [
        ("vibro-model", "tactile vibro-model configs/vibro_model.yaml --plot spectra.png"),
        ("detect-contact", "tactile detect-contact vibro.h5 --plot detections.png --find-band"),
    ],
    "Taxel arrays (paper 004)": [
        ("slip-interface", "tactile slip-interface taxel.h5 --plot features.png --out "
                           "slip_interface.json"),
    ],
}


def arrange(app: typer.Typer) -> None:
    """Put every command and group of ``app`` in its panel with its example (as the help's
    epilog), in the order of :data:`PANELS`; a command without a row stays last, in the
    default panel (the test names it)."""
    commands = {c.name: c for c in app.registered_commands}
    groups = {g.name: g for g in app.registered_groups}
    ordered = []
    for panel, rows in PANELS.items():
        for name, example in rows:
            info = commands.pop(name, None) or groups[name]
            info.rich_help_panel = panel
            info.epilog = f"Example: {example}"
            if name not in groups:
                ordered.append(info)
    app.registered_commands[:] = ordered + list(commands.values())


__all__ = ["PANELS", "arrange"]
