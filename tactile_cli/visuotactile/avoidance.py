"""The closed-loop slip-avoidance scene of paper 002, sec. V (Figs. 13-14):
``tactile simulate digit-avoidance OUT --seed N``.

An object is held on a DIGIT-like sensor (rendered by :mod:`.render` from the height maps
of :mod:`.shapes`). Interferences at known times push it (a short rigid shift, a slip);
a live monitor (:class:`~.monitor.MonitorManager`) watches the slip signal of the frames
as they are rendered and the simulated gripper obeys it: ``raise_grip`` presses the
object deeper (by ``raise_depth_mm`` over ``motion_s``), ``release_grip`` (``hold_s``
after the last slip) takes the extra depth back over ``motion_s``. The release changes
the contact shape too: the second peak of each pair in Fig. 14, which the manager must
not take for a slip.

The live monitor sees the intensity slip signal (:func:`.signals.intensity_maps`: the
frames' colour change from the reference on the tactile mesh), so the loop needs no
trained normal model; ``tactile monitor`` replays the written frames with either source.

Layout written (the image-sequence layout of ``tactile simulate digit-press``)::

    OUT/trials/<trial>/   reference.png, frame_0000.png ..., timestamps.csv (t_s)
    OUT/trial_labels.csv  trial, origin, dataset, object, slip, direction, slip_onset_s,
                          n_interferences, interference_s ("1.87;6.93;..." seconds)
    OUT/annotations.csv   trial, start_s, end_s, label: ``interference`` (each push) and
                          ``gripper_moving`` (each grip motion) intervals
    OUT/truth/<trial>.npz height_mm (n, H, W) float32, t_s, depth_mm, shift_px (n, 2),
                          gripper_moving (n,) bool, interference_s, live signal
    OUT/scene.json        config, seed, optics, tool version, the live monitor's events

The per-frame gripper motion reaches the HDF5 file as ``gripper_moving`` annotations
(``tactile ingest OUT/trials --trial-labels OUT/trial_labels.csv --annotations
OUT/annotations.csv``): image-sequence ingest carries no per-sample labels, and the
annotation intervals give the frames exactly (:func:`.signals.moving_flags`).
"""

from __future__ import annotations

import csv
import io
import json
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from pydantic import Field, model_validator

from ..config_file import load_yaml_model
from ..errors import check_seed
from ..interrupt import raise_if_requested
from ..progress import NullProgress, Progress
from ..store.outdir import output_folder
from .config import ObjectName, OpticsConfig, _Model
from .monitor import MonitorEvent, MonitorManager, SlipMonitor, static_threshold
from .signals import DEFAULT_MESH, mesh_slip_signal, moving_flags

#: ``dataset`` label of the scene's trials.
DATASET = "digit-avoidance"


