"""``tactile simulate digit-press``: a DIGIT-like scene with known height maps (paper 002).

Two parts, written as the image-sequence folders labs store (``tactile ingest`` reads
them):

- **Calibration presses** (sec. II-B): a ball bearing of known radius pressed at a random
  place and depth, one frame per press plus its no-contact reference;
- **Trials** (sec. III-IV): an object (cable, box face, fabric, hex keys) held still for at
  least 1.2 s, then, except in the no-slip trial of each object, slipping in one direction
  (+x, -x, +y, -y in the sensor plane, ``z`` pressing toward the sensor, ``rot`` turning
  about its centre), then held again; 30 Hz frames with ``timestamps.csv``.

Layout of ``OUT``::

    calibration/ball_NN/     reference.png, frame_0000.png, timestamps.csv (t_s = 0)
    trials/<object>_NN/      reference.png, frame_0000.png ..., timestamps.csv (t_s)
    calibration_labels.csv   trial, origin, dataset, ball_radius_mm, depth_mm,
                             true_centre_x_px, true_centre_y_px, true_contact_radius_px
    trial_labels.csv         trial, origin, dataset, object, slip (slip|no_slip), direction,
                             slip_onset_s (empty for no_slip), slip_end_s, depth_mm, slip_mm
    truth/<trial>.npz        height_mm (n_frames, H, W) float32 (the gel's indentation) and
                             t_s; presses also centre_px, radius_px (contact circle),
                             ball_radius_mm, depth_mm; trials shift_px, angle_deg, depth_mm
                             per frame (np.savez_compressed; read with allow_pickle=False)
    scene.json               config, seed, optics (px_per_mm, lights), tool version

Then (``px_per_mm`` reaches the file as the sensor attribute of the same name)::

    tactile ingest OUT/calibration --trial-labels OUT/calibration_labels.csv \\
        --px-per-mm 16 --out calib.h5
    tactile ingest OUT/trials --trial-labels OUT/trial_labels.csv --px-per-mm 16 --out trials.h5

``seed`` fixes every byte. The seed also draws this unit's lighting (``optics.lighting_jitter``):
another seed is another DIGIT, so held-out figures on another seed include that change.
"""

from __future__ import annotations

import json
import time
import zipfile
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np

from .._version import __version__
from ..errors import InputError, check_seed
from ..interrupt import raise_if_requested
from ..progress import NullProgress, Progress
from ..store.outdir import check_output_folder, output_folder
from ..store.provenance import current_command
from .config import DigitSceneConfig
from .render import (
    DIGIT_HEIGHT_PX,
    DIGIT_PX_PER_MM,
    DIGIT_WIDTH_PX,
    GelOptics,
    Led,
    render_reference,
    render_rgb,
)
from .shapes import ball_cap, contact_radius_px, object_height

CALIBRATION_LABELS = ("trial", "origin", "dataset", "ball_radius_mm", "depth_mm",
                      "true_centre_x_px", "true_centre_y_px", "true_contact_radius_px")
TRIAL_LABELS = ("trial", "origin", "dataset", "object", "slip", "direction", "slip_onset_s",
                "slip_end_s", "depth_mm", "slip_mm")
#: PNG zlib level: frames are noisy and hardly compress, so the fastest level is used.
PNG_COMPRESS_LEVEL = 1


def scene_optics(config: DigitSceneConfig, seed: int) -> GelOptics:
    """The sensor of scene ``seed``: the config's optics with this unit's lighting drawn
    from the seed (:meth:`GelOptics.jittered`)."""
    o = config.optics
    base = GelOptics(width_px=o.width_px, height_px=o.height_px, px_per_mm=o.px_per_mm,
                     noise_std=o.noise_std)
    # keep the LEDs at the same places relative to the frame for other sizes and scales
    sx = (o.width_px / o.px_per_mm) / (DIGIT_WIDTH_PX / DIGIT_PX_PER_MM)
    sy = (o.height_px / o.px_per_mm) / (DIGIT_HEIGHT_PX / DIGIT_PX_PER_MM)
    if (sx, sy) != (1.0, 1.0):
        base = replace(base, leds=tuple(Led(led.x_mm * sx, led.y_mm * sy, led.z_mm, led.rgb)
                                        for led in base.leds))
    rng = np.random.default_rng(np.random.SeedSequence([seed, 0]))
    return base.jittered(rng, amount=o.lighting_jitter)


