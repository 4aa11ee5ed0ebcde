"""How stable is the slip signal (paper 002, secs. III-IV)? Detection and false-alarm
rates of the per-trial slip decision against camera noise, lighting change and mesh
density, and the breaking point of each (the first level where detection falls below
95 % or false alarms exceed 5 %).

Trials are those of ``tactile simulate digit-press`` (objects held, then slipping or not),
drawn in memory for each scene seed with the scene's own plans and renderer
(:func:`.simulate.plan_trials`, :func:`.shapes.object_height`, :func:`.render.render_rgb`).
Each trial is rendered once without camera noise; the perturbations are applied to those
frames, vectorised over frames:

- ``noise``: Gaussian camera noise of standard deviation ``level`` (0-255 units) added to
  every frame and to the reference, then rounded to 8 bits;
- ``drift``: the frames' brightness drifting linearly from the reference's to
  ``1 + level`` times it over the trial (LEDs warming, exposure creeping), applied in the
  camera's linear domain (the 8-bit value scaled by ``(1 + level) ** (1 / gamma)``);
- ``step``: the brightness stepping by ``1 + level`` at a random frame after the static
  second (a lamp switched on in the room, an exposure jump), same way;
- ``mesh``: the tactile mesh (paper's densities, dense to sparse) at the scene's noise.

The breaking point walks away from the baseline (the scene's camera noise, no lighting
change, the paper's 32 x 24 mesh): noise levels below the scene's are reported but do not
count (with no camera noise at all the adaptive threshold is set by the grip's tremor
alone and is easily crossed).

The lighting axes carry the scene's own camera noise (``optics.noise_std``), and every
axis the scene's slow drift of press depth and LED brightness. Sources:
``intensity`` (:func:`.signals.intensity_maps`, no model) and ``height`` (height maps
from a trained normal model through :class:`.heightmap.HeightMapper`, when one is given).
The decision per trial is :func:`.slip.detect_slip` (adaptive threshold, 2 x the mean of
the first 30 signals) scored by :func:`.slip.score_trial`; rates by :class:`.slip.Rates`.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import asdict, dataclass, field
from typing import Any

import numpy as np

from ..progress import NullProgress, Progress
from .config import DigitSceneConfig
from .signals import intensity_maps

#: Perturbation axes, in the order they are reported.
AXES = ("noise", "drift", "step", "mesh")
#: Default levels per axis (noise: s.d. in 0-255 units; drift, step: relative brightness
#: change; mesh: cols x rows, dense to sparse).
DEFAULT_LEVELS: dict[str, tuple[Any, ...]] = {
    "noise": (0.0, 2.0, 4.0, 8.0, 16.0, 32.0),
    "drift": (0.0, 0.1, 0.25, 0.5),
    "step": (0.0, 0.02, 0.05, 0.1, 0.2),
    "mesh": ((320, 240), (160, 120), (64, 48), (32, 24), (16, 12), (8, 6), (4, 3)),
}
#: A level breaks the signal when detection falls below this ...
MIN_DETECTION = 0.95
#: ... or false alarms exceed this.
MAX_FALSE_ALARM = 0.05
#: Mesh used on the noise and lighting axes (the paper's).
BASE_MESH = (32, 24)


@dataclass(frozen=True)
class LevelResult:
    """Rates at one level of one axis for one source. level: the axis value (a float, or
    ``"COLSxROWS"`` on the mesh axis). mean_delay_s: mean of first detection minus onset
    over detected slip trials (None if none). broken: detection < 95 % or false alarms
    > 5 %."""

    axis: str
    source: str
    level: float | str
    n_slip: int
    n_no_slip: int
    detection_rate: float
    false_alarm_rate: float
    mean_delay_s: float | None
    broken: bool

    def as_dict(self) -> dict[str, Any]:
        return asdict(self)


@dataclass(frozen=True)
class StabilityResult:
    """Every level of every axis and source, the seeds and the breaking points (axis ->
    source -> first broken level, None when no level broke)."""

    seeds: list[int]
    n_trials: int
    results: list[LevelResult]
    breaking_points: dict[str, dict[str, float | str | None]] = field(default_factory=dict)

    def as_dict(self) -> dict[str, Any]:
        return {"seeds": self.seeds, "n_trials": self.n_trials,
                "min_detection": MIN_DETECTION, "max_false_alarm": MAX_FALSE_ALARM,
                "breaking_points": self.breaking_points,
                "results": [r.as_dict() for r in self.results]}


def linear_gain(frames: np.ndarray, gain: np.ndarray, gamma: float) -> np.ndarray:
    """(n, H, W, 3) frames (8-bit values, any float or uint dtype) with the light reaching
    the camera scaled by ``gain`` ((n,) per frame): values x ``gain ** (1 / gamma)``,
    float32, not rounded."""
    g = np.asarray(gain, dtype=np.float32) ** np.float32(1.0 / gamma)
    return np.asarray(frames, dtype=np.float32) * g[:, None, None, None]


def to_uint8(values: np.ndarray) -> np.ndarray:
    """Float 8-bit values -> uint8, rounded and clipped to 0-255."""
    return np.clip(np.rint(values), 0, 255).astype(np.uint8)


def with_noise(values: np.ndarray, std: float, rng: np.random.Generator) -> np.ndarray:
    """``values`` plus Gaussian noise of s.d. ``std`` (0-255 units), as uint8."""
    v = np.array(values, dtype=np.float32)  # a copy: the noise is added in place
    if std > 0:
        noise = rng.standard_normal(v.shape, dtype=np.float32)
        noise *= np.float32(std)
        v += noise
    return to_uint8(v)


@dataclass(frozen=True)
class _Trial:
    name: str
    slip: bool
    onset_s: float | None
    t_s: np.ndarray
    clean: np.ndarray  # (n, H, W, 3) uint8, no camera noise
    reference: np.ndarray  # (H, W, 3) uint8, no camera noise
    gain: np.ndarray  # (n,) the scene's own slow LED flicker


def scene_trials(config: DigitSceneConfig, seed: int) -> list[_Trial]:
    """The object trials of digit-press scene ``seed``, rendered without camera noise
    (frames (n, H, W, 3) uint8 and the reference), with their slip labels; the press depth
    and the LEDs drift slowly as in the scene (:func:`.simulate.slow_drift`), the LED drift
    kept as a per-frame gain applied with the perturbations."""
    from .render import render_reference, render_rgb
    from .shapes import object_height
    from .simulate import plan_trials, scene_optics, slow_drift

    optics = scene_optics(config, seed)
    tc = config.trials
    n = max(1, int(round(tc.duration_s * tc.frame_rate_hz)))
    t_s = np.arange(n, dtype=np.float64) / tc.frame_rate_hz
    out = []
    for j, plan in enumerate(plan_trials(config, seed)):
        rng = np.random.default_rng(np.random.SeedSequence([seed, 40, j]))
        shift, angle, depth = plan.motion(t_s, optics.px_per_mm)
        depth = np.maximum(depth + tc.tremor_mm * slow_drift(rng, n), 1e-3)
        gain = 1.0 + config.optics.flicker * slow_drift(rng, n)
        texture = np.random.SeedSequence([seed, 41, j])
        heights = np.stack([object_height(plan.object, optics, centre_px=plan.centre_px,
                                          shift_px=(float(shift[k, 0]), float(shift[k, 1])),
                                          angle_deg=float(angle[k]), depth_mm=float(depth[k]),
                                          rng=np.random.default_rng(texture))
                            for k in range(n)])
        out.append(_Trial(f"s{seed}/{plan.name}", plan.slip_onset_s is not None,
                          plan.slip_onset_s, t_s, render_rgb(heights, optics, noise_std=0.0),
                          render_reference(optics, noise_std=0.0), gain))
    return out


def _perturbed(trial: _Trial, axis: str, level: Any, *, noise_std: float, gamma: float,
               rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    """(frames, reference) uint8 of one trial at one level of one axis (the scene's own LED
    drift applied on every axis)."""
    n = trial.t_s.size
    std = float(level) if axis == "noise" else noise_std
    gain = np.ones(n)
    if axis == "drift":
        gain = 1.0 + float(level) * trial.t_s / max(trial.t_s[-1], 1e-9)
    elif axis == "step":  # after the static second the threshold is taken from
        k = int(rng.integers(min(31, n - 1), n))
        gain = np.where(np.arange(n) >= k, 1.0 + float(level), 1.0)
    frames = linear_gain(trial.clean, gain * trial.gain, gamma)
    return with_noise(frames, std, rng), with_noise(trial.reference, std, rng)


def _score(signals: list[tuple[np.ndarray, _Trial]], axis: str, source: str, level: Any
           ) -> LevelResult:
    from .slip import Rates, detect_slip, score_trial

    scores = [score_trial(detect_slip(s, t.t_s), slip=t.slip, onset_s=t.onset_s)
              for s, t in signals]
    rates = Rates.of(scores)
    delays = [s.delay_s for s in scores if s.delay_s is not None]
    det = float(rates.detection_rate)
    fa = float(rates.false_alarm_rate)
    shown = f"{level[0]}x{level[1]}" if axis == "mesh" else float(level)
    return LevelResult(axis, source, shown, rates.n_slip, rates.n_no_slip, det, fa,
                       float(np.mean(delays)) if delays else None,
                       bool(det < MIN_DETECTION or fa > MAX_FALSE_ALARM))


def breaking_points(results: Sequence[LevelResult], *, baseline_noise: float = 2.0
                    ) -> dict[str, dict[str, float | str | None]]:
    """axis -> source -> the first broken level walking away from the baseline in the
    axis's order (None: none broke). On the noise axis levels below ``baseline_noise``
    (cleaner than the scene's camera) are reported but do not count."""
    out: dict[str, dict[str, float | str | None]] = {}
    for r in results:
        per = out.setdefault(r.axis, {})
        if r.source not in per:
            per[r.source] = None
        below = r.axis == "noise" and float(r.level) < baseline_noise
        if r.broken and not below and per[r.source] is None:
            per[r.source] = r.level
    return out


def run_stability(config: DigitSceneConfig, seeds: Sequence[int], *,
                  levels: dict[str, Sequence[Any]] | None = None,
                  height_mapper: Callable[[np.ndarray, np.ndarray], np.ndarray] | None = None,
                  axes: Sequence[str] = AXES,
                  progress: Progress | None = None) -> StabilityResult:
    """Rates of every axis level for the intensity source (and the height source when
    ``height_mapper`` -- frame, reference -> (H, W) heights -- is given) over the object
    trials of the digit-press scenes ``seeds``, on the named ``axes`` (default all). Each
    trial is drawn and rendered once; perturbations are seeded by (seed, trial, axis,
    level)."""
    unknown = [a for a in axes if a not in AXES]
    if unknown:
        raise ValueError(f"`axes` (={list(axes)}) names {unknown[0]!r}; axes are "
                         f"{', '.join(AXES)}")
    axes = [a for a in AXES if a in axes]
    from .slip import slip_signal

    levels = {**DEFAULT_LEVELS, **(levels or {})}
    progress = progress or NullProgress()
    sources = ["intensity"] + (["height"] if height_mapper is not None else [])
    from .render import GelOptics

    noise_std = config.optics.noise_std
    gamma = GelOptics().gamma  # the scene's camera response
    # signals[(axis, level index, source)] = [(signal, trial), ...]
    signals: dict[tuple[str, int, str], list[tuple[np.ndarray, _Trial]]] = {}
    n_trials = 0
    progress.start(None, "trials")
    for seed in seeds:
        for j, trial in enumerate(scene_trials(config, seed)):
            n_trials += 1
            for axis in axes:
                axis_levels = list(levels[axis])
                if axis == "mesh":  # one rendering, every mesh
                    rng = np.random.default_rng(np.random.SeedSequence([seed, 50, j, 3, 0]))
                    frames, ref = _perturbed(trial, axis, None, noise_std=noise_std,
                                             gamma=gamma, rng=rng)
                    maps = _maps(frames, ref, sources, height_mapper)
                    for i, mesh in enumerate(axis_levels):
                        for src in sources:
                            signals.setdefault((axis, i, src), []).append(
                                (slip_signal(maps[src], tuple(mesh)), trial))
                    continue
                for i, level in enumerate(axis_levels):
                    rng = np.random.default_rng(np.random.SeedSequence(
                        [seed, 50, j, AXES.index(axis), i]))
                    frames, ref = _perturbed(trial, axis, level, noise_std=noise_std,
                                             gamma=gamma, rng=rng)
                    maps = _maps(frames, ref, sources, height_mapper)
                    for src in sources:
                        signals.setdefault((axis, i, src), []).append(
                            (slip_signal(maps[src], BASE_MESH), trial))
            progress.advance(1)
    progress.finish()
    results = [_score(signals[(axis, i, src)], axis, src, level)
               for axis in axes for src in sources
               for i, level in enumerate(levels[axis])]
    return StabilityResult([int(s) for s in seeds], n_trials, results,
                           breaking_points(results, baseline_noise=noise_std))


def _maps(frames: np.ndarray, ref: np.ndarray, sources: Sequence[str],
          height_mapper: Callable[[np.ndarray, np.ndarray], np.ndarray] | None
          ) -> dict[str, np.ndarray]:
    maps = {"intensity": intensity_maps(frames, ref)}
    if "height" in sources and height_mapper is not None:
        maps["height"] = np.stack([height_mapper(f, ref) for f in frames])
    return maps


def plot_stability(result: StabilityResult, out: Any) -> None:
    """One PNG: per axis, detection and false-alarm rates against the level per source,
    the 95 % / 5 % limits dashed and the breaking point marked."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    shown = [a for a in AXES if any(r.axis == a for r in result.results)]
    fig, axes = plt.subplots(1, len(shown), figsize=(4.2 * len(shown), 3.6), dpi=110,
                             squeeze=False)
    axes = axes[0]
    colours = {"intensity": "tab:blue", "height": "tab:green"}
    for ax, axis in zip(axes, shown, strict=True):
        rows = [r for r in result.results if r.axis == axis]
        labels = [str(r.level) for r in rows if r.source == "intensity"]
        x = np.arange(len(labels))
        for src in dict.fromkeys(r.source for r in rows):
            mine = [r for r in rows if r.source == src]
            ax.plot(x, [100 * r.detection_rate for r in mine], "o-", color=colours[src],
                    label=f"{src}: detection")
            ax.plot(x, [100 * r.false_alarm_rate for r in mine], "s--", color=colours[src],
                    alpha=0.6, label=f"{src}: false alarms")
            bp = result.breaking_points.get(axis, {}).get(src)
            if bp is not None:
                k = labels.index(str(bp))
                ax.axvline(k, color=colours[src], lw=2, alpha=0.35)
                ax.annotate(f"breaks ({src})", (k, 50 if src == "intensity" else 10),
                            rotation=90, fontsize=7, color=colours[src], ha="right")
        ax.axhline(100 * MIN_DETECTION, color="grey", ls=":", lw=0.8)
        ax.axhline(100 * MAX_FALSE_ALARM, color="grey", ls=":", lw=0.8)
        ax.set_xticks(x, labels, rotation=45, fontsize=7)
        ax.set_ylim(-3, 103)
        ax.set_title({"noise": "camera noise (s.d., 0-255)", "drift": "brightness drift",
                      "step": "brightness step", "mesh": "tactile mesh"}[axis], fontsize=9)
        ax.set_ylabel("%")
    handles, labels = axes[0].get_legend_handles_labels()
    fig.legend(handles, labels, loc="lower center", ncol=4, fontsize=8, frameon=False)
    fig.suptitle(f"slip-signal stability, seeds {result.seeds} ({result.n_trials} trials); "
                 f"breaking point: detection < {100 * MIN_DETECTION:.0f} % or false alarms > "
                 f"{100 * MAX_FALSE_ALARM:.0f} %", fontsize=10)
    fig.tight_layout(rect=(0, 0.07, 1, 1))
    fig.savefig(out)
    plt.close(fig)


__all__ = ["AXES", "BASE_MESH", "DEFAULT_LEVELS", "LevelResult", "MAX_FALSE_ALARM",
           "MIN_DETECTION", "StabilityResult", "breaking_points", "linear_gain",
           "plot_stability", "run_stability", "scene_trials", "to_uint8", "with_noise"]