class AvoidanceConfig(_Model):
    """The ``tactile simulate digit-avoidance`` scene (``configs/scene_digit_avoidance.yaml``
    repeats the defaults)."""

    version: int = Field(default=1, ge=1, le=1)
    optics: OpticsConfig = OpticsConfig()
    objects: list[ObjectName] = Field(default=["cable", "box"], min_length=1, max_length=100)
    """One trial per object (the paper's Fig. 14 holds a toy arm)."""
    frame_rate_hz: float = Field(default=30.0, gt=0, le=1000)
    static_s: float = Field(default=1.6, ge=1.2, le=60)
    """Static grip before the first interference (>= 1.2 s: the adaptive threshold
    averages 30 slip signals at 30 Hz)."""
    interferences: int = Field(default=5, ge=1, le=100)
    """Interferences per trial (Fig. 14: five)."""
    gap_s: tuple[float, float] = (4.6, 5.6)
    """Range of the time between interferences that each end a slip episode: longer
    than ``hold_s`` plus two motions, so every one gives a pair of peaks."""
    repeat_after_s: float | None = Field(default=1.6, gt=0, le=60)
    """If set, the second interference of each trial comes this soon after the first,
    while the monitor is still in slip mode (it restarts the hold timer); None: never."""
    tail_s: float = Field(default=4.8, gt=0, le=60)
    """Seconds recorded after the last interference (the release and its peak)."""
    push_s: float = Field(default=0.2, gt=0, le=5)
    """Duration of each push (the slip)."""
    push_mm: tuple[float, float] = (0.5, 1.2)
    """Range of the distance an interference moves the object in the gel plane (mm)."""
    depth_mm: float = Field(default=0.45, gt=0, le=5)
    """Press depth of the normal grip (mm)."""
    raise_depth_mm: float = Field(default=0.3, gt=0, le=5)
    """Extra press depth of the raised grip (mm)."""
    squeeze_mm: float = Field(default=0.6, ge=0, le=5)
    """How far the raised grip moves the object in the gel plane (mm, a direction drawn
    per trial; fingers never close perfectly square), undone by the release: with the
    depth change, the contact change behind both peaks of a pair (Fig. 14)."""
    motion_s: float = Field(default=0.3, gt=0, le=10)
    """Seconds the gripper takes to raise or release its grip (the live manager ignores
    the signal that long after each command)."""
    hold_s: float = Field(default=3.0, gt=0, le=60)
    """The live monitor's hold timer."""
    tremor_mm: float = Field(default=0.002, ge=0, le=1)
    """Standard deviation (mm) of the press depth's slow drift while held (correlation
    about 10 frames, :func:`.simulate.slow_drift`)."""
    mesh: tuple[int, int] = DEFAULT_MESH
    """Tactile mesh of the live monitor's slip signal (columns, rows)."""

    @model_validator(mode="after")
    def _ranges(self) -> AvoidanceConfig:
        for name in ("gap_s", "push_mm"):
            lo, hi = getattr(self, name)
            if not 0 < lo <= hi:
                raise ValueError(f"{name} (={[lo, hi]}) must be 0 < low <= high")
        episode = self.hold_s + 2 * self.motion_s + self.push_s
        if self.gap_s[0] <= episode:
            raise ValueError(f"gap_s (={list(self.gap_s)}) must start above hold_s + 2 x "
                             f"motion_s + push_s (={episode:g} s) so each interference ends "
                             "its slip episode")
        if self.repeat_after_s is not None and not (
                self.motion_s + self.push_s < self.repeat_after_s < self.hold_s):
            raise ValueError(f"repeat_after_s (={self.repeat_after_s}) must lie between "
                             "motion_s + push_s and hold_s (a new slip in slip mode)")
        if self.tail_s <= self.hold_s + self.motion_s:
            raise ValueError(f"tail_s (={self.tail_s}) must exceed hold_s + motion_s so the "
                             "last release is recorded")
        if min(self.mesh) < 2:
            raise ValueError(f"mesh (={list(self.mesh)}) must be at least 2 x 2")
        return self

    def with_overrides(self, *, objects: list[str] | None = None,
                       interferences: int | None = None) -> AvoidanceConfig:
        """A copy with the CLI's overrides, validated like the file."""
        from ..config_file import with_overrides

        return with_overrides(self, {"objects": ("objects", objects),
                                     "interferences": ("interferences", interferences)})


def load_avoidance_config(path: str | Path) -> AvoidanceConfig:
    """Read and validate a digit-avoidance scene config (one InputError line)."""
    return load_yaml_model(path, AvoidanceConfig, not_a_mapping="a digit-avoidance scene "
                           "config is a YAML mapping; see configs/scene_digit_avoidance.yaml")


def make_optics(cfg: OpticsConfig, seed: int) -> Any:
    """The scene's :class:`~.render.GelOptics`, drawn as ``tactile simulate digit-press``
    draws its unit for ``seed`` (:func:`.simulate.scene_optics`): another seed, another
    sensor."""
    from .config import DigitSceneConfig
    from .simulate import scene_optics

    return scene_optics(DigitSceneConfig(optics=cfg), seed)


def interference_times(cfg: AvoidanceConfig, rng: np.random.Generator) -> np.ndarray:
    """(interferences,) onsets in s: the first after ``static_s`` (+ up to 0.4 s), then
    gaps drawn from ``gap_s``, the second after ``repeat_after_s`` when that is set."""
    t = [cfg.static_s + float(rng.uniform(0.0, 0.4))]
    for i in range(1, cfg.interferences):
        gap = (cfg.repeat_after_s if i == 1 and cfg.repeat_after_s is not None
               else float(rng.uniform(*cfg.gap_s)))
        t.append(t[-1] + gap)
    return np.round(np.asarray(t), 6)