@dataclass(frozen=True)
class TrialPlan:
    """One object trial, drawn before any frame is rendered. Times in s, lengths in mm."""

    name: str
    object: str
    direction: str
    centre_px: tuple[float, float]
    angle_deg: float
    depth_mm: float
    slip_onset_s: float | None
    slip_s: float
    slip_mm: float

    def motion(self, t_s: np.ndarray, px_per_mm: float
               ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Per frame: shift_px (n, 2), angle_deg (n,), depth_mm (n,) before tremor."""
        n = len(t_s)
        if self.slip_onset_s is None:
            p = np.zeros(n)
        else:
            u = np.clip((t_s - self.slip_onset_s) / self.slip_s, 0.0, 1.0)
            p = 0.5 - 0.5 * np.cos(np.pi * u)  # smooth start and stop
        shift = np.zeros((n, 2))
        angle = np.full(n, self.angle_deg)
        depth = np.full(n, self.depth_mm)
        dist_px = self.slip_mm * px_per_mm * p
        axis = {"+x": (0, 1.0), "-x": (0, -1.0), "+y": (1, 1.0), "-y": (1, -1.0)}
        if self.direction in axis:
            k, sign = axis[self.direction]
            shift[:, k] = sign * dist_px
        elif self.direction == "rot":
            angle = angle + 4.0 * self.slip_mm * p
        elif self.direction == "z":
            depth = depth * (1.0 + 0.15 * self.slip_mm * p)
        return shift, angle, depth


def plan_trials(config: DigitSceneConfig, seed: int) -> list[TrialPlan]:
    """Every object trial of the scene, drawn from ``seed`` (the first trial of each object
    holds still; the others slip in ``trials.directions`` taken in turn)."""
    tc, oc = config.trials, config.optics
    slip_dirs = [d for d in tc.directions if d != "none"] or ["none"]
    plans = []
    for j, obj in enumerate(tc.objects):
        for k in range(tc.per_object):
            rng = np.random.default_rng(np.random.SeedSequence([seed, 2, j, k]))
            direction = "none" if k == 0 else slip_dirs[(k - 1 + j) % len(slip_dirs)]
            slip = direction != "none"
            plans.append(TrialPlan(
                name=f"{obj}_{k:02d}", object=obj, direction=direction,
                centre_px=(oc.width_px / 2 + float(rng.uniform(-0.08, 0.08)) * oc.width_px,
                           oc.height_px / 2 + float(rng.uniform(-0.08, 0.08)) * oc.height_px),
                angle_deg=float(rng.uniform(0, 180)) if obj != "box"
                else float(rng.uniform(-15, 15)),
                depth_mm=float(rng.uniform(*tc.depth_mm)),
                slip_onset_s=round(float(rng.uniform(*tc.static_s)), 4) if slip else None,
                slip_s=round(float(rng.uniform(*tc.slip_s)), 4) if slip else 0.0,
                slip_mm=round(float(rng.uniform(*tc.slip_mm)), 4) if slip else 0.0))
    return plans


@dataclass(frozen=True)
class PressPlan:
    """One ball-bearing press: centre (x, y) px, ball radius and depth in mm."""

    name: str
    centre_px: tuple[float, float]
    ball_radius_mm: float
    depth_mm: float


def plan_presses(config: DigitSceneConfig, seed: int) -> list[PressPlan]:
    """Every calibration press of the scene, drawn from ``seed``."""
    cc, oc = config.calibration, config.optics
    plans = []
    width = max(2, len(str(max(cc.presses - 1, 0))))
    for i in range(cc.presses):
        rng = np.random.default_rng(np.random.SeedSequence([seed, 1, i]))
        margin_x = min(cc.margin_px, oc.width_px // 2 - 1)
        margin_y = min(cc.margin_px, oc.height_px // 2 - 1)
        plans.append(PressPlan(
            name=f"ball_{i:0{width}d}",
            centre_px=(round(float(rng.uniform(margin_x, oc.width_px - margin_x)), 3),
                       round(float(rng.uniform(margin_y, oc.height_px - margin_y)), 3)),
            ball_radius_mm=float(rng.choice(cc.ball_radius_mm)),
            depth_mm=round(float(rng.uniform(*cc.depth_mm)), 4)))
    return plans


@dataclass(frozen=True)
class DigitSceneResult:
    """What ``simulate_digit_press`` wrote."""

    out_dir: Path
    seed: int
    presses: tuple[PressPlan, ...]
    trials: tuple[TrialPlan, ...]
    n_frames: int
    px_per_mm: float
    elapsed_s: float

    def as_dict(self) -> dict[str, Any]:
        return {"out_dir": str(self.out_dir), "seed": self.seed,
                "n_calibration_presses": len(self.presses), "n_trials": len(self.trials),
                "n_slip": sum(t.slip_onset_s is not None for t in self.trials),
                "n_frames": self.n_frames, "px_per_mm": self.px_per_mm,
                "elapsed_s": round(self.elapsed_s, 3),
                "ingest": ingest_shell_commands(self.out_dir, self.px_per_mm,
                                                presses=bool(self.presses),
                                                trials=bool(self.trials))}

    def summary_lines(self) -> list[str]:
        s = self.as_dict()
        return [f"digit-press -> {self.out_dir} (seed {self.seed}): "
                f"{s['n_calibration_presses']} calibration presses, {s['n_trials']} trials "
                f"({s['n_slip']} slipping), {s['n_frames']} frames, simulated in "
                f"{self.elapsed_s:.1f} s", *(f"  then: {line}" for line in s["ingest"])]


def ingest_shell_commands(out: Path, px_per_mm: float, *, presses: bool = True,
                          trials: bool = True) -> list[str]:
    """The ``tactile ingest`` command lines for a scene folder (its parts that exist)."""
    lines = []
    if presses:
        lines.append(f"tactile ingest {out / 'calibration'} --trial-labels "
                     f"{out / 'calibration_labels.csv'} --px-per-mm {px_per_mm:g} "
                     "--out calib.h5")
    if trials:
        lines.append(f"tactile ingest {out / 'trials'} --trial-labels "
                     f"{out / 'trial_labels.csv'} --px-per-mm {px_per_mm:g} --out trials.h5")
    return lines


def simulate_digit_press(config: DigitSceneConfig, out_dir: str | Path, *, seed: int,
                         progress: Progress | None = None, overwrite: bool = False,
                         command: str | None = None) -> DigitSceneResult:
    """Render every press and trial of ``config`` and write the scene folder ``out_dir``
    (layout: module docstring). ``seed`` (>= 0) fixes every byte. Raises
    :class:`InputError` when ``out_dir`` is a file, or a non-empty folder and
    ``overwrite`` is false; nothing is left behind when the run fails or is interrupted.
    """
    started = time.perf_counter()
    progress = progress or NullProgress()
    seed = check_seed(seed)
    out = check_output_folder(out_dir, overwrite=overwrite)
    optics = scene_optics(config, seed)
    presses = plan_presses(config, seed)
    trials = plan_trials(config, seed)
    tc = config.trials
    n_per_trial = max(1, int(round(tc.duration_s * tc.frame_rate_hz)))
    n_frames = len(presses) + n_per_trial * len(trials)
    dataset = f"digit-press seed {seed}"
    try:
        with output_folder(out, overwrite=overwrite) as tmp:
            progress.start(n_frames, "frames")
            (tmp / "truth").mkdir()
            for i, press in enumerate(presses):
                raise_if_requested()
                _write_press(tmp, press, optics, config, seed, i)
                progress.advance(1)
            for j, plan in enumerate(trials):
                raise_if_requested()
                _write_trial(tmp, plan, optics, config, seed, j, n_per_trial, progress)
            _write_csv(tmp / "calibration_labels.csv", CALIBRATION_LABELS,
                       [[p.name, "simulated", dataset, p.ball_radius_mm, p.depth_mm,
                         p.centre_px[0], p.centre_px[1],
                         round(contact_radius_px(optics, p.ball_radius_mm, p.depth_mm), 4)]
                        for p in presses])
            _write_csv(tmp / "trial_labels.csv", TRIAL_LABELS,
                       [[t.name, "simulated", dataset, t.object,
                         "no_slip" if t.slip_onset_s is None else "slip", t.direction,
                         t.slip_onset_s,
                         None if t.slip_onset_s is None else round(t.slip_onset_s + t.slip_s, 4),
                         round(t.depth_mm, 4), t.slip_mm] for t in trials])
            scene = {"scene": "digit-press", "seed": seed, "tool_version": __version__,
                     "command": command if command is not None else current_command(),
                     "config": config.model_dump(mode="json"), "optics": optics.as_dict(),
                     "n_frames_per_trial": n_per_trial,
                     "ingest": ingest_shell_commands(out, optics.px_per_mm,
                                                     presses=bool(presses),
                                                     trials=bool(trials))}
            (tmp / "scene.json").write_text(json.dumps(scene, indent=2) + "\n",
                                            encoding="utf-8")
    finally:
        progress.finish()
    return DigitSceneResult(out, seed, tuple(presses), tuple(trials), n_frames,
                            optics.px_per_mm, time.perf_counter() - started)


def _gain(rng: np.random.Generator, flicker: float) -> float:
    return float(1.0 + flicker * rng.standard_normal()) if flicker > 0 else 1.0


#: Correlation time (frames, Gaussian sigma) of the slow drifts within a trial.
DRIFT_FRAMES = 10.0


def slow_drift(rng: np.random.Generator, n: int, *, sigma_frames: float = DRIFT_FRAMES
               ) -> np.ndarray:
    """(n,) float64 smooth random drift with unit standard deviation: white noise low-passed
    by a Gaussian of ``sigma_frames``. A held grip and the LEDs drift slowly; white
    frame-to-frame jitter would make the static slip signal heavy-tailed (its largest
    values several times its mean), which the paper's threshold of twice the static mean
    could not live with (sec. V: the static signal "is within a stable range")."""
    from scipy.ndimage import gaussian_filter1d

    pad = int(4 * sigma_frames)
    drift = gaussian_filter1d(rng.standard_normal(n + 2 * pad), sigma_frames)[pad:pad + n]
    return drift / np.sqrt(1.0 / (2.0 * np.sqrt(np.pi) * sigma_frames))


def _save_png(path: Path, image: np.ndarray) -> None:
    from PIL import Image

    Image.fromarray(image).save(path, compress_level=PNG_COMPRESS_LEVEL)


def _write_press(tmp: Path, press: PressPlan, optics: GelOptics, config: DigitSceneConfig,
                 seed: int, i: int) -> None:
    rng = np.random.default_rng(np.random.SeedSequence([seed, 3, i]))
    folder = tmp / "calibration" / press.name
    folder.mkdir(parents=True)
    flicker = config.optics.flicker
    height = ball_cap(optics, press.centre_px, press.ball_radius_mm, press.depth_mm)
    _save_png(folder / "reference.png",
              render_reference(optics, rng=rng, lighting_gain=_gain(rng, flicker)))
    _save_png(folder / "frame_0000.png",
              render_rgb(height, optics, rng=rng, lighting_gain=_gain(rng, flicker)))
    (folder / "timestamps.csv").write_text("t_s\n0.0\n", encoding="utf-8")
    np.savez_compressed(
        tmp / "truth" / f"{press.name}.npz", height_mm=height[None], t_s=np.zeros(1),
        centre_px=np.asarray(press.centre_px, dtype=np.float64),
        radius_px=np.float64(contact_radius_px(optics, press.ball_radius_mm, press.depth_mm)),
        ball_radius_mm=np.float64(press.ball_radius_mm), depth_mm=np.float64(press.depth_mm))


def _write_trial(tmp: Path, plan: TrialPlan, optics: GelOptics, config: DigitSceneConfig, seed: int,
                 j: int, n: int, progress: Progress) -> None:
    rng = np.random.default_rng(np.random.SeedSequence([seed, 4, j]))
    texture_seed = np.random.SeedSequence([seed, 5, j])
    folder = tmp / "trials" / plan.name
    folder.mkdir(parents=True)
    tc = config.trials
    t_s = np.arange(n, dtype=np.float64) / tc.frame_rate_hz
    shift, angle, depth = plan.motion(t_s, optics.px_per_mm)
    depth = np.maximum(depth + tc.tremor_mm * slow_drift(rng, n), 1e-3)
    flicker = config.optics.flicker
    _save_png(folder / "reference.png",
              render_reference(optics, rng=rng, lighting_gain=_gain(rng, flicker)))
    gains = 1.0 + flicker * slow_drift(rng, n)
    heights = np.empty((n, optics.height_px, optics.width_px), dtype=np.float32)
    for k in range(n):
        raise_if_requested()
        heights[k] = object_height(plan.object, optics, centre_px=plan.centre_px,
                                   shift_px=(float(shift[k, 0]), float(shift[k, 1])),
                                   angle_deg=float(angle[k]), depth_mm=float(depth[k]),
                                   rng=np.random.default_rng(texture_seed))
        _save_png(folder / f"frame_{k:04d}.png",
                  render_rgb(heights[k], optics, rng=rng, lighting_gain=float(gains[k])))
        progress.advance(1)
    (folder / "timestamps.csv").write_text(
        "t_s\n" + "".join(f"{float(t)!r}\n" for t in np.round(t_s, 6)), encoding="utf-8")
    # rounded to 0.1 um, far below the gel's resolution, so the archive compresses
    np.savez_compressed(tmp / "truth" / f"{plan.name}.npz",
                        height_mm=np.round(heights, 4).astype(np.float32), t_s=t_s,
                        shift_px=shift, angle_deg=angle, depth_mm=depth)


def _write_csv(path: Path, header: tuple[str, ...], rows: list[list[Any]]) -> None:
    def cell(v: Any) -> str:
        if v is None:
            return ""
        return repr(v) if isinstance(v, float) else str(v)

    text = ",".join(header) + "\n" + "".join(",".join(cell(v) for v in row) + "\n"
                                            for row in rows)
    path.write_text(text, encoding="utf-8")


def read_truth(path: str | Path) -> dict[str, np.ndarray]:
    """The arrays of one ``truth/<trial>.npz`` (InputError naming the file if unreadable)."""
    path = Path(path)
    try:  # the file opened here, so that numpy's errors on a damaged archive close it
        with open(path, "rb") as fh:
            z = np.load(fh, allow_pickle=False)
            if not hasattr(z, "files"):
                raise ValueError("a .npy array, not an .npz archive")
            with z:
                return {k: z[k] for k in z.files}
    except (OSError, ValueError, EOFError, zipfile.BadZipFile) as exc:
        reason = " ".join(str(exc).split()) or type(exc).__name__
        raise InputError(f"cannot read the scene truth ({reason})", path=path) from None


__all__ = ["CALIBRATION_LABELS", "TRIAL_LABELS", "DigitSceneResult", "PressPlan", "TrialPlan",
           "ingest_shell_commands", "plan_presses", "plan_trials", "read_truth", "scene_optics",
           "simulate_digit_press"]
