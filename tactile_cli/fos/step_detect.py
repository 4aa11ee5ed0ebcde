"""Steps found in a sampled signal, for fits without annotated regions (``tactile fit-fos FILE
--stream NAME --regions detect``).

A step here is a fast change of level: a gripper closing on a taxel pad (a rise) or letting
go (a fall). The detector works on lagged differences ``d_w[i] = x[i + w] - x[i]`` in units
of the noise: for a first-order step of amplitude A starting at sample ``o``, ``d_w`` peaks
exactly at ``i = o`` (before it the window only holds part of the rise, after it the rise
has slowed), at ``A (1 - exp(-w dt / tau))``. So:

1. The noise: ``sigma = 1.4826 MAD(diff(x)) / sqrt(2)`` (robust to the steps themselves), at
   least a quarter of the signal's smallest nonzero change (quantised ADC counts).
2. The scale: the smallest lag ``w`` (1, 2, 4, ... samples, at most an eighth of the signal)
   whose largest ``|d_w|`` reaches 80 % of the largest over every lag. That is about 1.6
   time constants of the fastest large change: long enough to see it whole, short enough
   that a slow creep or relaxation after a press changes little within it.
3. The steps: where ``|d_w| / (sigma sqrt 2)`` exceeds ``min_snr``, one per run of such
   samples (its peak, the coarse onset), kept when its ``|d_w|`` is at least
   ``min_fraction`` of the largest one. Onsets of one sign closer than ``2 w`` samples are
   one step.
4. The onset: the early rise (10 % to 40 % of the step) extrapolated back to the level
   before it, corrected for the curvature of a first-order rise, and rounded to the nearest
   sample (see :func:`_refine`; ``benchmarks/stream_step_detect.py`` measures it). The
   peak of ``d_w`` alone is noisy there: its window still holds most of the rise when it
   starts a little early.

Each step's region runs from its onset to the next step's onset (or one sample past the
end of the signal); it is labelled ``rise`` or ``fall``. Detection is per curve: each channel
fitted (or their mean) is searched on its own, so a channel that never responds is
reported, not fitted.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

#: Default threshold: a step's lagged difference over the noise of such a difference.
MIN_SNR = 8.0
#: Default: a step must change at least this share of the largest step's change.
MIN_FRACTION = 0.25
#: A lag reaching this share of the best lag's largest change is long enough.
_SCALE_SHARE = 0.8


@dataclass(frozen=True)
class DetectedStep:
    """One step: ``start_s`` its onset, ``end_s`` the next onset (or one sample past the
    signal's end), both in the signal's time; ``label`` ``"rise"`` or ``"fall"``;
    ``change`` the lagged difference at the onset (signal units, over ``lag_s``);
    ``snr`` that change over the noise of a lagged difference."""

    start_s: float
    end_s: float
    label: str
    change: float
    snr: float
    lag_s: float


def held_run_length(x: ArrayLike) -> float:
    """The median length of the runs of exactly equal consecutive samples of ``x``: 1 for a
    signal that changes every sample, about 4 for a 42 Hz logger that repeats a sensor's
    value between its ~10 Hz updates (``xela_press``)."""
    v = np.asarray(x, dtype=np.float64)
    if v.size < 2:
        return 1.0
    change = np.flatnonzero(v[1:] != v[:-1])
    bounds = np.concatenate([[0], change + 1, [v.size]])
    return float(np.median(np.diff(bounds)))


def noise_sigma(x: ArrayLike) -> float:
    """Robust sample noise of ``x`` (n,): 1.4826 MAD of first differences over sqrt 2,
    floored at a quarter of the smallest nonzero first difference; 0 for a constant signal.
    A signal of held samples (median run of equal samples of 2 or more: a logger faster than
    its sensor) is measured between its distinct values: its many zero differences are
    repeats, not a noiseless sensor."""
    v = np.asarray(x, dtype=np.float64)
    d = np.diff(v)
    if d.size == 0:
        return 0.0
    if held_run_length(v) >= 2:
        d = d[d != 0]
        if d.size == 0:
            return 0.0
    mad = 1.4826 * float(np.median(np.abs(d - np.median(d)))) / np.sqrt(2.0)
    nonzero = np.abs(d[d != 0])
    floor = 0.25 * float(nonzero.min()) if nonzero.size else 0.0
    return max(mad, floor)


def _lagged(x: np.ndarray, w: int) -> np.ndarray:
    return x[w:] - x[:-w]


def _refine(t: np.ndarray, x: np.ndarray, onset: int, w: int, sigma: float = 0.0) -> int:
    """The onset sample, from the early rise: a line through the samples of the rise between
    10 % and 40 % of the way from the level before the step (the ``w`` samples before the coarse
    onset, less 3) to the level after it (the median of the ``w`` samples from ``w`` past
    the onset), extrapolated back to the level before. For a first-order rise that line
    meets it about 0.035 tau before the true onset, which is added back (``0.03 span /
    slope``, span/slope being about 1.2 tau); the onset sample is the one nearest that time
    (a start a sample late or early biases tau by about dt/tau, either way).

    A rise that is not one smooth curve (a gripper closing in stages: a staircase) bends
    that line, which then meets the level before far too early. The departure from that
    level bounds it: the last sample, before the rise's first sample past 10 %, that lies
    within ``max(4 sigma, 5 % of the step)`` of the level before. An extrapolated onset
    earlier than the departure by more than the band's own length (a first-order rise's
    onset lies about a quarter of the band before it), and a rise faster than the sampling
    (fewer than 2 samples in the band), get the departure."""
    before = x[max(0, onset - w - 3):max(1, onset - 3)]
    after = x[min(onset + w, x.size - 1):min(onset + 2 * w, x.size)]
    if before.size == 0 or after.size == 0:
        return onset
    low, high = float(np.median(before)), float(np.median(after))
    span = high - low
    if span == 0.0:
        return onset
    lo, hi = max(0, onset - w), min(x.size, onset + w + 1)
    share = (x[lo:hi] - low) / span
    # the rise itself: back from the first sample past 40 % to the last one under 10 %
    # (noisy baseline samples above 10 % before the rise are not part of it)
    past = np.flatnonzero(share > 0.4)
    if past.size == 0:
        return onset
    under = np.flatnonzero(share[:past[0]] < 0.1)
    first = under[-1] + 1 if under.size else 0
    tol = max(4.0 * sigma, 0.05 * abs(span))
    near = np.flatnonzero(np.abs(x[lo:lo + first + 1] - low) <= tol)
    departure = lo + (int(near[-1]) if near.size else 0)
    band = np.arange(first, past[0]) + lo
    if band.size < 2 or np.ptp(t[band]) == 0.0:
        return departure
    slope, intercept = np.polyfit(t[band], x[band] - low, 1)
    if not slope * span > 0:
        return departure
    # the line meets the level before ~0.035 tau early, and span/slope is ~1.2 tau
    t0 = -intercept / slope + 0.03 * span / slope
    dt = sample_step_s(t)
    found = int(np.searchsorted(t, t0 + 0.5 * dt, side="right") - 1)
    if found < departure - max(2, band.size):  # a staircase, not a smooth rise
        return departure
    return int(np.clip(found, lo, min(hi, x.size) - 1))


@dataclass(frozen=True)
class SkippedStep:
    """A step found but not fitted: ``start_s`` its onset, ``label``, and ``reason``."""

    start_s: float
    label: str
    reason: str


@dataclass(frozen=True)
class StepSearch:
    """What :func:`find_steps` found in one signal: the fittable ``steps``; the ``skipped``
    ones with why (a step cut by the end of the recording); ``reason``, why there is no
    step at all (None when there is one); the noise ``sigma`` (signal units), the lag
    ``lag_s`` of the differences (None before it is chosen), the median run of held
    samples and the samples dropped as not finite."""

    steps: list[DetectedStep]
    skipped: list[SkippedStep]
    reason: str | None
    sigma: float
    lag_s: float | None
    held_run: float
    dropped: int

    @property
    def why_not(self) -> str | None:
        """Why the signal gives nothing to fit (None when it gives a step)."""
        if self.steps:
            return None
        if self.skipped:
            return "; ".join(f"{k.label} at {k.start_s:.3f} s {k.reason}" for k in self.skipped)
        return self.reason


#: A step back after a step is a relaxation of it (not a release) while the level it settles
#: at keeps more than this share of the first step's excursion.
RELAX_SHARE = 0.5


def _merge_relaxations(x: np.ndarray, found: list[tuple[int, int]], d: np.ndarray, w: int
                       ) -> list[tuple[int, int]]:
    """``found`` (refined start, coarse onset) without the opposite steps that only relax a
    step: a press that overshoots and creeps back part of the way is one press, whose region
    runs to the release. A step back whose settled level (the median of ``w`` samples from
    ``w`` past its coarse onset) keeps more than :data:`RELAX_SHARE` of the excursion of the
    step before it (from the level before that step to its extreme before the step back) is
    dropped; one that returns further is a release and stays."""
    out = list(found)
    k = 0
    while k + 1 < len(out):
        (s0, o0), (s1, o1) = out[k], out[k + 1]
        if np.sign(d[o0]) == np.sign(d[o1]) or s1 <= s0:
            k += 1
            continue
        base = float(np.median(x[max(0, s0 - w):s0])) if s0 > 0 else float(x[0])
        sign = np.sign(d[o0])
        extreme = float(sign * np.max(sign * x[s0:s1]))
        tail = x[min(o1 + w, x.size - 1):min(o1 + 2 * w, x.size)]
        settled = float(np.median(tail)) if tail.size else float(x[-1])
        excursion = extreme - base
        if excursion != 0.0 and (settled - base) / excursion > RELAX_SHARE:
            del out[k + 1]  # a relaxation: the first step's region runs on
        else:
            k += 1
    return out


def sample_step_s(t: np.ndarray) -> float:
    """The median positive step of ``t`` (s): the sample period, with repeated timestamps
    left out; 0 when ``t`` never advances."""
    d = np.diff(np.asarray(t, dtype=np.float64))
    d = d[d > 0]
    return float(np.median(d)) if d.size else 0.0


def find_steps(
    t_s: ArrayLike, x: ArrayLike, *, min_snr: float = MIN_SNR,
    min_fraction: float = MIN_FRACTION, min_points: int = 4,
) -> StepSearch:
    """The steps of one signal (see the module doc), in time order, and why any were left
    out. Never raises on a real stream: held (repeated) samples, repeated timestamps, a
    step cut by the end of the recording, a flat channel, a drifting baseline and
    non-finite samples (dropped) each give steps or a reason.

    ``t_s`` (n,) non-decreasing seconds, ``x`` (n,) the signal. A step whose region holds
    fewer than ``min_points`` samples is skipped (it cannot be fitted), with its reason.
    Raises ValueError only for arguments of the wrong shape or range (a caller's bug).
    """
    t = np.asarray(t_s, dtype=np.float64)
    x = np.asarray(x, dtype=np.float64)
    if t.ndim != 1 or t.shape != x.shape:
        raise ValueError(f"`t_s` {t.shape} and `x` {x.shape} must be (n,) arrays of one "
                         "length.")
    if not (min_snr > 0 and 0 < min_fraction <= 1):
        raise ValueError(f"`min_snr` (={min_snr}) must be > 0 and `min_fraction` "
                         f"(={min_fraction}) in (0, 1].")
    finite = np.isfinite(t) & np.isfinite(x)
    dropped = int((~finite).sum())
    t, x = t[finite], x[finite]
    if t.size > 1 and np.any(np.diff(t) < 0):  # out of order: in time order, stably
        order = np.argsort(t, kind="stable")
        t, x = t[order], x[order]
    n = x.size
    held = held_run_length(x)

    def nothing(reason: str, sigma: float = 0.0, lag_s: float | None = None) -> StepSearch:
        return StepSearch([], [], reason, sigma, lag_s, held, dropped)

    if n < 2 * min_points:
        return nothing(f"too short: {n} finite samples, at least {2 * min_points} needed")
    if np.ptp(x) == 0.0:
        return nothing("flat: the signal never changes")
    dt = sample_step_s(t)
    if dt == 0.0:
        return nothing("no time passes: every sample has the same timestamp")
    sigma = noise_sigma(x) or 1e-300
    lags = [1]
    while lags[-1] * 2 <= max(1, n // 4):
        lags.append(lags[-1] * 2)
    peaks = [float(np.max(np.abs(_lagged(x, w)))) for w in lags]
    best = max(peaks)
    w = next(w for w, p in zip(lags, peaks, strict=True) if p >= _SCALE_SHARE * best)
    lag_s = dt * w
    d = _lagged(x, w)
    z = np.abs(d) / (sigma * np.sqrt(2.0))
    above = z > min_snr
    if not above.any():
        return nothing(f"no change reaches {min_snr:g} times the noise (the largest is "
                       f"{float(z.max()):.3g} times; noise {sigma:.3g})", sigma, lag_s)
    peaks_at: list[int] = []
    i = 0
    while i < d.size:  # one coarse onset per run of samples above the threshold: its peak
        if not above[i]:
            i += 1
            continue
        j = i
        while j < d.size and above[j] and np.sign(d[j]) == np.sign(d[i]):
            j += 1
        peak = i + int(np.argmax(np.abs(d[i:j])))
        if (peaks_at and peak - peaks_at[-1] < 2 * w
                and np.sign(d[peak]) == np.sign(d[peaks_at[-1]])):
            if abs(d[peak]) > abs(d[peaks_at[-1]]):
                peaks_at[-1] = peak
        else:
            peaks_at.append(peak)
        i = j
    largest = max(abs(d[o]) for o in peaks_at)
    peaks_at = [o for o in peaks_at if abs(d[o]) >= min_fraction * largest]
    # the size, sign and SNR of a step are those at its coarse onset (an index into the
    # lagged differences); only its start moves to the refined onset (an index into x)
    found: list[tuple[int, int]] = []
    for o in peaks_at:
        start = _refine(t, x, o, w, sigma)
        if found and start <= found[-1][0]:  # two onsets refined onto one sample: one step
            if abs(d[o]) > abs(d[found[-1][1]]):
                found[-1] = (found[-1][0], o)
            continue
        found.append((start, o))
    found = _merge_relaxations(x, found, d, w)
    bounds = [float(t[s]) for s, _ in found] + [float(t[-1]) + dt]
    steps: list[DetectedStep] = []
    skipped: list[SkippedStep] = []
    for k, (_, o) in enumerate(found):
        start, end = bounds[k], bounds[k + 1]
        label = "rise" if d[o] > 0 else "fall"
        count = int(((t >= start) & (t < end)).sum())
        if count < min_points:
            last = k == len(found) - 1
            skipped.append(SkippedStep(start, label, (
                f"is cut by the end of the recording ({count} samples after its onset, "
                f"{min_points} needed)" if last else
                f"holds {count} samples before the next step ({min_points} needed)")))
            continue
        steps.append(DetectedStep(start, end, label, float(d[o]), float(z[o]), lag_s))
    return StepSearch(steps, skipped, None, sigma, lag_s, held, dropped)


def detect_steps(
    t_s: ArrayLike, x: ArrayLike, *, min_snr: float = MIN_SNR,
    min_fraction: float = MIN_FRACTION, min_points: int = 4,
) -> list[DetectedStep]:
    """The steps of one signal (see the module doc), in time order; empty when none
    (:func:`find_steps` says why).

    ``t_s`` (n,) increasing seconds, ``x`` (n,) the signal. A step whose region holds fewer
    than ``min_points`` samples is dropped (it cannot be fitted).
    """
    return find_steps(t_s, x, min_snr=min_snr, min_fraction=min_fraction,
                      min_points=min_points).steps


def level_before(t: np.ndarray, x: np.ndarray, start: float, end: float) -> float:
    """The level before a region ``[start, end)``: the mean of the samples in the window of
    the same length just before it, else the region's first sample (as ``fit-fos
    --stream`` subtracts it)."""
    before = (t < start) & (t >= start - (end - start))
    if before.any():
        return float(np.mean(x[before]))
    return float(x[(t >= start) & (t < end)][0])


def best_step_start(t_s: ArrayLike, x: ArrayLike, start_s: float, end_s: float, *,
                    shifts: int = 1, n_tau: int = 160) -> float:
    """The start among the found one and the ``shifts`` samples either side of it whose
    first-order step ``alpha (1 - exp(-t/tau))`` (baseline subtracted) leaves the smallest
    residual per sample over the rise (up to three times the time to 90 % of the largest
    excursion). A start a sample off is a shape no first-order step takes (and one
    a second-order system with a zero does), so the order verdict depends on it
    (``benchmarks/stream_step_detect.py``).

    The fit is a grid over ``n_tau`` log-spaced tau from a tenth of a sample to the region's
    length, alpha in closed form; numpy only (about 0.5 ms for 600 samples and 3 starts).
    """
    t = np.asarray(t_s, dtype=np.float64)
    x = np.asarray(x, dtype=np.float64)
    k = int(np.searchsorted(t, start_s))
    dt = sample_step_s(t)
    if dt == 0.0 or not np.all(np.isfinite(x)):
        return start_s
    taus = np.geomspace(0.1 * dt, max(end_s - start_s, 2 * dt), n_tau)
    best, best_start = np.inf, start_s
    for j in range(max(0, k - shifts), min(t.size - 4, k + shifts + 1)):
        inside = (t >= t[j]) & (t < end_s)
        if inside.sum() < 4:
            continue
        tt = t[inside] - t[j]
        y = x[inside] - level_before(t, x, float(t[j]), end_s)
        # the rise only: up to three times the time to 90 % of the largest excursion, so
        # that a later creep or relaxation does not choose the start
        t90 = tt[int(np.argmax(np.abs(y) >= 0.9 * np.max(np.abs(y))))]
        early = tt <= max(3.0 * t90, 4 * dt)
        tt, y = tt[early], y[early]
        basis = -np.expm1(-tt[None, :] / taus[:, None])  # (n_tau, n)
        gain = basis @ y / np.einsum("ij,ij->i", basis, basis)
        rss = np.min(np.sum((y[None, :] - gain[:, None] * basis) ** 2, axis=1)) / tt.size
        if rss < best:
            best, best_start = rss, float(t[j])
    return best_start


__all__ = ["MIN_FRACTION", "MIN_SNR", "RELAX_SHARE", "DetectedStep", "SkippedStep", "StepSearch",
           "best_step_start", "detect_steps", "find_steps", "held_run_length", "level_before",
           "noise_sigma", "sample_step_s"]