def _ramp(x: np.ndarray) -> np.ndarray:
    """Cosine ramp: 0 for x <= 0, 1 for x >= 1."""
    x = np.clip(x, 0.0, 1.0)
    return 0.5 - 0.5 * np.cos(np.pi * x)


@dataclass
class _Gripper:
    """The simulated gripper: press depth (mm) and the object's in-plane offset (px) follow
    its commands along a ``motion_s`` cosine ramp: raised, the depth is ``depth_mm +
    raise_mm`` and the offset ``squeeze_px``; released, ``depth_mm`` and no offset."""

    depth_mm: float
    raise_mm: float
    squeeze_px: tuple[float, float]
    motion_s: float
    moves: list[tuple[float, np.ndarray, np.ndarray]] = field(default_factory=list)

    def command(self, t_s: float, kind: str) -> None:
        now = self.state_at(t_s)
        raised = kind == "raise_grip"
        target = np.array([self.depth_mm + (self.raise_mm if raised else 0.0),
                           *(self.squeeze_px if raised else (0.0, 0.0))])
        self.moves.append((t_s, now, target))

    def state_at(self, t_s: float) -> np.ndarray:
        """(3,) depth (mm), offset x, y (px) at time ``t_s``."""
        if not self.moves:
            return np.array([self.depth_mm, 0.0, 0.0])
        t0, a, b = self.moves[-1]
        return a + (b - a) * _ramp(np.asarray((t_s - t0) / self.motion_s))

    def intervals(self) -> list[tuple[float, float]]:
        return [(t0, t0 + self.motion_s) for t0, _, _ in self.moves]


@dataclass(frozen=True)
class AvoidanceTrial:
    """One simulated trial: name, object, n_frames, interference onsets (s), the live
    monitor's threshold and events, and the gripper's motion intervals (s)."""

    name: str
    object: str
    n_frames: int
    interference_s: list[float]
    threshold: float
    events: list[MonitorEvent]
    moving_s: list[tuple[float, float]]

    def as_dict(self) -> dict[str, Any]:
        return {"trial": self.name, "object": self.object, "n_frames": self.n_frames,
                "interference_s": self.interference_s, "threshold": self.threshold,
                "gripper_moving_s": [list(m) for m in self.moving_s],
                "events": [e.as_dict() for e in self.events]}


@dataclass(frozen=True)
class AvoidanceResult:
    """What ``simulate_digit_avoidance`` wrote: the folder, the seed, each trial, seconds."""

    out_dir: Path
    seed: int
    trials: list[AvoidanceTrial]
    elapsed_s: float

    def as_dict(self) -> dict[str, Any]:
        return {"out_dir": str(self.out_dir), "seed": self.seed,
                "n_trials": len(self.trials),
                "n_frames": sum(t.n_frames for t in self.trials),
                "n_interferences": sum(len(t.interference_s) for t in self.trials),
                "n_raise_grip": sum(1 for t in self.trials for e in t.events
                                    if e.kind == "raise_grip"),
                "n_release_grip": sum(1 for t in self.trials for e in t.events
                                      if e.kind == "release_grip"),
                "elapsed_s": self.elapsed_s, "trials": [t.as_dict() for t in self.trials]}

    def summary_lines(self) -> list[str]:
        s = self.as_dict()
        return [f"digit-avoidance -> {self.out_dir} (seed {self.seed}): {s['n_trials']} trials, "
                f"{s['n_frames']} frames, {s['n_interferences']} interferences; live monitor: "
                f"{s['n_raise_grip']} raise and {s['n_release_grip']} release commands; "
                f"simulated in {self.elapsed_s:.1f} s"]


