"""The slip signal, its adaptive threshold and per-trial slip decisions (paper 002, eq. 10
and sec. V).

- :func:`slip_signal`: ``S_t = sum_i |h_t(i) - h_(t-1)(i)|`` over the ``n`` units of a
  tactile mesh (:mod:`.mesh`), one value per frame; ``S_0`` is NaN (no previous frame).
  Units: those of the maps (mm for height maps, 0-255 colour units for the intensity
  source) summed over the units.
- :func:`adaptive_threshold`: ``scale`` (2 in the paper) times the mean of the first
  ``n_static`` (30: one second at 30 Hz) finite signal values, taken while the grip is
  static.
- :func:`detect_slip`: a frame after those static frames whose signal is *larger* than
  the threshold (a signal equal to it is not a slip) is a slip; the first such frame is the
  detection. :func:`score_trial` compares that with a trial's label: on a ``slip`` trial
  the slip is detected when a frame at or after the labelled onset (``t >= slip_onset_s``,
  the change a frame shows happened since the previous one) crosses the threshold, and a
  crossing before the onset is a false alarm; on a ``no_slip`` trial any crossing is a
  false alarm.
- :func:`best_scale`: the threshold scale that best separates labelled slip from no-slip
  trials (largest detection rate minus false-alarm rate; ties go to the scale nearest 2).
- :func:`check_static`: whether the frames that set the threshold were static. Their
  signals' spread (standard deviation over mean above :data:`STATIC_SPREAD_LIMIT`), a
  static signal already above the threshold, or a rise through them (the last static
  signal above :data:`STATIC_RISE_LIMIT` x the first: motion starting in the first frames)
  each flag the trial, with the reason: the threshold is then a threshold on motion, not
  on the sensor's noise (a lift is never static at its start).
- :func:`scale_by_cv` (``--scale auto``): the threshold scale learned from labelled
  trials. Leave one group out (the trial label ``object`` when every labelled trial has
  one and there are two objects or more, else each trial its own group: neighbouring
  trials of one object never sit on both sides): per fold :func:`best_scale` on the other
  groups (the middle of the scales that tie there, so the threshold keeps its distance
  from both classes), scored on the held-out group;
  the cross-validated accuracy (a trial is right when a slip trial is detected without a
  false alarm, a no_slip trial has none) with its 95 % Wilson interval over trials. The
  scale used is :func:`best_scale` on every labelled trial.
- :func:`slip_signal_file` (``tactile slip-signal``): all of it for every trial of a file,
  on height maps (a ``tactile heightmap`` file, or frames through a normal model) or on
  the frames' colour change from the reference (``intensity``: for sensors without
  calibration presses), or both side by side.
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from dataclasses import asdict, dataclass, field

import numpy as np

from ..errors import InputError
from ..progress import NullProgress, Progress
from ..store.trials import TactileFile, Trial
from ..threads import limit_threads
from .heightmap import (
    STREAM,
    HeightMapper,
    absolute_folder,
    check_frame_times,
    check_stride,
    frames_px_per_mm,
    read_height_maps,
    trial_heights,
)
from .mesh import slip_signal
from .normals import NormalModel, default_workers

DEFAULT_N_STATIC = 30
DEFAULT_SCALE = 2.0
#: threshold scales :func:`best_scale` tries
SCALE_GRID = tuple(np.round(np.arange(1.0, 20.01, 0.1), 2))
#: largest spread (standard deviation over mean) of the static signals of a static grip: the
#: signal of a static gel is camera noise, a few percent to tens of percent from frame to
#: frame; spread beyond this is motion
STATIC_SPREAD_LIMIT = 0.5
#: largest ratio of the last static signal to the first of a static grip (a rise through the
#: static frames is motion starting)
STATIC_RISE_LIMIT = 2.0
#: ``scale`` value that learns the threshold scale from labelled trials
SCALE_AUTO = "auto"


def _static_index(signal: np.ndarray, n_static: int) -> np.ndarray:
    idx = np.flatnonzero(np.isfinite(signal))
    if n_static < 1:
        raise ValueError(f"`n_static` (={n_static}) must be at least 1")
    if idx.size < n_static:
        raise ValueError(f"the adaptive threshold needs {n_static} static slip signals but "
                         f"the signal has {idx.size} finite values; lower `n_static`")
    return idx[:n_static]


def adaptive_threshold(signal: np.ndarray, n_static: int = DEFAULT_N_STATIC,
                       scale: float = DEFAULT_SCALE) -> float:
    """``scale`` x the mean of the first ``n_static`` finite values of ``signal``
    ((n_frames,) slip signal). ValueError when there are fewer."""
    if not (np.isfinite(scale) and scale > 0):
        raise ValueError(f"`scale` (={scale}) must be a positive number")
    s = np.asarray(signal, dtype=np.float64)
    return float(scale * s[_static_index(s, n_static)].mean())


@dataclass(frozen=True)
class StaticCheck:
    """Were the frames that set the threshold static? static: no sign of motion;
    spread: standard deviation over mean of the static signals (None with fewer than two);
    rise: last static signal over the first (None with fewer than two or a zero first);
    reason: why not static (None when static)."""

    static: bool
    spread: float | None
    rise: float | None
    reason: str | None


def check_static(signal: np.ndarray, n_static: int = DEFAULT_N_STATIC,
                 scale: float = DEFAULT_SCALE) -> StaticCheck:
    """Judge the first ``n_static`` finite values of ``signal`` ((n_frames,) slip signal):
    flagged when their spread exceeds :data:`STATIC_SPREAD_LIMIT`, one of them exceeds
    ``scale`` x their mean (the threshold), or the last exceeds :data:`STATIC_RISE_LIMIT` x
    the first. ValueError when there are fewer than ``n_static`` finite values."""
    s = np.asarray(signal, dtype=np.float64)
    static = s[_static_index(s, n_static)]
    mean = float(static.mean())
    if static.size < 2:
        return StaticCheck(True, None, None, None)
    spread = float(static.std() / mean) if mean > 0 else 0.0
    rise = float(static[-1] / static[0]) if static[0] > 0 else None
    reasons = []
    if spread > STATIC_SPREAD_LIMIT:
        reasons.append(f"static signals spread {spread:.2f} (std/mean) > "
                       f"{STATIC_SPREAD_LIMIT:g}")
    if mean > 0 and static.max() > scale * mean:
        reasons.append(f"a static signal is {static.max() / mean:.1f} x their mean, above "
                       "the threshold")
    if rise is not None and rise > STATIC_RISE_LIMIT:
        reasons.append(f"static signals rise {rise:.1f} x from first to last > "
                       f"{STATIC_RISE_LIMIT:g}")
    why = "; ".join(reasons) + " (motion in the first frames)" if reasons else None
    return StaticCheck(not reasons, spread, rise, why)


@dataclass
class SlipDetection:
    """One trial's slip decision.

    signal: (n_frames,) slip signal; t_s: (n_frames,) frame times (s); threshold: the
    adaptive (or given) threshold; first_judged: index of the first frame judged (the
    frames before it gave the threshold); detected: any judged frame above the threshold;
    first_index / first_time_s: the first such frame (None when not detected);
    crossings: indices of every judged frame above the threshold; static: whether the
    frames that set the threshold were static (:func:`check_static`).
    """

    signal: np.ndarray = field(repr=False)
    t_s: np.ndarray = field(repr=False)
    threshold: float
    first_judged: int
    detected: bool
    first_index: int | None
    first_time_s: float | None
    crossings: np.ndarray = field(repr=False)
    static: StaticCheck | None = None

    def peak_ratio(self) -> float:
        """Largest judged signal over the mean static signal (the paper's 'ratio between
        the signal peak and the average signal before slip'); NaN without judged frames."""
        judged = self.signal[self.first_judged:]
        static = self.signal[:self.first_judged]
        static = static[np.isfinite(static)]
        if judged.size == 0 or static.size == 0 or not static.mean() > 0:
            return float("nan")
        return float(np.nanmax(judged) / static.mean())


def detect_slip(signal: np.ndarray, t_s: np.ndarray, *, n_static: int = DEFAULT_N_STATIC,
                scale: float = DEFAULT_SCALE, threshold: float | None = None
                ) -> SlipDetection:
    """Judge every frame after the first ``n_static`` finite signals against the adaptive
    threshold (or ``threshold`` when given): a frame whose signal is larger is a slip."""
    s = np.asarray(signal, dtype=np.float64)
    t = np.asarray(t_s, dtype=np.float64)
    if s.shape != t.shape or s.ndim != 1:
        raise ValueError(f"`signal` {s.shape} and `t_s` {t.shape} must be (n_frames,)")
    first = int(_static_index(s, n_static)[-1]) + 1
    thr = adaptive_threshold(s, n_static, scale) if threshold is None else float(threshold)
    above = np.flatnonzero(s[first:] > thr) + first
    hit = above.size > 0
    return SlipDetection(signal=s, t_s=t, threshold=thr, first_judged=first, detected=hit,
                         first_index=int(above[0]) if hit else None,
                         first_time_s=float(t[above[0]]) if hit else None, crossings=above,
                         static=check_static(s, n_static, scale))


@dataclass(frozen=True)
class TrialScore:
    """A detection against a trial's label. slip: the label (True: slip); detected: a
    crossing at or after the onset (slip trials; False on no_slip trials); false_alarm: a
    crossing before the onset, or any crossing on a no_slip trial; delay_s: first crossing
    at or after the onset minus the onset (slip trials that were detected), else None."""

    slip: bool
    detected: bool
    false_alarm: bool
    delay_s: float | None


def score_trial(det: SlipDetection, *, slip: bool, onset_s: float | None) -> TrialScore:
    """Score ``det`` against the label (``slip``; ``onset_s`` required when slip)."""
    times = det.t_s[det.crossings]
    if not slip:
        return TrialScore(False, False, bool(times.size), None)
    if onset_s is None or not np.isfinite(onset_s):
        raise ValueError("a slip trial needs its `onset_s` to be scored")
    after = times[times >= onset_s]
    return TrialScore(True, bool(after.size), bool((times < onset_s).any()),
                      float(after[0] - onset_s) if after.size else None)


def trial_correct(score: TrialScore) -> bool:
    """A trial decided right: a slip trial detected without a false alarm, a no_slip
    trial without one."""
    return (score.detected and not score.false_alarm) if score.slip else not score.false_alarm


@dataclass(frozen=True)
class Rates:
    """Detection rate over slip trials and false-alarm rate over all trials (a slip trial
    with a crossing before its onset counts as a false alarm too); correct / accuracy:
    trials decided right (:func:`trial_correct`) and their share."""

    n_slip: int
    n_no_slip: int
    detection_rate: float
    false_alarm_rate: float
    false_alarms: int
    correct: int = 0
    accuracy: float = float("nan")

    @classmethod
    def of(cls, scores: Sequence[TrialScore]) -> Rates:
        n_slip = sum(s.slip for s in scores)
        det = sum(s.detected for s in scores if s.slip)
        fa = sum(s.false_alarm for s in scores)
        ok = sum(trial_correct(s) for s in scores)
        return cls(n_slip, len(scores) - n_slip,
                   det / n_slip if n_slip else float("nan"),
                   fa / len(scores) if scores else float("nan"), fa, ok,
                   ok / len(scores) if scores else float("nan"))


@dataclass(frozen=True)
class ScaleChoice:
    """The best threshold scale: scale, its rates, and the range of scales as good."""

    scale: float
    rates: Rates
    best_from: float
    best_to: float


def best_scale(signals: Sequence[tuple[np.ndarray, np.ndarray]],
               labels: Sequence[tuple[bool, float | None]], *,
               n_static: int = DEFAULT_N_STATIC,
               grid: Sequence[float] = SCALE_GRID, middle: bool = False) -> ScaleChoice:
    """Try every scale of ``grid`` on the labelled trials ((signal, t_s) and (slip,
    onset_s) per trial); return the one with the largest detection rate minus false-alarm
    rate (ties: nearest to the paper's 2; ``middle``: the median of the tied scales, the
    one farthest from both classes' edges, which :func:`scale_by_cv` uses)."""
    if not signals:
        raise ValueError("no labelled trials to choose a threshold scale on")
    best: list[tuple[float, float, Rates]] = []
    for scale in grid:
        scores = [score_trial(detect_slip(s, t, n_static=n_static, scale=scale),
                              slip=lab, onset_s=on)
                  for (s, t), (lab, on) in zip(signals, labels, strict=True)]
        r = Rates.of(scores)
        dr = 0.0 if np.isnan(r.detection_rate) else r.detection_rate
        best.append((dr - r.false_alarm_rate, float(scale), r))
    top = max(b[0] for b in best)
    winners = [b for b in best if b[0] == top]
    if middle:
        score, scale, rates = sorted(winners, key=lambda b: b[1])[(len(winners) - 1) // 2]
    else:
        score, scale, rates = min(winners, key=lambda b: abs(b[1] - DEFAULT_SCALE))
    return ScaleChoice(scale, rates, min(w[1] for w in winners), max(w[1] for w in winners))


def wilson_interval(k: int, n: int, z: float = 1.96) -> tuple[float, float]:
    """95 % (``z`` = 1.96) Wilson score interval of a proportion ``k`` of ``n``."""
    if n <= 0:
        return float("nan"), float("nan")
    p = k / n
    den = 1 + z * z / n
    mid = (p + z * z / (2 * n)) / den
    half = z * np.sqrt(p * (1 - p) / n + z * z / (4 * n * n)) / den
    return float(max(0.0, mid - half)), float(min(1.0, mid + half))


@dataclass(frozen=True)
class ScaleFold:
    """One held-out group of :func:`scale_by_cv`: the scale chosen without it, and its
    trials decided right under that scale."""

    group: str
    scale: float
    n_trials: int
    correct: int


@dataclass(frozen=True)
class ScaleCV:
    """The threshold scale learned from labelled trials (``--scale auto``).

    scale: :func:`best_scale` on every labelled trial (the scale used); best_from/best_to:
    the scales as good there; group_by: ``object`` or ``trial``; folds: one per held-out
    group; rates: the held-out decisions pooled over folds (the honest figure);
    accuracy_interval: its 95 % Wilson interval over trials."""

    scale: float
    best_from: float
    best_to: float
    group_by: str
    folds: tuple[ScaleFold, ...]
    rates: Rates
    accuracy_interval: tuple[float, float]

    def as_dict(self) -> dict[str, object]:
        return {"scale": self.scale, "scale_range": [self.best_from, self.best_to],
                "group_by": self.group_by, "n_groups": len(self.folds),
                "cv_accuracy": _finite_or_none(self.rates.accuracy),
                "cv_accuracy_interval": [round(v, 4) for v in self.accuracy_interval],
                "cv_rates": asdict(self.rates),
                "folds": [asdict(f) for f in self.folds]}


def scale_by_cv(signals: Sequence[tuple[np.ndarray, np.ndarray]],
                labels: Sequence[tuple[bool, float | None]], groups: Sequence[str], *,
                n_static: int = DEFAULT_N_STATIC, group_by: str = "object",
                grid: Sequence[float] = SCALE_GRID) -> ScaleCV:
    """The threshold scale by leave-one-group-out CV (module docstring): ``signals``
    (signal, t_s) and ``labels`` (slip, onset_s) per labelled trial, ``groups`` its group
    (at least two distinct). ValueError with fewer than two groups."""
    names = list(dict.fromkeys(groups))
    if len(names) < 2:
        raise ValueError(f"`scale='auto'` needs labelled trials of at least two groups "
                         f"({group_by}) to cross-validate; found {len(names)}")
    folds: list[ScaleFold] = []
    scores: list[TrialScore] = []
    for g in names:
        inner = [i for i, x in enumerate(groups) if x != g]
        held = [i for i, x in enumerate(groups) if x == g]
        choice = best_scale([signals[i] for i in inner], [labels[i] for i in inner],
                            n_static=n_static, grid=grid, middle=True)
        fold = [score_trial(detect_slip(*signals[i], n_static=n_static, scale=choice.scale),
                            slip=labels[i][0], onset_s=labels[i][1]) for i in held]
        scores.extend(fold)
        folds.append(ScaleFold(g, choice.scale, len(fold), sum(map(trial_correct, fold))))
    rates = Rates.of(scores)
    final = best_scale(signals, labels, n_static=n_static, grid=grid, middle=True)
    return ScaleCV(final.scale, final.best_from, final.best_to, group_by, tuple(folds), rates,
                   wilson_interval(rates.correct, len(scores)))




# -- file level: `tactile slip-signal` -------------------------------------------------------
#: where the maps of the slip signal come from
SOURCES = ("auto", "height", "intensity", "both")


@dataclass
class TrialSlip:
    """One trial's slip decision from one source (``height`` or ``intensity``): its label
    (``slip`` True/False, None when the trial has no slip label), onset, detection and
    score (None without a label)."""

    trial: str
    source: str
    object: str | None
    slip: bool | None
    onset_s: float | None
    detection: SlipDetection
    score: TrialScore | None

    def as_dict(self, *, with_signal: bool = True) -> dict[str, object]:
        d = self.detection
        out: dict[str, object] = {
            "trial": self.trial, "source": self.source, "object": self.object,
            "label": None if self.slip is None else ("slip" if self.slip else "no_slip"),
            "slip_onset_s": self.onset_s, "threshold": d.threshold,
            "detected": d.detected, "first_detection_s": d.first_time_s,
            "first_judged_s": float(d.t_s[d.first_judged]) if d.first_judged < d.t_s.size
            else None, "peak_ratio": _finite_or_none(d.peak_ratio()),
        }
        if d.static is not None:
            out.update(static=d.static.static, static_reason=d.static.reason,
                       static_spread=d.static.spread, static_rise=d.static.rise)
        if self.score is not None:
            out.update(slip_detected=self.score.detected, false_alarm=self.score.false_alarm,
                       delay_s=self.score.delay_s)
        if with_signal:
            out["t_s"] = [float(v) for v in d.t_s]
            out["signal"] = [_finite_or_none(float(v)) for v in d.signal]
        return out

    def verdict(self) -> str:
        """``hit``, ``missed``, ``false alarm``, ``correct reject`` (``-`` without a label)."""
        if self.score is None:
            return "-"
        if self.score.false_alarm:
            return "hit + false alarm" if self.score.detected else "false alarm"
        return "hit" if self.score.detected else "missed" if self.slip else "correct reject"


def _finite_or_none(v: float) -> float | None:
    return float(v) if np.isfinite(v) else None


def trial_label(labels: dict[str, object], *, path: object, trial: str
                ) -> tuple[bool | None, float | None]:
    """(slip, onset_s) from a trial's labels ``slip`` (slip | no_slip) and ``slip_onset_s``;
    (None, None) without a ``slip`` label; InputError for other values."""

    value = labels.get("slip")
    if value is None or value == "":
        return None, None
    if str(value) not in ("slip", "no_slip"):
        raise InputError(f"trial {trial!r} has label slip={value!r}; expected slip or no_slip",
                         path=str(path), where=f"/trials/{trial}/labels")
    if str(value) == "no_slip":
        return False, None
    onset = labels.get("slip_onset_s")
    try:
        onset_f = float(onset)  # type: ignore[arg-type]
    except (TypeError, ValueError):
        onset_f = float("nan")
    if not np.isfinite(onset_f):
        raise InputError(f"slip trial {trial!r} has no numeric slip_onset_s label "
                         f"(={onset!r}): a slip is scored by the frame it is found at, so each "
                         "trial labelled slip=slip needs its onset in seconds; add a "
                         "slip_onset_s column to the table of trial labels the file was "
                         "ingested with and ingest again, or decide whole lifts without "
                         "onsets with `tactile slip-imprint`",
                         path=str(path), where=f"/trials/{trial}/labels")
    return True, onset_f


@dataclass
class SlipFileResult:
    """Every trial's decision per source, and per source the rates and the best threshold
    scale over the labelled trials (empty without labels)."""

    path: str
    mesh: tuple[int, int]
    scale: float
    n_static: int
    trials: list[TrialSlip]
    rates: dict[str, Rates]
    best: dict[str, ScaleChoice]
    run_dir: str | None
    plot: str | None = None
    #: per source, the scale learned by CV (``scale='auto'``; the scale used per source)
    scale_cv: dict[str, ScaleCV] = field(default_factory=dict)
    #: warnings (e.g. frames of another sensor unit than the model's calibration)
    warnings: list[str] = field(default_factory=list)

    def not_static(self, source: str) -> list[TrialSlip]:
        """Trials of ``source`` whose static frames were not static."""
        return [t for t in self.trials if t.source == source
                and t.detection.static is not None and not t.detection.static.static]

    def as_dict(self, *, with_signal: bool = True) -> dict[str, object]:
        sources = list(dict.fromkeys(t.source for t in self.trials))
        return {
            "file": self.path, "mesh": f"{self.mesh[0]}x{self.mesh[1]}",
            "scale": SCALE_AUTO if self.scale_cv else self.scale,
            "n_static": self.n_static, "run": self.run_dir,
            "summary": {src: {**(asdict(self.rates[src]) if src in self.rates else {}),
                              **({"best_scale": self.best[src].scale,
                                  "best_scale_range": [self.best[src].best_from,
                                                       self.best[src].best_to],
                                  "best_scale_rates": asdict(self.best[src].rates)}
                                 if src in self.best else {}),
                              **({"scale_auto": self.scale_cv[src].as_dict()}
                                 if src in self.scale_cv else {}),
                              "n_trials": sum(t.source == src for t in self.trials),
                              "n_not_static": len(self.not_static(src))}
                        for src in sources},
            "warnings": list(self.warnings),
            "trials": [t.as_dict(with_signal=with_signal) for t in self.trials],
        }

    def table(self) -> tuple[str, list[str], list[list[str]]]:
        """Title, columns and one row per trial and source."""
        cols = ["trial", "object", "source", "label", "onset (s)", "threshold",
                "detected at (s)", "peak/static", "static", "result"]
        rows = []
        for r in self.trials:
            d = r.detection
            rows.append([r.trial, r.object or "-", r.source,
                         "-" if r.slip is None else ("slip" if r.slip else "no_slip"),
                         "-" if r.onset_s is None else f"{r.onset_s:.3f}", f"{d.threshold:.4g}",
                         "-" if d.first_time_s is None else f"{d.first_time_s:.3f}",
                         f"{d.peak_ratio():.1f}",
                         "-" if d.static is None else "yes" if d.static.static else "NO",
                         r.verdict()])
        scale = ("auto (" + ", ".join(f"{s}: {c.scale:g}" for s, c in self.scale_cv.items())
                 + ")") if self.scale_cv else f"{self.scale:g}"
        return (f"Slip signal of {self.path} (mesh {self.mesh[0]}x{self.mesh[1]}, threshold "
                f"{scale} x mean of {self.n_static} static signals)", cols, rows)

    def summary_lines(self) -> list[str]:
        lines = [f"warning: {w}" for w in self.warnings]
        for src in dict.fromkeys(t.source for t in self.trials):
            moving = self.not_static(src)
            if moving:
                n = sum(t.source == src for t in self.trials)
                lines.append(f"{src}: the static frames were not static in {len(moving)} of "
                             f"{n} trials ({moving[0].trial}: "
                             f"{moving[0].detection.static.reason}); their threshold "  # type: ignore[union-attr]
                             "is a threshold on motion, not on noise (scale auto learns "
                             "one from labelled trials)")
            if src not in self.rates:
                continue
            rates, best = self.rates[src], self.best[src]
            lines.append(f"{src}: detection rate {rates.detection_rate:.2f} over "
                         f"{rates.n_slip} slip trials, false alarms {rates.false_alarms} of "
                         f"{rates.n_slip + rates.n_no_slip} trials, accuracy "
                         f"{rates.accuracy:.3f}; best scale {best.scale:g} "
                         f"(as good: {best.best_from:g}-{best.best_to:g}; detection "
                         f"{best.rates.detection_rate:.2f}, false alarms "
                         f"{best.rates.false_alarms}; chosen on these trials)")
            if src in self.scale_cv:
                cv = self.scale_cv[src]
                lo, hi = cv.accuracy_interval
                lines.append(f"{src}: scale auto {cv.scale:g} (as good: {cv.best_from:g}-"
                             f"{cv.best_to:g}); leave-one-{cv.group_by}-out accuracy "
                             f"{cv.rates.accuracy:.3f} [95 % {lo:.3f}-{hi:.3f}] over "
                             f"{cv.rates.n_slip + cv.rates.n_no_slip} trials of "
                             f"{len(cv.folds)} groups (fold scales: "
                             + ", ".join(f"{f.group} {f.scale:g}" for f in cv.folds) + ")")
        return lines + ([f"wrote {self.plot}/slip_*.png"] if self.plot is not None else [])


def trial_maps(trial: Trial, source: str, mapper: HeightMapper | None
               ) -> tuple[np.ndarray, np.ndarray]:
    """(n_frames, H, W) maps and t_s of one trial for ``source`` (``height``: the trial's
    height_mm stream, else its frames through ``mapper``; ``intensity``: the frames' mean
    colour change from the reference)."""
    if source == "height":
        if trial.has_signal(STREAM):
            maps, t_s, _ = read_height_maps(trial)
            return maps, t_s
        if mapper is None:
            raise InputError(f"trial {trial.name!r} has frames but no height maps; pass "
                             "`run_dir` (a normal model) or use `source='intensity'`",
                             path=trial.path)
        return trial_heights(mapper, trial)
    if not trial.has_frames:
        raise InputError(f"trial {trial.name!r} has no frames for the intensity source (a "
                         "heightmap file keeps only heights; give the ingested frames file)",
                         path=trial.path)
    from .signals import intensity_maps

    frames = trial.frames()
    ref = frames.reference
    maps = np.stack([intensity_maps(img[None], ref)[0] for _, img in frames])
    return maps, frames.t_s


def slip_signal_file(path: str | os.PathLike[str], *, source: str = "auto",
                     run_dir: str | os.PathLike[str] | None = None,
                     mesh: tuple[int, int] = (32, 24), scale: float | str = DEFAULT_SCALE,
                     n_static: int = DEFAULT_N_STATIC, trials: Sequence[str] | None = None,
                     px_per_mm: float | None = None, workers: int | None = None,
                     stride: int = 1, progress: Progress | None = None,
                     keep_maps: dict[tuple[str, str], np.ndarray] | None = None,
                     plot: str | os.PathLike[str] | None = None) -> SlipFileResult:
    """The slip signal (eq. 10) on ``mesh`` of every trial of ``path`` (an ingested
    frames file or a ``tactile heightmap`` file), its adaptive threshold (``scale`` x the
    mean of the first ``n_static`` signals) and slip decision; with trial labels, the
    detection rate, false alarms and the best threshold scale per source.

    source: ``height`` (the file's height maps, or the frames through the normal model of
    ``run_dir``), ``intensity`` (colour change from the reference), ``both``, or ``auto``
    (height when the file holds height maps or ``run_dir`` is given, else intensity).
    ``workers``: threads of the maps (BLAS and OpenMP included; results do not depend on
    it). ``stride``: block side of the height maps made from frames
    (:class:`.heightmap.HeightMapper`; 1: every pixel). ``plot``: a folder for one PNG per
    trial and source (S, threshold, onset and detection), same-named files replaced;
    checked before any work. ``scale='auto'``: the scale learned per source from the
    labelled trials (:func:`scale_by_cv`). Every trial says whether its static frames were
    static (:func:`check_static`)."""
    plot = None if plot is None else absolute_folder(plot)
    threads = _check_outputs(path, run_dir, plot, workers)
    if source not in SOURCES:
        raise InputError(f"`source` (={source!r}) must be one of {', '.join(SOURCES)}")
    auto = isinstance(scale, str)
    if auto and scale != SCALE_AUTO:
        raise InputError(f"`scale` (={scale!r}) must be a positive number or {SCALE_AUTO!r}")
    if not auto and not (np.isfinite(scale) and scale > 0):  # type: ignore[arg-type]
        raise InputError(f"`scale` (={scale}) must be a positive number or {SCALE_AUTO!r}")
    fixed = DEFAULT_SCALE if auto else float(scale)  # type: ignore[arg-type]
    if n_static < 1:
        raise InputError(f"`n_static` (={n_static}) must be at least 1")
    check_stride(stride)
    prog = progress or NullProgress()
    found: list[tuple[Trial, str, bool | None, float | None, np.ndarray, np.ndarray]] = []
    warnings: list[str] = []
    with TactileFile(path) as tf:
        chosen = tf.trials(list(trials)) if trials is not None else tf.trials()
        if not chosen:
            raise InputError("the file holds no trials", path=tf.path)
        has_heights = all(t.has_signal(STREAM) for t in chosen)
        if source == "auto":
            source = "height" if has_heights or run_dir is not None else "intensity"
        sources = ("height", "intensity") if source == "both" else (source,)
        mapper = None
        if "height" in sources and not has_heights:
            if run_dir is None:
                raise InputError("the height source needs height maps: give a `tactile "
                                 "heightmap` file or pass `run_dir` (a normal model), or use "
                                 "`source='intensity'`", path=tf.path)
            first = next((t for t in chosen if t.has_frames), None)
            if first is None:
                raise InputError("no trial holds frames or height maps", path=tf.path)
            mapper = HeightMapper(NormalModel.from_run(run_dir),
                                  frames_px_per_mm(tf, first, px_per_mm), workers=threads,
                                  stride=stride)
            warnings.extend(mapper.model.check_frames(tf, first, mapper.px_per_mm))
        prog.start(len(chosen) * len(sources), "slip signals")
        for t in chosen:
            slip, onset = trial_label(t.labels, path=tf.path, trial=t.name)
            for src in sources:
                with limit_threads(threads):
                    maps, t_s = trial_maps(t, src, mapper)
                check_frame_times(t_s, t)
                try:
                    sig = slip_signal(maps, mesh)
                    _static_index(sig, n_static)
                except ValueError as exc:
                    raise InputError(f"trial {t.name!r}: {exc}", path=tf.path) from None
                if keep_maps is not None:
                    keep_maps[(t.name, src)] = maps
                found.append((t, src, slip, onset, sig, t_s))
                prog.advance()
        scale_cv: dict[str, ScaleCV] = {}
        if auto:
            for src in sources:
                scale_cv[src] = _auto_scale(tf.path, [f for f in found if f[1] == src],
                                            n_static)
    out: list[TrialSlip] = []
    for t, src, slip, onset, sig, t_s in found:
        used = scale_cv[src].scale if auto else fixed
        det = detect_slip(sig, t_s, n_static=n_static, scale=used)
        score = None if slip is None else score_trial(det, slip=slip, onset_s=onset)
        obj = t.labels.get("object")
        out.append(TrialSlip(t.name, src, None if obj is None else str(obj), slip, onset, det,
                             score))
    rates: dict[str, Rates] = {}
    best: dict[str, ScaleChoice] = {}
    for src in sources:
        labelled = [r for r in out if r.source == src and r.score is not None]
        if labelled:
            rates[src] = Rates.of([r.score for r in labelled if r.score is not None])
            best[src] = best_scale([(r.detection.signal, r.detection.t_s) for r in labelled],
                                   [(bool(r.slip), r.onset_s) for r in labelled],
                                   n_static=n_static)
    cells = (int(mesh[0]), int(mesh[1]))
    result = SlipFileResult(str(path), cells, fixed, int(n_static), out, rates, best,
                            None if run_dir is None else str(run_dir), scale_cv=scale_cv,
                            warnings=warnings)
    if plot is not None:
        _plot_signals(result, plot)
        result.plot = str(plot)
    return result


def parse_scale(text: str) -> float | str:
    """A ``--scale`` value: :data:`SCALE_AUTO` or a positive number (InputError naming
    `scale` otherwise)."""
    if text.strip().lower() == SCALE_AUTO:
        return SCALE_AUTO
    try:
        value = float(text)
    except ValueError:
        value = float("nan")
    if not (np.isfinite(value) and value > 0):
        raise InputError(f"`scale` (={text!r}) must be a positive number or {SCALE_AUTO!r}")
    return value


def _auto_scale(path: str, found: Sequence[tuple[Trial, str, bool | None, float | None,
                                                  np.ndarray, np.ndarray]],
                n_static: int) -> ScaleCV:
    """:func:`scale_by_cv` on the labelled trials of one source (groups: the ``object``
    label when every labelled trial has one and there are two or more, else the trial);
    InputError when they do not allow it."""
    labelled = [f for f in found if f[2] is not None]
    if not labelled:
        raise InputError("`scale='auto'` learns the threshold from trials labelled slip or "
                         "no_slip (trial label `slip`); the file has none: give a number",
                         path=path)
    objects = [f[0].labels.get("object") for f in labelled]
    by_object = (all(o is not None and str(o) != "" for o in objects)
                 and len({str(o) for o in objects}) >= 2)
    groups = [str(o) for o in objects] if by_object else [f[0].name for f in labelled]
    try:
        return scale_by_cv([(f[4], f[5]) for f in labelled], [(bool(f[2]), f[3])
                                                              for f in labelled],
                           groups, n_static=n_static,
                           group_by="object" if by_object else "trial")
    except ValueError as exc:
        raise InputError(str(exc), path=path) from None


def _check_outputs(path: str | os.PathLike[str], run_dir: str | os.PathLike[str] | None,
                   plot: str | os.PathLike[str] | None, workers: int | None) -> int:
    """Before any work: the plot folder is no input and can be written; the thread count
    (returned) is a whole number the machine can run."""
    from ..input_guard import check_outputs
    from ..store.outdir import check_output_folder
    from ..threads import check_threads

    model = None if run_dir is None else os.path.join(run_dir, "model.pt")
    check_outputs({"plot": plot}, [path, model])
    if plot is not None:
        check_output_folder(plot, merge=True)
    return default_workers() if workers is None else check_threads(workers, "workers")


def _plot_signals(result: SlipFileResult, plot: str | os.PathLike[str]) -> None:
    """One PNG per trial and source in folder ``plot`` (Figs. 5, 7, 10, 11)."""
    from ..store.outdir import output_folder
    from .plots import slip_signal_figure

    mesh = f"{result.mesh[0]}x{result.mesh[1]}"
    with output_folder(plot, merge=True) as tmp:
        for r in result.trials:
            d = r.detection
            slip_signal_figure(
                d.t_s, d.signal, d.threshold, tmp / f"slip_{r.trial}_{r.source}.png",
                onset_s=r.onset_s, detected_s=d.first_time_s,
                first_judged_s=float(d.t_s[min(d.first_judged, d.t_s.size - 1)]),
                unit="mm" if r.source == "height" else "colour units",
                title=f"{r.trial} ({r.object or '-'}, {r.source}, mesh {mesh})")


__all__ = ["DEFAULT_N_STATIC", "DEFAULT_SCALE", "SCALE_AUTO", "SCALE_GRID", "SOURCES",
           "STATIC_RISE_LIMIT", "STATIC_SPREAD_LIMIT", "Rates", "ScaleChoice", "ScaleCV",
           "ScaleFold", "SlipDetection", "SlipFileResult", "StaticCheck", "TrialScore",
           "TrialSlip", "adaptive_threshold", "best_scale", "check_static", "detect_slip",
           "parse_scale", "scale_by_cv", "score_trial", "slip_signal", "slip_signal_file",
           "trial_correct", "trial_label", "trial_maps", "wilson_interval"]
