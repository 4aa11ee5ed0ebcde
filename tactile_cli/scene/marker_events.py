"""``tactile simulate marker-events``: raw event recordings of the paper's marker sensor with
their ground truth beside them (paper 000, secs. 3-4, eqs. 15-17).

Each trial is an approach-press-slip-release sequence at one force level. Its expected net
events per 20 ms bin follow eq. 16 in the press region and eq. 17 in the slip region
(:mod:`tactile_cli.fos.actions`), flattened for the biggest force level(s); they split into
positive (strip apertures opening) and negative (markers darkening) events, get Poisson
counting noise and uniform background events, and land on strips and markers of a
640 x 480 sensor (:mod:`tactile_cli.scene.events`). The output folder holds:

- ``<trial>.npy``: (n,) structured events ``t`` int64 us from the trial start, ``x``/``y``
  uint16 px, ``p`` int8 -1/+1, sorted by ``t`` (``tactile ingest`` reads it);
- ``trials.csv``: one row of ground truth per trial (FOS parameters, timeline,
  saturation limit, slip speed in m/s and px/s, event counts) and where it comes from
  (``origin`` = simulated, ``dataset`` = ``marker-events seed <seed>``: the labels of
  :mod:`tactile_cli.store.origin` once ingested with ``--trial-labels``);
- ``annotations.csv``: ``trial,start_s,end_s,label``, the four action regions per trial;
- ``scene.json``: resolved config, seed, tool version, command, sensor geometry and ROIs.

Everything is written into a temporary folder beside the output and renamed into place
only when complete; an existing non-empty output folder is replaced only with
``overwrite=True``.
"""

from __future__ import annotations

import csv
import io
import json
import os
import time
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from .._version import __version__
from ..errors import check_seed
from ..interrupt import raise_if_requested
from ..progress import NullProgress, Progress
from ..store.origin import DATASET_LABEL, ORIGIN_LABEL
from ..store.outdir import check_output_folder, output_folder
from ..store.provenance import current_command
from .config import MarkerSceneConfig
from .events import EVENT_DTYPE, trial_events
from .layout import SceneLayout, scene_layout
from .trials import SceneTrial, draw_trial, expected_rates, trial_rng

#: Columns of trials.csv after the ground truth of :meth:`SceneTrial.row`.
COUNT_COLUMNS = ("n_events", "n_positive", "n_negative", "n_background")
ANNOTATION_COLUMNS = ("trial", "start_s", "end_s", "label")
#: The value of the trial label ``origin`` (see :mod:`tactile_cli.store.origin`) and the
#: name that the ``dataset`` label of a scene's trials starts with.
ORIGIN = "simulated"
DATASET = "marker-events"
SCENE_FORMAT = "tactile-marker-events"
SCENE_FORMAT_VERSION = 1


@dataclass(frozen=True)
class SimulatedTrial:
    """One written trial: its ground truth and event counts (background of both
    polarities in ``n_background``)."""

    trial: SceneTrial
    n_events: int
    n_positive: int
    n_negative: int
    n_background: int

    def row(self) -> dict[str, Any]:
        return {**self.trial.row(), "n_events": self.n_events, "n_positive": self.n_positive,
                "n_negative": self.n_negative, "n_background": self.n_background}


@dataclass(frozen=True)
class SceneResult:
    """What :func:`simulate_marker_events` wrote.

    duration_s: summed trial durations (s); elapsed_s: wall time of the run (s).
    """

    out_dir: Path
    seed: int
    trials: tuple[SimulatedTrial, ...]
    duration_s: float
    elapsed_s: float

    @property
    def n_events(self) -> int:
        return sum(t.n_events for t in self.trials)

    def as_dict(self) -> dict[str, Any]:
        return {
            "out_dir": str(self.out_dir), "seed": self.seed, "n_trials": len(self.trials),
            "n_events": self.n_events,
            "n_positive": sum(t.n_positive for t in self.trials),
            "n_negative": sum(t.n_negative for t in self.trials),
            "duration_s": self.duration_s, "elapsed_s": self.elapsed_s,
            "trials": [t.row() for t in self.trials],
        }