def _simulate_trial(name: str, obj: str, cfg: AvoidanceConfig, optics: Any,
                    rng: np.random.Generator, folder: Path, progress: Progress
                    ) -> tuple[AvoidanceTrial, dict[str, np.ndarray]]:
    from PIL import Image

    from .render import render_reference, render_rgb
    from .shapes import object_height
    from .signals import intensity_maps
    from .simulate import slow_drift

    dt = 1.0 / cfg.frame_rate_hz
    onsets = interference_times(cfg, rng)
    n = int(round((onsets[-1] + cfg.tail_s) * cfg.frame_rate_hz))
    t_s = np.round(np.arange(n) * dt, 6)  # as timestamps.csv holds them
    # each push: a direction and distance in the gel plane (px), applied over push_s
    angle = rng.uniform(0, 2 * np.pi, onsets.size)
    dist_px = rng.uniform(*cfg.push_mm, onsets.size) * optics.px_per_mm
    push = np.stack([np.cos(angle), np.sin(angle)], -1) * dist_px[:, None]
    progress_shift = _ramp((t_s[:, None] - onsets[None, :]) / cfg.push_s)  # (n, k)
    shift_px = progress_shift @ push  # (n, 2)
    centre = (optics.width_px / 2 + float(rng.uniform(-0.05, 0.05)) * optics.width_px,
              optics.height_px / 2 + float(rng.uniform(-0.05, 0.05)) * optics.height_px)
    obj_angle = float(rng.uniform(-30, 30))
    texture_seed = int(rng.integers(2**31))
    # the held grip and the LEDs drift slowly, as in the digit-press scene
    tremor = cfg.tremor_mm * slow_drift(rng, n)
    flicker = 1.0 + cfg.optics.flicker * slow_drift(rng, n)
    noise_rng = np.random.default_rng(rng.integers(2**63))

    reference = render_reference(optics, rng=noise_rng)
    Image.fromarray(reference).save(folder / "reference.png", compress_level=1)
    squeeze_angle = float(rng.uniform(0, 2 * np.pi))
    squeeze = cfg.squeeze_mm * optics.px_per_mm
    gripper = _Gripper(cfg.depth_mm, cfg.raise_depth_mm,
                       (squeeze * np.cos(squeeze_angle), squeeze * np.sin(squeeze_angle)),
                       cfg.motion_s)
    heights = np.empty((n, optics.height_px, optics.width_px), dtype=np.float32)
    depth = np.empty(n)
    signal = np.full(n, np.nan)
    events: list[MonitorEvent] = []
    manager: MonitorManager | None = None
    threshold = float("nan")
    prev_map: np.ndarray | None = None
    for k in range(n):
        raise_if_requested()
        grip = gripper.state_at(float(t_s[k]))
        depth[k] = max(float(grip[0]) + tremor[k], 1e-3)
        shift_px[k] += grip[1:]
        heights[k] = object_height(obj, optics, centre_px=centre,
                                   shift_px=(float(shift_px[k, 0]), float(shift_px[k, 1])),
                                   angle_deg=obj_angle, depth_mm=float(depth[k]),
                                   rng=np.random.default_rng(texture_seed))
        frame = render_rgb(heights[k], optics, rng=noise_rng, lighting_gain=float(flicker[k]))
        Image.fromarray(frame).save(folder / f"frame_{k:04d}.png", compress_level=1)
        # the live monitor: the slip signal of this frame against the previous one
        cur_map = intensity_maps(frame[None], reference)[0]
        if prev_map is not None:
            signal[k] = float(mesh_slip_signal(np.stack([prev_map, cur_map]), cfg.mesh)[1])
        prev_map = cur_map
        if manager is None:
            if np.isfinite(signal[: k + 1]).sum() >= 30:  # the adaptive-threshold request
                threshold = static_threshold(signal[: k + 1], n_static=30)
                manager = MonitorManager(SlipMonitor(threshold, hold_s=cfg.hold_s),
                                         motion_s=cfg.motion_s)
        else:
            new = manager.step(float(t_s[k]), k, float(signal[k]))
            events += new
            for e in new:
                if e.kind in ("raise_grip", "release_grip"):
                    gripper.command(float(t_s[k]), e.kind)
        progress.advance(1)
    with open(folder / "timestamps.csv", "w", encoding="utf-8", newline="") as fh:
        fh.write("t_s\n" + "".join(f"{t:.6f}\n" for t in t_s))
    moving = gripper.intervals()
    # rounded to 0.1 um, far below the gel's resolution, so the archive compresses
    truth = {"height_mm": np.round(heights, 4).astype(np.float32), "t_s": t_s,
             "depth_mm": depth.astype(np.float32),
             "shift_px": shift_px.astype(np.float32),
             "gripper_moving": moving_flags(t_s, moving),
             "interference_s": onsets, "live_signal": signal}
    return (AvoidanceTrial(name, obj, n, [float(x) for x in onsets], threshold, events,
                           moving), truth)


