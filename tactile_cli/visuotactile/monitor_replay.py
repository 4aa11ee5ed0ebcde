"""``tactile monitor``: recorded visuotactile trials replayed through the slip-avoidance
monitor (paper 002, sec. V), frame by frame as a live stream would reach it.

For each trial of a tactile HDF5 file (image frames with their no-contact reference):

1. per-frame maps from the chosen source (:data:`.signals.SOURCES`): ``intensity``
   (brightness change from the reference, no model) or ``height`` (the height maps of a
   ``tactile heightmap`` file, or the frames through a trained normal network,
   ``tactile train configs/train_mlp_normals.yaml``, and Poisson integration);
2. the slip signal on the tactile mesh, one value per frame (the first NaN);
3. :func:`.monitor.replay`: the adaptive threshold from the first 30 static signals (or a
   fixed one), then the monitor manager and the state monitor;
4. where the truth is known, slips caught, missed and false, and the detection delay
   (:func:`.monitor.score_slips`).

Truth per trial: ``interference`` annotations (start and end: the avoidance scene), else
the labels ``slip``/``slip_onset_s``/``slip_end_s`` (``tactile simulate digit-press``: one
slip or none). A judged slip from an interference's onset to ``match_s`` after its end
belongs to it; any other is a false slip. Gripper motion: ``gripper_moving`` annotations
give per-frame flags (:func:`.signals.moving_flags`); without them the manager takes the
gripper to move for ``motion_s`` after each of its own commands.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import InputError
from ..interrupt import raise_if_requested
from ..progress import NullProgress, Progress
from ..store.trials import TactileFile, Trial
from .monitor import (
    DEFAULT_HOLD_S,
    DEFAULT_MOTION_S,
    DEFAULT_N_STATIC,
    DEFAULT_SCALE,
    MonitorEvent,
    SlipScore,
    replay,
    score_slips,
)
from .signals import DEFAULT_MESH, SOURCES, intensity_maps, mesh_slip_signal, moving_flags

#: Frames turned into maps at once (memory: block x H x W float32).
BLOCK_FRAMES = 64
#: A judged slip within this many seconds after an interference onset catches it.
DEFAULT_MATCH_S = 0.5


@dataclass(frozen=True)
class TrialMonitor:
    """One trial replayed through the monitor.

    trial: name. n_frames. threshold, start_frame: as :class:`.monitor.MonitorReplay`.
    events: the monitor's events in order. motion_from: ``annotations`` (per-frame
    ``gripper_moving`` flags) or ``motion_s`` (the manager's own model). interference_s:
    true onsets (s), None when the trial's truth is unknown. score: against them (None
    when unknown). t_s, signal, mode, moving: (n_frames,) arrays for plots.
    """

    trial: str
    n_frames: int
    threshold: float
    start_frame: int
    events: list[MonitorEvent]
    motion_from: str
    interference_s: list[float] | None
    score: SlipScore | None
    t_s: np.ndarray = field(repr=False)
    signal: np.ndarray = field(repr=False)
    mode: np.ndarray = field(repr=False)
    moving: np.ndarray = field(repr=False)

    def as_dict(self) -> dict[str, Any]:
        return {"trial": self.trial, "n_frames": self.n_frames, "threshold": self.threshold,
                "start_frame": self.start_frame, "motion_from": self.motion_from,
                "interference_s": self.interference_s,
                "score": None if self.score is None else self.score.as_dict(),
                "events": [e.as_dict() for e in self.events]}


@dataclass(frozen=True)
class MonitorFileResult:
    """Every trial of one file through the monitor, with the settings used and totals
    over the trials whose truth is known."""

    file: str
    source: str
    mesh: tuple[int, int]
    hold_s: float
    motion_s: float
    trials: list[TrialMonitor]
    plot: Path | None = None
    #: one line each: frames of another unit or scale than the normal model's calibration
    warnings: list[str] = field(default_factory=list)

    def totals(self) -> dict[str, Any]:
        scored = [t.score for t in self.trials if t.score is not None]
        delays = [d for s in scored for d in s.delays_s]
        n = sum(s.n_interferences for s in scored)
        caught = sum(s.caught for s in scored)
        return {"trials_scored": len(scored), "interferences": n, "caught": caught,
                "missed": sum(s.missed for s in scored),
                "false_slips": sum(s.false_slips for s in scored),
                "detection_rate": caught / n if n else None,
                "mean_delay_s": float(np.mean(delays)) if delays else None,
                "raise_grip": sum(1 for t in self.trials for e in t.events
                                  if e.kind == "raise_grip"),
                "release_grip": sum(1 for t in self.trials for e in t.events
                                    if e.kind == "release_grip")}

    def as_dict(self) -> dict[str, Any]:
        return {"file": self.file, "source": self.source, "mesh": list(self.mesh),
                "hold_s": self.hold_s, "motion_s": self.motion_s, "totals": self.totals(),
                "warnings": list(self.warnings),
                "trials": [t.as_dict() for t in self.trials]}

    def summary_lines(self) -> list[str]:
        """Per trial its threshold, mode changes, grip commands and score; the totals."""
        lines = [f"warning: {w}" for w in self.warnings]
        for t in self.trials:
            lines.append(f"{t.trial}: threshold {t.threshold:.6g} (monitor from frame "
                         f"{t.start_frame}; gripper motion from {t.motion_from})")
            lines += [f"  {e.t_s:8.3f} s  frame {e.frame:5d}  {e.kind:<12} {e.detail}"
                      for e in t.events
                      if e.kind in ("slip", "no_slip", "raise_grip", "release_grip")]
            ignored = sum(1 for e in t.events if e.kind == "ignored_moving")
            restarts = sum(1 for e in t.events if e.kind == "timer_restart")
            line = (f"  {restarts} timer restarts, {ignored} frames above threshold ignored "
                    "while the gripper moved")
            if t.score is not None:
                s = t.score
                delay = (f", mean delay {1e3 * sum(s.delays_s) / len(s.delays_s):.0f} ms"
                         if s.delays_s else "")
                line += (f"; truth: {s.caught}/{s.n_interferences} caught, {s.missed} "
                         f"missed, {s.false_slips} false slips{delay}")
            lines.append(line)
        tot = self.totals()
        if tot["trials_scored"]:
            rate = tot["detection_rate"]
            lines.append(f"all: {tot['caught']}/{tot['interferences']} interferences caught"
                         + (f" ({100 * rate:.0f} %)" if rate is not None else "")
                         + f", {tot['false_slips']} false slips, {tot['raise_grip']} raise and "
                         f"{tot['release_grip']} release commands")
        return lines


def parse_mesh(text: str) -> tuple[int, int]:
    """``"32x24"`` -> ``(32, 24)`` (columns, rows) by :func:`.mesh.parse_mesh`, its error
    as an InputError."""
    from .mesh import parse_mesh as _parse

    try:
        return _parse(text)
    except ValueError as exc:
        raise InputError(str(exc)) from None


class _MapSource:
    """Per-frame maps of one source; for ``height`` the normal model, loaded once."""

    def __init__(self, source: str, model_run: str | Path | None, stride: int = 1):
        from .heightmap import check_stride

        if source not in SOURCES:
            raise InputError(f"`source` (={source!r}) is not one of {', '.join(SOURCES)}")
        self.source = source
        self.stride = check_stride(stride)
        self.model: Any = None
        if source == "height" and model_run is not None:
            from .normals import NormalModel

            self.model = NormalModel.from_run(model_run)

    def blocks(self, tf: TactileFile, trial: Trial, block: int
               ) -> Iterator[tuple[np.ndarray, np.ndarray]]:
        """(t_s, maps) blocks of one trial in frame order: (b,) s and (b, H, W) float32.
        ``height``: the trial's ``height_mm`` stream (a ``tactile heightmap`` file), else
        its frames through the normal model; ``intensity``: its frames."""
        from .heightmap import STREAM, HeightMapper, frames_px_per_mm, read_height_maps

        if self.source == "height" and trial.has_signal(STREAM):
            maps, t_s, _ = read_height_maps(trial)
            for a in range(0, len(t_s), block):
                yield t_s[a:a + block], np.asarray(maps[a:a + block], dtype=np.float32)
            return
        if not trial.has_frames:
            raise InputError(f"trial {trial.name!r} has neither frames nor height maps",
                             path=trial.path, where=trial.where)
        frames = trial.frames()
        reference = frames.reference
        mapper = None
        if self.source == "height":
            if self.model is None:
                raise InputError("the height source needs height maps (a `tactile heightmap` "
                                 "file) or a trained normal model: pass `model_run` (a run of "
                                 "`tactile train configs/train_mlp_normals.yaml`)",
                                 path=trial.path)
            mapper = HeightMapper(self.model, frames_px_per_mm(tf, trial, None),
                                  stride=self.stride)
        for a in range(0, frames.n_frames, block):
            b = min(a + block, frames.n_frames)
            raise_if_requested()
            images = np.stack([frames[k] for k in range(a, b)])
            if mapper is None:
                maps = intensity_maps(images, reference)
            else:
                maps = np.stack([mapper(img, reference) for img in images])
            yield frames.t_s[a:b], maps


def trial_signal(tf: TactileFile, trial: Trial, source: _MapSource, mesh: tuple[int, int], *,
                 progress: Progress) -> tuple[np.ndarray, np.ndarray]:
    """(t_s, signal) of one trial: (n_frames,) each, ``signal[0]`` NaN. Maps come in
    blocks; each block's first signal uses the previous block's last map, so the result
    equals the slip signal of all maps at once."""
    times: list[np.ndarray] = []
    parts: list[np.ndarray] = []
    prev: np.ndarray | None = None
    for t_block, maps in source.blocks(tf, trial, BLOCK_FRAMES):
        stack = maps if prev is None else np.concatenate([prev[None], maps])
        try:
            s = mesh_slip_signal(stack, mesh)
        except ValueError as exc:
            raise InputError(str(exc), path=trial.path, where=trial.where) from None
        parts.append(s if prev is None else s[1:])
        times.append(np.asarray(t_block, dtype=np.float64))
        prev = maps[-1]
        progress.advance(maps.shape[0])
    if not parts:
        return np.zeros(0), np.zeros(0)
    return np.concatenate(times), np.concatenate(parts)


def trial_truth(trial: Trial) -> tuple[list[float], list[float | None]] | None:
    """True interferences of a trial as (onsets, ends) in s: its ``interference``
    annotations (start, end), else for ``slip=slip`` the labels ``slip_onset_s`` and
    ``slip_end_s`` (end None when absent) and for ``slip=no_slip`` none; None when
    unknown."""
    notes = sorted((a.start_s, a.end_s) for a in trial.annotations
                   if a.label == "interference")
    if notes:
        return [a for a, _ in notes], [b for _, b in notes]
    slip = trial.labels.get("slip")
    if slip == "no_slip":
        return [], []
    if slip == "slip":
        onset = _number(trial.labels.get("slip_onset_s"))
        if onset is None:
            raise InputError(f"trial label slip=slip needs a numeric slip_onset_s, got "
                             f"{trial.labels.get('slip_onset_s')!r}", path=trial.path,
                             where=f"{trial.where}/labels")
        return [onset], [_number(trial.labels.get("slip_end_s"))]
    return None


def _number(value: object) -> float | None:
    try:
        out = float(value)  # type: ignore[arg-type]
    except (TypeError, ValueError):
        return None
    return out if math.isfinite(out) else None


def monitor_file(path: str | Path, *, source: str = "intensity",
                 model_run: str | Path | None = None, mesh: tuple[int, int] = DEFAULT_MESH,
                 hold_s: float = DEFAULT_HOLD_S, motion_s: float = DEFAULT_MOTION_S,
                 threshold: float | None = None, n_static: int = DEFAULT_N_STATIC,
                 scale: float = DEFAULT_SCALE, match_s: float = DEFAULT_MATCH_S,
                 trials: Sequence[str] | None = None, stride: int = 1,
                 progress: Progress | None = None) -> MonitorFileResult:
    """Replay every trial with frames in tactile HDF5 file ``path`` (or the named
    ``trials``) through the monitor; see the module docstring. ``stride``: the height
    source's block side (:class:`.heightmap.HeightMapper`; 1: every pixel). InputError
    naming the file for a file without frames, an unknown trial, or too few static
    frames."""
    progress = progress or NullProgress()
    if min(mesh) < 1:
        raise InputError(f"`mesh` (={mesh}) must have at least one column and one row")
    maps = _MapSource(source, model_run, stride)
    results: list[TrialMonitor] = []
    with TactileFile(path) as tf:
        from .heightmap import STREAM, check_frame_times

        chosen = tf.trials(list(trials)) if trials else [
            t for t in tf.trials() if t.has_frames or t.has_signal(STREAM)]
        if not chosen:
            raise InputError("no trial has image frames or height maps; ingest image-sequence "
                             "folders (`tactile ingest OUT/trials`)", path=path)
        warnings: list[str] = []
        if maps.model is not None:  # before any work: frames the model was calibrated on
            from .heightmap import frames_px_per_mm

            for trial in chosen:
                if trial.has_frames and not trial.has_signal(STREAM):
                    for w in maps.model.check_frames(tf, trial,
                                                     frames_px_per_mm(tf, trial, None)):
                        if w not in warnings:
                            warnings.append(w)
        progress.start(None, "frames")
        for trial in chosen:
            t_s, signal = trial_signal(tf, trial, maps, mesh, progress=progress)
            check_frame_times(t_s, trial)
            intervals = [(a.start_s, a.end_s) for a in trial.annotations
                         if a.label == "gripper_moving"]
            flags = moving_flags(t_s, intervals) if intervals else None
            try:
                rep = replay(signal, t_s, threshold=threshold, n_static=n_static,
                             scale=scale, hold_s=hold_s, motion_s=motion_s,
                             gripper_moving=flags)
            except InputError as exc:
                raise InputError(exc.message, path=trial.path, where=trial.where) from None
            truth = trial_truth(trial)
            score = None if truth is None else score_slips(rep.slip_times_s, truth[0],
                                                           ends_s=truth[1], match_s=match_s)
            results.append(TrialMonitor(trial.name, int(signal.size), rep.threshold,
                                        rep.start_frame, rep.events,
                                        "annotations" if flags is not None else "motion_s",
                                        None if truth is None else truth[0], score, t_s,
                                        signal, rep.mode, rep.moving))
        progress.finish()
    return MonitorFileResult(str(path), source, (int(mesh[0]), int(mesh[1])), float(hold_s),
                             float(motion_s), results, warnings=warnings)


#: ``ingest_frames(inputs, out, options)``: ingest the image-sequence folder(s) ``inputs``
#: into the tactile file ``out`` with ``options`` (``px_per_mm``, ``trial_labels``,
#: ``annotations``) and return ``out`` (``tactile monitor`` passes ``tactile_cli.ingest``).
IngestFrames = Callable[[Path, Path, dict[str, Any]], Path]


def frames_folder_plan(folder: str | Path) -> tuple[Path, dict[str, Any]]:
    """What to ingest from a folder of frames: a scene folder (``trials/`` beside
    ``scene.json``) gives its ``trials/`` with the scene's ``optics.px_per_mm`` and its
    ``trial_labels.csv`` and ``annotations.csv`` where present; any other folder is
    image-sequence folders without options."""
    from ..config_file import parse_json, read_text
    from ..input_guard import note_input

    folder = Path(folder)
    note_input(folder, tree=True)
    scene = folder / "scene.json"
    if not ((folder / "trials").is_dir() and scene.is_file()):
        return folder, {}
    doc = parse_json(read_text(scene, "scene file"), scene)
    try:
        px = float(doc["optics"]["px_per_mm"])
    except (ValueError, KeyError, TypeError) as exc:
        raise InputError(f"cannot read optics.px_per_mm ({type(exc).__name__}: {exc})",
                         path=scene) from None
    if not (math.isfinite(px) and px > 0):
        raise InputError(f"optics.px_per_mm is {px}; expected a positive number of pixels "
                         "per mm", path=scene)
    labels, notes = folder / "trial_labels.csv", folder / "annotations.csv"
    return folder / "trials", {"px_per_mm": px,
                               "trial_labels": labels if labels.is_file() else None,
                               "annotations": notes if notes.is_file() else None}


def monitor_input(path: str | Path, *, ingest_frames: IngestFrames | None = None,
                  plot: str | Path | None = None, overwrite: bool = False,
                  model_run: str | Path | None = None, mesh: str | tuple[int, int] = DEFAULT_MESH,
                  progress: Progress | None = None, **settings: Any) -> MonitorFileResult:
    """:func:`monitor_file` on ``path``: a tactile file, or a folder of frames (see
    :func:`frames_folder_plan`) ingested by ``ingest_frames`` into a temporary file first;
    ``settings``: the other arguments of :func:`monitor_file`. With ``plot`` one PNG per
    trial in that folder (added to it, same-named files replaced; ``overwrite``: the folder
    replaced whole). ``plot`` is checked before any work and may not be, hold or lie inside
    an input (the recording's folder above all: the replay never deletes its frames)."""
    import dataclasses
    import tempfile

    from ..input_guard import check_outputs
    from ..store.outdir import check_output_folder, output_folder
    from .heightmap import absolute_folder

    path = Path(path)
    plot = None if plot is None else absolute_folder(plot)
    if not path.exists():
        raise InputError("file not found", path=path)
    model = None if model_run is None else Path(model_run) / "model.pt"
    check_outputs({"plot": plot}, [path, model], trees=[path] if path.is_dir() else [])
    if plot is not None:
        check_output_folder(plot, overwrite=overwrite, merge=not overwrite)
    cells = parse_mesh(mesh) if isinstance(mesh, str) else mesh
    with tempfile.TemporaryDirectory(prefix="tactile-monitor-") as tmp:
        data = path
        if path.is_dir():
            if ingest_frames is None:
                raise InputError("a folder of frames needs `ingest_frames` (tactile_cli.ingest) "
                                 "to be read; or give its ingested tactile file", path=path)
            inputs, options = frames_folder_plan(path)
            data = ingest_frames(inputs, Path(tmp) / "frames.h5", options)
        result = monitor_file(data, model_run=model_run, mesh=cells, progress=progress,
                              **settings)
    if plot is not None:
        with output_folder(plot, overwrite=overwrite, merge=not overwrite) as folder:
            for trial in result.trials:
                plot_trial(trial, folder / f"{trial.trial}.png")
    return dataclasses.replace(result, file=str(path),
                               plot=None if plot is None else Path(plot))


def plot_trial(result: TrialMonitor, out: str | Path) -> None:
    """A PNG of one replayed trial like Fig. 14: slip signal and threshold against time,
    slip mode shaded, gripper motion shaded, grip commands and true interferences marked."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(10, 3.2), dpi=110)
    t = result.t_s
    ax.plot(t, result.signal, lw=0.9, color="black", label="slip signal")
    ax.axhline(result.threshold, color="tab:red", ls="--", lw=0.9, label="threshold")
    ymax = float(np.nanmax(result.signal)) if np.isfinite(result.signal).any() else 1.0
    ax.fill_between(t, 0, ymax * 1.05, where=result.mode, color="tab:orange", alpha=0.15,
                    step="post", label="slip mode")
    ax.fill_between(t, 0, ymax * 1.05, where=result.moving, color="tab:blue", alpha=0.15,
                    step="post", label="gripper moving (not judged)")
    for e in result.events:
        if e.kind in ("raise_grip", "release_grip"):
            ax.axvline(e.t_s, color="tab:green" if e.kind == "raise_grip" else "tab:purple",
                       lw=0.8)
    for i, onset in enumerate(result.interference_s or []):
        ax.axvline(onset, color="tab:red", lw=0.6, ls=":",
                   label="interference (truth)" if i == 0 else None)
    ax.set_xlabel("time (s)")
    ax.set_ylabel("slip signal")
    ax.set_title(f"{result.trial}: green = raise grip, purple = release grip")
    ax.legend(loc="upper right", fontsize=7)
    fig.tight_layout()
    fig.savefig(out)
    plt.close(fig)


__all__ = ["BLOCK_FRAMES", "DEFAULT_MATCH_S", "IngestFrames", "MonitorFileResult",
           "TrialMonitor", "frames_folder_plan", "monitor_file", "monitor_input", "parse_mesh",
           "plot_trial", "trial_signal", "trial_truth"]