def simulate_marker_events(
    config: MarkerSceneConfig,
    out_dir: str | Path,
    *,
    seed: int,
    progress: Progress | None = None,
    overwrite: bool = False,
    command: str | None = None,
) -> SceneResult:
    """Simulate every trial of ``config`` and write the scene folder ``out_dir``.

    ``seed`` (>= 0) fixes every byte of the output. ``command`` is recorded in scene.json
    (default: this process's command line). Raises :class:`InputError` when ``out_dir`` is
    a file, or a non-empty folder and ``overwrite`` is false; nothing is written then, and
    nothing is left behind when the run fails or is interrupted.
    """
    started = time.perf_counter()
    progress = progress or NullProgress()
    seed = check_seed(seed)
    out = check_output_folder(out_dir, overwrite=overwrite)
    layout = scene_layout(config)
    cells = [(g, k) for g in range(1, config.trials.groups + 1)
             for k in config.trials.selected_levels]
    written: list[SimulatedTrial] = []
    try:
        # built in a hidden folder beside ``out`` and renamed into place when complete
        with output_folder(out, overwrite=overwrite) as tmp:
            progress.start(len(cells), "marker events")
            for group, level in cells:
                raise_if_requested()
                rng = trial_rng(seed, group, level)
                trial = draw_trial(config, group, level, rng)
                drawn = trial_events(trial, expected_rates(trial, config), layout, rng)
                np.save(tmp / f"{trial.name}.npy", drawn.events, allow_pickle=False)
                written.append(SimulatedTrial(trial, drawn.n_events, drawn.n_positive,
                                              drawn.n_negative, drawn.n_background))
                progress.advance(1)
            _write_text(tmp / "trials.csv", _trials_csv(written, seed))
            _write_text(tmp / "annotations.csv", _annotations_csv([w.trial for w in written]))
            scene = _scene_json(config, layout, seed,
                                command if command is not None else current_command(), written)
            _write_text(tmp / "scene.json", json.dumps(scene, indent=2) + "\n")
            _fsync_folder(tmp)
    finally:
        progress.finish()
    duration = sum(w.trial.timeline.end_s for w in written)
    return SceneResult(out, seed, tuple(written), round(duration, 6),
                       time.perf_counter() - started)


# -- output ---------------------------------------------------------------------------------
def _fsync_folder(folder: Path) -> None:
    """Flush the files of ``folder`` and the folder itself to disk before the rename."""
    for path in [*folder.iterdir(), folder]:
        fd = os.open(path, os.O_RDONLY)
        try:
            os.fsync(fd)
        finally:
            os.close(fd)


def _write_text(path: Path, text: str) -> None:
    with open(path, "w", encoding="utf-8", newline="") as f:
        f.write(text)


def _cell(value: Any) -> str:
    if value is None:
        return ""
    if isinstance(value, float):
        return repr(value)  # shortest text that parses back to the same float
    return str(value)


def _table(columns: Sequence[str], rows: Sequence[dict[str, Any]]) -> str:
    buf = io.StringIO()
    writer = csv.writer(buf, lineterminator="\n")
    writer.writerow(columns)
    for row in rows:
        writer.writerow([_cell(row[c]) for c in columns])
    return buf.getvalue()


def _trials_csv(written: Sequence[SimulatedTrial], seed: int) -> str:
    """The ground truth of every trial, and its origin and data set as the last columns."""
    rows = [{**w.row(), ORIGIN_LABEL: ORIGIN, DATASET_LABEL: f"{DATASET} seed {seed}"}
            for w in written]
    return _table(list(rows[0]) if rows else [], rows)


def _annotations_csv(trials: Sequence[SceneTrial]) -> str:
    rows = [{"trial": t.name, "start_s": start, "end_s": end, "label": label}
            for t in trials for start, end, label in t.timeline.intervals()]
    return _table(ANNOTATION_COLUMNS, rows)


def _scene_json(config: MarkerSceneConfig, layout: SceneLayout, seed: int, command: str,
                written: Sequence[SimulatedTrial]) -> dict[str, Any]:
    s = config.sensor
    return {
        "format": SCENE_FORMAT,
        "format_version": SCENE_FORMAT_VERSION,
        "tool_name": "tactile-cli",
        "tool_version": __version__,
        "command": command,
        "seed": seed,
        "config": config.model_dump(mode="json"),
        "sensor": {
            "width_px": s.width_px, "height_px": s.height_px,
            "pixel_pitch_m": s.pixel_pitch_m, "focal_length_m": s.focal_length_m,
            "strip_distance_m": s.strip_distance_m,
            "slip_px_per_m": layout.px_per_m,
            "note": "strip_distance_m (delta of eqs. 3, 15) is an assumption of the scene",
        },
        **layout.as_dict(),
        "events": {"dtype": [[name, EVENT_DTYPE[name].str] for name in EVENT_DTYPE.names],
                   "t": "int64 microseconds from the trial start (t_origin_us = 0)",
                   "p": "+1 strip apertures opening and background ON, -1 markers "
                        "darkening and background OFF"},
        "bin_s": config.bin_s,
        "trials": [w.trial.name for w in written],
    }


__all__ = ["SceneResult", "SimulatedTrial", "simulate_marker_events"]