def ingest_shell_command(out: Path, px_per_mm: float) -> str:
    """The ``tactile ingest`` command line for an avoidance scene folder."""
    return (f"tactile ingest {out / 'trials'} --trial-labels {out / 'trial_labels.csv'} "
            f"--annotations {out / 'annotations.csv'} --px-per-mm {px_per_mm:g} "
            "--out avoidance.h5")


def _csv(rows: list[dict[str, Any]], columns: list[str]) -> str:
    buf = io.StringIO()
    writer = csv.DictWriter(buf, fieldnames=columns, lineterminator="\n")
    writer.writeheader()
    writer.writerows(rows)
    return buf.getvalue()


def simulate_digit_avoidance(cfg: AvoidanceConfig, out: str | Path, *, seed: int = 0,
                             progress: Progress | None = None,
                             overwrite: bool = False) -> AvoidanceResult:
    """Write the closed-loop avoidance scene to folder ``out`` (see the module docstring);
    one trial per ``cfg.objects`` entry, everything fixed by ``seed``. The folder is
    built beside ``out`` and renamed on success."""
    from .._version import __version__
    from ..store.provenance import current_command

    seed = check_seed(seed)
    progress = progress or NullProgress()
    started = time.perf_counter()
    rng = np.random.default_rng(seed)
    optics = make_optics(cfg.optics, seed)
    names = [f"avoid_{i:02d}_{obj}" for i, obj in enumerate(cfg.objects)]
    trials: list[AvoidanceTrial] = []
    with output_folder(out, overwrite=overwrite) as tmp:
        (tmp / "truth").mkdir()
        progress.start(None, "frames")
        for name, obj in zip(names, cfg.objects, strict=True):
            folder = tmp / "trials" / name
            folder.mkdir(parents=True)
            trial, truth = _simulate_trial(name, obj, cfg, optics,
                                           np.random.default_rng(rng.integers(2**63)),
                                           folder, progress)
            np.savez_compressed(tmp / "truth" / f"{name}.npz", **truth)
            trials.append(trial)
        progress.finish()
        labels = [{"trial": t.name, "origin": "simulated", "dataset": f"{DATASET} seed {seed}",
                   "object": t.object, "slip": "slip", "direction": "mixed",
                   "slip_onset_s": f"{t.interference_s[0]:.6f}",
                   "n_interferences": len(t.interference_s),
                   "interference_s": ";".join(f"{x:.6f}" for x in t.interference_s)}
                  for t in trials]
        (tmp / "trial_labels.csv").write_text(_csv(labels, list(labels[0])), encoding="utf-8")
        ann = [{"trial": t.name, "start_s": f"{s:.6f}", "end_s": f"{s + cfg.push_s:.6f}",
                "label": "interference"} for t in trials for s in t.interference_s]
        ann += [{"trial": t.name, "start_s": f"{a:.6f}", "end_s": f"{b:.6f}",
                 "label": "gripper_moving"} for t in trials for a, b in t.moving_s]
        (tmp / "annotations.csv").write_text(
            _csv(ann, ["trial", "start_s", "end_s", "label"]), encoding="utf-8")
        elapsed = time.perf_counter() - started
        result = AvoidanceResult(Path(out), seed, trials, round(elapsed, 3))
        scene = {"scene": "digit-avoidance", "seed": seed, "tool_version": __version__,
                 "command": current_command(), "config": cfg.model_dump(mode="json"),
                 "optics": optics.as_dict(),
                 "ingest": ingest_shell_command(Path(out), optics.px_per_mm),
                 "trials": [t.as_dict() for t in trials]}
        (tmp / "scene.json").write_text(json.dumps(scene, indent=2) + "\n", encoding="utf-8")
    return result


__all__ = ["DATASET", "AvoidanceConfig", "AvoidanceResult", "AvoidanceTrial",
           "interference_times", "load_avoidance_config", "make_optics",
           "simulate_digit_avoidance"]
