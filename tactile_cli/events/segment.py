"""Segment one approach-press-slip-release trial into its action regions from net counts.

Paper 000, sec. 4.2 (Fig. 10): in the net event count per 20 ms bin the four actions are
visible as four regions. The expected shape (:func:`tactile_cli.fos.actions.expected_net_counts`)
is a flat approach baseline; a press that rises as eq. 16 (``alpha1 (1 - exp(-t/tau1))``)
and, once the press input ends after T, decays; a slip whose ramp response (eq. 17) grows
on top of the press tail; and a release where the ramp stops and the count falls steeply
(the slip's build-up decays and the markers spring back). The biggest forces flatten the
counts (``limit tanh(x / limit)``, :func:`tactile_cli.fos.actions.saturate`).

The method (``t`` are bin centres; every fit integrates its model over each bin, so a
boundary inside a bin is located to a fraction of a bin):

1. Smooth the net counts with a centred moving average of ``smooth_bins``.
2. The smoothed counts must rise ``k_sigma`` bin-to-bin noise std above the first bins,
   else there is no press. The bins before the smoothed curve first exceeds
   ``baseline_fraction`` of its rise (less ``smooth_bins``) are the approach: its median is
   the baseline, 1.4826 x its MAD the noise std (at least ``min_noise_std``); fewer than
   ``min_approach_bins`` such bins means no approach.
3. Press crossing: the first bin from which ``sustain_bins`` raw counts in a row exceed
   the baseline by ``k_sigma`` noise std.
4. Peaks: local maxima of the smoothed curve after the crossing whose prominence exceeds
   ``k_sigma`` times the smoothed noise there (Poisson: it grows with the count) and
   ``min_prominence_fraction`` of the curve's range. The first is the press peak, the last
   the release peak; fewer than two means no press followed by a slip: the trial fails.
5. Press start: a grid least-squares fit of ``c + a (1 - exp(-(t - t0)/tau))`` (zero
   before ``t0``) from 12 bins before the crossing up to the press peak.
6. Slip start: from the press start to the release peak the counts are the press pulse of
   eq. 16 (tau1, T) plus the ramp of eq. 17 started at ``ts`` (tau2), with both gains
   solved in closed form for every grid point (time constants within
   ``[tau_min_s, tau_max_s]``, ``T <= ts``: without such bounds a later, slower ramp and
   an earlier, faster one fit noisy counts almost equally). Saturation: compressive
   limits are tried on a coarse grid (the counts linearised as ``limit atanh(y / limit)``
   with delta-method weights) and kept only when they beat the linear model by BIC. A
   coarse grid, an alternating refinement of the press and ramp parameters and a fine
   product grid around the optimum give ``ts``. No positive ramp: the trial fails.
7. Release start: for linear counts, the corner of a continuous two-line (hinge) fit at the
   end of the release peak's top (it must turn downwards, else the trial fails); for
   saturated counts, where the corner hides in the flat top, a fit of the fall with the
   step-6 model frozen at the release (the ramp decaying with tau1, minus a release pulse)
   flattened by the fitted limit.
8. Uncertainties: each boundary's profile half-width, the range over which the weighted
   residual sum stays within one residual variance of its minimum (the other parameters
   re-fitted on the grid). They are lower bounds: on synthetic trials the errors' 68th
   percentile is 1.5 (press) to 2.5 (slip) times them. Status ``"ok"``; ``"uncertain"``
   when one exceeds ``max_uncertainty_bins``; ``"failed"`` (labels all -1, boundaries not
   found are NaN, the reason in ``message``) when the trial does not show the four regions.

Weights: the variance of a net count is about the background noise variance plus the
count itself (Poisson; the two polarities add), so the fits weight bin ``k`` by
``1 / (noise_std**2 + |smoothed_k - baseline|)``.

Measured accuracy (tests/events): synthetic trials around the paper's parameters, a
quarter saturated: all segmented, 99.3 % of bins as in the timeline; marker-scene trials
(``tactile simulate marker-events``): 99.4 % of bins as annotated, every boundary within
2.1 bins (96 trials).
"""

from __future__ import annotations

from dataclasses import asdict, dataclass, field

import numpy as np

from ..vocabulary import ACTIONS, BIN_S
from .accumulate import centred_moving_average

#: Segmentation status values.
STATUSES: tuple[str, ...] = ("ok", "uncertain", "failed")
_MAD_TO_STD = 1.4826
#: Saturation limits tried by the slip fit, as multiples of the highest smoothed count.
_LIMIT_FACTORS = (1.05, 1.15, 1.3, 1.6, 2.2, 3.5)
#: |y / limit| is clipped here before atanh (the inverse of the saturation).
_MAX_TANH = 0.97


@dataclass(frozen=True)
class SegmentOptions:
    """Settings of :func:`segment_actions` (see the module docstring for their roles)."""

    smooth_bins: int = 5
    k_sigma: float = 5.0
    sustain_bins: int = 3
    min_approach_bins: int = 5
    baseline_fraction: float = 0.1
    min_noise_std: float = 1.0
    min_prominence_fraction: float = 0.03
    max_uncertainty_bins: float = 2.0
    tau_min_s: float = 0.1
    tau_max_s: float = 1.0

    def validate(self) -> None:
        if self.smooth_bins < 1 or self.smooth_bins % 2 == 0:
            raise ValueError(f"`smooth_bins` (={self.smooth_bins}) must be odd and >= 1")
        for name in ("k_sigma", "min_noise_std", "max_uncertainty_bins"):
            if not getattr(self, name) > 0:
                raise ValueError(f"`{name}` (={getattr(self, name)}) must be > 0")
        if not 0 < self.tau_min_s < self.tau_max_s:
            raise ValueError(f"`tau_min_s` (={self.tau_min_s}) and `tau_max_s` "
                             f"(={self.tau_max_s}) must satisfy 0 < tau_min_s < tau_max_s")
        for name in ("sustain_bins", "min_approach_bins"):
            if getattr(self, name) < 1:
                raise ValueError(f"`{name}` (={getattr(self, name)}) must be >= 1")
        for name in ("baseline_fraction", "min_prominence_fraction"):
            if not 0 < getattr(self, name) < 1:
                raise ValueError(f"`{name}` (={getattr(self, name)}) must be in (0, 1)")


@dataclass(frozen=True)
class Segmentation:
    """Action regions found in one trial's net counts.

    Boundaries in seconds from the trial's time origin (NaN when not found);
    ``*_se_s`` their uncertainties (profile half-widths, lower bounds of the error: see the
    module docstring); ``labels`` (n_bins,) int8 indices into
    ``ACTIONS`` by bin centre (all -1 when ``status == "failed"``); ``message`` says why a
    trial failed or is uncertain. ``baseline`` and ``noise_std`` (events per bin) are the
    approach level and noise the thresholds were set from.
    """

    press_start_s: float
    slip_start_s: float
    release_start_s: float
    end_s: float
    labels: np.ndarray
    status: str
    message: str = ""
    press_start_se_s: float = float("nan")
    slip_start_se_s: float = float("nan")
    release_start_se_s: float = float("nan")
    baseline: float = float("nan")
    noise_std: float = float("nan")
    bin_s: float = BIN_S
    method: str = "onset fit / eq. 16 pulse + eq. 17 ramp fit / hinge or saturated-fall fit"
    options: SegmentOptions = field(default_factory=SegmentOptions)

    @property
    def segmented(self) -> bool:
        """True when the four regions were found (status ``ok`` or ``uncertain``)."""
        return self.status != "failed"

    @property
    def boundaries_s(self) -> np.ndarray:
        """(5,) start of approach, press, slip, release and the end, seconds."""
        return np.array([0.0, self.press_start_s, self.slip_start_s, self.release_start_s,
                         self.end_s])

    def intervals(self) -> list[tuple[float, float, str]]:
        """``(start_s, end_s, action)`` of the four regions (empty when failed), like
        :meth:`tactile_cli.fos.actions.ActionTimeline.intervals`."""
        if self.status == "failed":
            return []
        b = self.boundaries_s
        return [(float(b[i]), float(b[i + 1]), ACTIONS[i]) for i in range(len(ACTIONS))]

    def as_dict(self) -> dict[str, object]:
        """JSON-ready summary (without the per-bin labels)."""
        out = {k: v for k, v in asdict(self).items() if k not in ("labels", "options")}
        out["options"] = asdict(self.options)
        return {k: (None if isinstance(v, float) and not np.isfinite(v) else v)
                for k, v in out.items()}


@dataclass(frozen=True)
class _PressSlipModel:
    """The press pulse + slip ramp fitted before the release (linear, events per bin)."""

    press_s: float
    tau1_s: float
    duration_s: float
    alpha1: float
    slip_s: float
    tau2_s: float
    alpha2: float

    def components(self, t_s: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Press pulse and slip ramp (without the release) at times ``t_s``."""
        u = np.maximum(t_s - self.press_s, 0.0)
        head = np.minimum(u, self.duration_s)
        press = self.alpha1 * -np.expm1(-head / self.tau1_s) * np.exp(
            -np.maximum(u - self.duration_s, 0.0) / self.tau1_s)
        v = np.maximum(t_s - self.slip_s, 0.0) / self.tau2_s
        return press, self.alpha2 * (v + np.expm1(-v))


class _Failed(Exception):
    """Internal: the trial does not show the expected regions (message says why)."""


# -- bin-integrated model pieces (t relative to the change point, bin edges lo/hi) -----------
def _bin_mean(antiderivative, edges: np.ndarray) -> np.ndarray:
    """Mean of a function over consecutive bins from its antiderivative at the bin edges:
    edges (..., m + 1) -> (..., m)."""
    return np.diff(antiderivative(edges), axis=-1) / np.diff(edges, axis=-1)


def _rise_int(u: np.ndarray, tau: np.ndarray) -> np.ndarray:
    """Integral of ``1 - exp(-u/tau)`` from 0 to ``u`` (0 for u <= 0)."""
    up = np.maximum(u, 0.0)
    return up + tau * np.expm1(-up / tau)


def _ramp_int(u: np.ndarray, tau: np.ndarray) -> np.ndarray:
    """Integral of the unit ramp response ``u/tau - 1 + exp(-u/tau)`` from 0 to ``u``."""
    up = np.maximum(u, 0.0)
    return up * up / (2 * tau) - up - tau * np.expm1(-up / tau)


def _pulse_int(u: np.ndarray, tau: np.ndarray, dur: np.ndarray) -> np.ndarray:
    """Integral of the unit pulse response of eq. 16 (a press of ``dur`` s) from 0 to ``u``."""
    up = np.maximum(u, 0.0)
    head = np.minimum(up, dur)
    tail = np.maximum(up - dur, 0.0)
    return head + tau * np.expm1(-head / tau) - np.expm1(-dur / tau) * tau * -np.expm1(
        -tail / tau)


def _hinge_int(u: np.ndarray) -> np.ndarray:
    up = np.maximum(u, 0.0)
    return 0.5 * up * up


def _solve(bases: np.ndarray, y: np.ndarray, w: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Weighted least squares for every grid point at once.

    bases: (G, k, m) basis functions on the m bins; y, w: (m,). Returns the weighted
    residual sums (G,) and the coefficients (G, k); singular systems get an infinite sum.
    """
    bw = bases * w
    a = np.einsum("gkm,gjm->gkj", bw, bases)
    rhs = np.einsum("gkm,m->gk", bw, y)
    k = bases.shape[1]
    a = a + np.eye(k) * (1e-12 * np.trace(a, axis1=1, axis2=2)[:, None, None] / k)
    coef = np.linalg.solve(a, rhs[..., None])[..., 0]
    sse = float(np.sum(w * y * y)) - np.einsum("gk,gk->g", coef, rhs)
    return np.maximum(sse, 0.0), coef


def _solve_pair(
    first: np.ndarray, second: np.ndarray, y: np.ndarray, w: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Weighted least squares ``y ~ a1 first_i + a2 second_j`` for every pair (i, j).

    first: (G1, m), second: (G2, m) basis functions; returns the residual sums and the
    gains a1, a2, each (G1, G2). Separable grids cost matrix products, not G1 x G2 fits.
    """
    fw, sw = first * w, second * w
    ff = np.einsum("im,im->i", fw, first)[:, None]
    ss = np.einsum("jm,jm->j", sw, second)[None, :]
    # einsum, not BLAS: these products are small, and a threaded BLAS on a busy machine
    # spends milliseconds waking its threads for each
    fs = np.einsum("im,jm->ij", fw, second)
    fy = np.einsum("im,m->i", fw, y)[:, None]
    sy = np.einsum("jm,m->j", sw, y)[None, :]
    det = ff * ss - fs * fs
    ok = det > 1e-12 * ff * ss
    det = np.where(ok, det, 1.0)
    a1 = (ss * fy - fs * sy) / det
    a2 = (ff * sy - fs * fy) / det
    sse = float(np.sum(w * y * y)) - a1 * fy - a2 * sy
    return np.where(ok, np.maximum(sse, 0.0), np.inf), a1, a2


def _profile_halfwidth(grid: np.ndarray, sse: np.ndarray, dof: int) -> float:
    """Half the range of ``grid`` whose profiled sum stays within one residual variance of
    the minimum (a 1-sigma interval for a weighted least-squares fit)."""
    best = float(np.min(sse))
    if not np.isfinite(best):
        return float("nan")
    within = grid[sse <= best + best / max(dof, 1)]
    step = float(np.min(np.diff(grid))) if grid.size > 1 else 0.0
    return max(0.5 * float(within.max() - within.min()), 0.5 * step)


def _profile(points: np.ndarray, sse: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Minimum of ``sse`` over every other grid dimension for each distinct point."""
    uniq, inverse = np.unique(points, return_inverse=True)
    prof = np.full(uniq.shape, np.inf)
    np.minimum.at(prof, inverse, sse)
    return uniq, prof


class _Trial:
    """The arrays one segmentation works on."""

    def __init__(self, net: np.ndarray, bin_s: float, opts: SegmentOptions):
        self.y = net
        self.n = net.shape[0]
        self.bin_s = bin_s
        self.lo = np.arange(self.n) * bin_s
        self.hi = self.lo + bin_s
        self.t = self.lo + 0.5 * bin_s
        self.opts = opts
        self.s = centred_moving_average(net, opts.smooth_bins)
        self.baseline = float("nan")
        self.noise_std = float("nan")
        self.limit = float("inf")  # saturation limit found by the slip fit (events/bin)
        self.model: _PressSlipModel | None = None

    def edges(self, idx: np.ndarray) -> np.ndarray:
        """(1, m + 1) edges of the consecutive bins ``idx``, seconds."""
        return np.append(self.lo[idx], self.hi[idx[-1]])[None, :]

    def weights(self, idx: np.ndarray) -> np.ndarray:
        return 1.0 / (self.noise_std**2 + np.abs(self.s[idx] - self.baseline))

    # -- step 2 --------------------------------------------------------------------
    def approach_noise(self) -> None:
        o = self.opts
        top = float(self.s.max())
        level = float(np.median(self.y[: o.min_approach_bins]))
        # bin-to-bin noise of the whole trial (robust: most bins are not at a boundary)
        diff_std = _MAD_TO_STD * float(np.median(np.abs(np.diff(self.y)))) / np.sqrt(2)
        if not top - level > o.k_sigma * max(diff_std, o.min_noise_std):
            raise _Failed(
                f"no press: the smoothed net counts never rise clearly above the noise "
                f"(highest {top - level:.1f} above the first bins, noise std {diff_std:.1f})"
            )
        first = int(np.argmax(self.s > level + o.baseline_fraction * (top - level)))
        m = first - o.smooth_bins  # the average reaches about smooth_bins/2 bins ahead
        if m < o.min_approach_bins:
            raise _Failed(
                f"no approach baseline: the counts rise within the first {first} bins "
                f"(need at least {o.min_approach_bins + o.smooth_bins} flat bins first)"
            )
        approach = self.y[:m].astype(np.float64)
        self.baseline = float(np.median(approach))
        mad = float(np.median(np.abs(approach - self.baseline)))
        self.noise_std = max(_MAD_TO_STD * mad, o.min_noise_std)

    # -- step 3 --------------------------------------------------------------------
    def press_crossing(self) -> int:
        """First bin of the first run of ``sustain_bins`` raw counts above the threshold."""
        o = self.opts
        above = self.y > self.baseline + o.k_sigma * self.noise_std
        run = np.convolve(above.astype(np.int64), np.ones(o.sustain_bins, dtype=np.int64),
                          mode="valid")
        hits = np.flatnonzero(run == o.sustain_bins)
        if hits.size == 0:
            raise _Failed(
                f"no press: the net counts never stay {o.k_sigma:g} noise std above the "
                f"approach baseline {self.baseline:.1f} for {o.sustain_bins} bins"
            )
        i = int(hits[0])
        if i < o.min_approach_bins:
            raise _Failed(f"no approach baseline: the counts are above it from bin {i}")
        return i

    def press_start(self, i: int, p: int) -> tuple[float, float]:
        """Onset ``t0`` (s) and its uncertainty (s) from a fit of the rise between the
        approach and the press peak ``p``."""
        w0, w1 = max(0, i - 12), min(self.n, max(i + 6, min(p - 1, i + 30)))
        idx = np.arange(w0, w1)
        t0 = np.arange(self.lo[max(i - 4, 0)], self.hi[i] + 1e-12, self.bin_s / 20)
        tau = np.geomspace(0.03, 2.0, 24)
        t0g, taug = (a.ravel() for a in np.meshgrid(t0, tau, indexing="ij"))
        rise = _bin_mean(lambda x: _rise_int(x - t0g[:, None], taug[:, None]),
                         self.edges(idx))
        bases = np.stack([np.ones_like(rise), rise], axis=1)
        sse, coef = _solve(bases, self.y[idx].astype(np.float64), self.weights(idx))
        sse = np.where(coef[:, 1] > 0, sse, np.inf)
        if not np.isfinite(sse).any():
            raise _Failed("no press: the press onset fit found no rising response")
        j = int(np.argmin(sse))
        grid, prof = _profile(t0g, sse)
        return float(t0g[j]), _profile_halfwidth(grid, prof, idx.size - 3)

    # -- step 4 --------------------------------------------------------------------
    def peaks(self, start: int) -> tuple[int, int]:
        o = self.opts
        s = self.s[start:]
        # noise of the smoothed curve at each bin: Poisson variance grows with the count
        noise_s = np.sqrt(self.noise_std**2 + np.abs(s - self.baseline)) / np.sqrt(o.smooth_bins)
        span = float(self.s.max() - self.s.min())
        from scipy.signal import find_peaks  # here: importing scipy.signal takes ~1 s

        found, props = find_peaks(s, prominence=o.min_prominence_fraction * span)
        keep = props["prominences"] > o.k_sigma * noise_s[found]
        found = found[keep] + start
        if found.size < 2:
            raise _Failed(
                f"found {found.size} clear peak(s) of the net counts after the press start; "
                "expected a press peak followed by the slip ramp's peak at the release"
            )
        return int(found[0]), int(found[-1])

    # -- step 5 --------------------------------------------------------------------
    def linearised(self, idx: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Counts above the baseline at bins ``idx`` with the saturation undone
        (``limit * atanh(y / limit)``), and their weights (delta method)."""
        y = self.y[idx].astype(np.float64) - self.baseline
        w = self.weights(idx)
        if not np.isfinite(self.limit):
            return y, w
        r = np.clip(y / self.limit, -_MAX_TANH, _MAX_TANH)
        r_s = np.clip((self.s[idx] - self.baseline) / self.limit, -_MAX_TANH, _MAX_TANH)
        return self.limit * np.arctanh(r), w * (1.0 - r_s * r_s) ** 2

    def slip_start(self, press_s: float, p: int, g: int) -> tuple[float, float]:
        """Slip start (s) and its uncertainty (s) from the press-pulse + ramp fit between
        the press start and the release peak ``g``; sets ``self.limit``."""
        o = self.opts
        if g - 1 - (p + 1) < 6:
            raise _Failed(
                f"press peak (bin {p}) and release peak (bin {g}) are too close for a slip"
            )
        idx = np.arange(int(press_s // self.bin_s), g - 1)
        v = p + int(np.argmin(self.s[p:g]))
        edges = self.edges(idx) - press_s
        peak_s, valley_s = self.t[p] - press_s, self.t[v] - press_s
        ts_max = self.lo[min(v + 6, g - 3)] - press_s

        def bases(tau1, dur, ts, tau2):
            t1g, dg = (a.ravel()[:, None] for a in np.meshgrid(tau1, dur, indexing="ij"))
            tsg, t2g = (a.ravel()[:, None] for a in np.meshgrid(ts, tau2, indexing="ij"))
            press = _bin_mean(lambda x: _pulse_int(x, t1g, dg), edges)
            ramp = _bin_mean(lambda x: _ramp_int(x - tsg, t2g), edges)
            return press, ramp, (t1g[:, 0], dg[:, 0]), (tsg[:, 0], t2g[:, 0])

        def fit(press, ramp, dg, tsg):
            z, wz = self.linearised(idx)
            sse, a1, a2 = _solve_pair(press, ramp, z, wz)
            # gains positive; the press input ends before the slip starts (T <= region)
            valid = (a1 > 0) & (a2 > 0) & (dg[:, None] <= tsg[None, :] + 1e-9)
            sse = np.where(valid, sse, np.inf)
            k = np.unravel_index(int(np.argmin(sse)), sse.shape)
            return sse, k, (float(a1[k]), float(a2[k]))

        def grid(tau_n: int, step_bins: float):
            taus = np.geomspace(o.tau_min_s, o.tau_max_s, tau_n)
            dur = np.arange(max(peak_s - 3 * self.bin_s, self.bin_s / 2), valley_s + 1e-12,
                            step_bins * self.bin_s)
            ts = np.arange(peak_s - self.bin_s, ts_max + 1e-12, step_bins * self.bin_s)
            if dur.size == 0 or ts.size == 0:
                raise _Failed("no slip: no room for a ramp between the two peaks")
            return taus, bases(taus, dur, ts, taus)

        # saturation (the big-force flattening, ``limit tanh(x / limit)``): on a coarse grid,
        # the linear model against compressive limits above the highest count; a limit is
        # kept only when it lowers the residual sum by more than ln(n) residual variances
        # (one parameter more, as by BIC)
        _, (press, ramp, (t1c, dc), (tsc, t2c)) = grid(5, 2.0)
        top = float(np.max(self.s[idx] - self.baseline))
        best_sse, best_limit, best_k = np.inf, np.inf, (0, 0)
        for limit in (np.inf, *(top * f for f in _LIMIT_FACTORS)):
            self.limit = limit
            sse, k, *_ = fit(press, ramp, dc, tsc)
            if np.isinf(limit):
                if not np.isfinite(sse[k]):
                    raise _Failed("no slip: no growing ramp (eq. 17) fits between the peaks")
                penalty = np.log(idx.size) * float(sse[k]) / max(idx.size - 6, 1)
                best_sse, best_k = float(sse[k]), k
            elif sse[k] + penalty < best_sse:
                best_sse, best_limit, best_k = float(sse[k]), limit, k
        self.limit = best_limit
        # from the coarse optimum, alternate between the press and the ramp parameters on
        # a finer grid (each step one 1-D family of two-gain fits, not the whole product)
        taus, (press, ramp, (t1g, dg), (tsg, t2g)) = grid(10, 0.5)
        ic, jc = best_k
        i = int(np.argmin(np.abs(np.log(t1g / t1c[ic])) + np.abs(dg - dc[ic]) / self.bin_s))
        j = int(np.argmin(np.abs(np.log(t2g / t2c[jc])) + np.abs(tsg - tsc[jc]) / self.bin_s))
        for _ in range(10):
            sse, (i_new, _), *_ = fit(press, ramp[j:j + 1], dg, tsg[j:j + 1])
            sse, (_, j_new), *_ = fit(press[i_new:i_new + 1], ramp, dg[i_new:i_new + 1], tsg)
            if (i_new, j_new) == (i, j):
                break
            i, j = i_new, j_new
        if not np.isfinite(sse[0, j]):
            raise _Failed("no slip: no growing ramp (eq. 17) fits between the two peaks")
        steps = (taus[1] / taus[0]) ** np.linspace(-1, 1, 5)

        def within(tau: np.ndarray) -> np.ndarray:
            return tau[(tau >= o.tau_min_s * 0.999) & (tau <= o.tau_max_s * 1.001)]

        fine_dur = dg[i] + np.arange(-1.0, 1.01, 0.25) * self.bin_s
        fine_ts = tsg[j] + np.arange(-1.5, 1.51, 0.1) * self.bin_s
        press, ramp, (t1g, dg), (tsg, t2g) = bases(
            within(t1g[i] * steps), fine_dur[fine_dur > 0], fine_ts[fine_ts <= ts_max + 1e-9],
            within(t2g[j] * steps))
        sse, (i, j), (a1, a2) = fit(press, ramp, dg, tsg)
        self.model = _PressSlipModel(press_s, float(t1g[i]), float(dg[i]), a1,
                                     press_s + float(tsg[j]), float(t2g[j]), a2)
        grid_ts, prof = _profile(tsg, sse.min(axis=0))
        return float(press_s + grid_ts[np.argmin(prof)]), _profile_halfwidth(
            grid_ts, prof, idx.size - 6)

    # -- step 6 --------------------------------------------------------------------
    def release_start(self, g: int) -> tuple[float, float]:
        """Release start (s) and its uncertainty (s): the corner of a hinge fit at the end
        of the release peak's top (saturation undone with ``self.limit``)."""
        every = np.arange(self.n)
        z_s = self.s - self.baseline
        if np.isfinite(self.limit):
            z_s = self.limit * np.arctanh(np.clip(z_s / self.limit, -_MAX_TANH, _MAX_TANH))
        # the last bin of the peak's top: the curve is within its noise of the peak value
        noise_g = np.sqrt(self.noise_std**2 + abs(self.s[g] - self.baseline))
        near_top = z_s[g:] >= z_s[g] - noise_g / np.sqrt(self.opts.smooth_bins)
        c = g + int(np.argmin(near_top)) - 1 if not near_top.all() else self.n - 1
        if c > self.n - 4:
            raise _Failed("no release: the counts are still at their peak at the trial's end")
        if np.isfinite(self.limit) and self.model is not None:
            return self._release_saturated(g, c)
        idx = every[max(0, c - 6): min(self.n, c + 5)]
        r = np.arange(self.lo[max(c - 2, 0)], self.hi[min(c + 1, self.n - 1)] + 1e-12,
                      self.bin_s / 20)
        hinge = _bin_mean(lambda x: _hinge_int(x - r[:, None]), self.edges(idx))
        line = np.broadcast_to(self.t[idx][None, :] - self.t[c], hinge.shape)
        bases = np.stack([np.ones_like(hinge), line, hinge], axis=1)
        z, wz = self.linearised(idx)
        sse, coef = _solve(bases, z, wz)
        # the slope after the corner (coef 1 + coef 2) must be falling, and by more than before
        turns = (coef[:, 2] < 0) & (coef[:, 1] + coef[:, 2] < 0)
        sse = np.where(turns, sse, np.inf)
        if not np.isfinite(sse).any():
            raise _Failed("no release: the counts do not turn downwards after their peak")
        best = float(r[np.argmin(sse)])
        return best, _profile_halfwidth(r, sse, idx.size - 3)

    def _release_saturated(self, g: int, c: int) -> tuple[float, float]:
        """Release start under saturation, where the corner hides in the flat top: fit the
        fall after it with the model (the slip ramp frozen at the release and decaying
        with tau1, minus a release pulse), flattened by the fitted limit."""
        m, limit = self.model, self.limit
        idx = np.arange(max(0, c - 8), min(self.n, c + 12))
        sub = self.lo[idx][:, None] + (np.arange(4) + 0.5) / 4 * self.bin_s  # (m, 4)
        press, ramp = m.components(sub)
        y = self.y[idx].astype(np.float64) - self.baseline
        w = self.weights(idx)

        def sse(r: np.ndarray, dur: np.ndarray, gain: np.ndarray) -> np.ndarray:
            r_, d_, g_ = r[:, None, None, None, None], dur[None, :, None, None, None], \
                gain[None, None, :, None, None]
            after = np.maximum(sub - r_, 0.0)
            slip = np.where(sub < r_, ramp, m.components(r_)[1] * np.exp(-after / m.tau1_s))
            release = g_ * -np.expm1(-np.minimum(after, d_) / m.tau1_s) * np.exp(
                -np.maximum(after - d_, 0.0) / m.tau1_s)
            model = (limit * np.tanh((press + slip - release) / limit)).mean(axis=-1)
            return np.sum(w * (y - model) ** 2, axis=-1)

        durs = np.array([0.05, 0.1, 0.15, 0.2, 0.3, 0.4])
        gains = m.alpha1 * np.geomspace(0.2, 2.0, 12)
        r = np.arange(self.lo[max(g - 4, 0)], self.hi[min(c + 3, self.n - 1)] + 1e-12,
                      self.bin_s / 2)
        coarse = sse(r, durs, gains)
        i, j, k = np.unravel_index(int(np.argmin(coarse)), coarse.shape)
        fine_r = r[i] + np.arange(-0.75, 0.76, 0.05) * self.bin_s
        prof = sse(fine_r, durs[max(j - 1, 0): j + 2], gains[max(k - 1, 0): k + 2])
        prof = prof.reshape(fine_r.size, -1).min(axis=1)
        return float(fine_r[np.argmin(prof)]), _profile_halfwidth(fine_r, prof, idx.size - 3)


def segment_actions(
    net: np.ndarray,
    *,
    bin_s: float = BIN_S,
    smooth_bins: int = 5,
    options: SegmentOptions | None = None,
) -> Segmentation:
    """Find the press, slip and release starts of one trial from its net counts per bin.

    net: (n_bins,) net events (positive minus negative) per bin of ``bin_s`` seconds, bin 0
    starting at the trial's time origin. ``smooth_bins`` (odd) overrides
    ``options.smooth_bins``. Returns a :class:`Segmentation`; a trial that does not show
    approach, press, slip and release gets ``status="failed"`` and a ``message``, never
    made-up boundaries. See the module docstring for the method.
    """
    opts = options or SegmentOptions()
    if smooth_bins != opts.smooth_bins:
        opts = SegmentOptions(**{**asdict(opts), "smooth_bins": smooth_bins})
    opts.validate()
    net = np.asarray(net)
    if net.ndim != 1:
        raise ValueError(f"`net` must be (n_bins,), got shape {net.shape}")
    if not np.isfinite(net).all():
        raise ValueError("`net` holds NaN or inf")
    n = net.shape[0]
    end_s = n * bin_s
    found = {"press_start_s": np.nan, "slip_start_s": np.nan, "release_start_s": np.nan}
    errors = {"press_start_se_s": np.nan, "slip_start_se_s": np.nan,
              "release_start_se_s": np.nan}
    trial = None
    try:
        if n < 4 * opts.min_approach_bins + 2 * opts.smooth_bins:
            raise _Failed(f"only {n} bins: too short for four action regions")
        trial = _Trial(net, bin_s, opts)
        trial.approach_noise()
        crossing = trial.press_crossing()
        p, g = trial.peaks(max(crossing - opts.smooth_bins, 0))
        press, errors["press_start_se_s"] = trial.press_start(crossing, p)
        found["press_start_s"] = press
        slip, errors["slip_start_se_s"] = trial.slip_start(press, p, g)
        found["slip_start_s"] = slip
        release, errors["release_start_se_s"] = trial.release_start(g)
        found["release_start_s"] = release
        if not press < slip < release < end_s:
            raise _Failed(f"boundaries out of order: press {press:.3f} s, slip {slip:.3f} s, "
                          f"release {release:.3f} s")
    except _Failed as exc:
        status, message = "failed", str(exc)
        labels = np.full(n, -1, dtype=np.int8)
    else:
        t = (np.arange(n) + 0.5) * bin_s
        edges = np.array([found["press_start_s"], found["slip_start_s"],
                          found["release_start_s"]])
        labels = np.searchsorted(edges, t, side="right").astype(np.int8)
        wide = {k: v for k, v in errors.items()
                if not v <= opts.max_uncertainty_bins * bin_s}
        status, message = "ok", ""
        if wide:
            status = "uncertain"
            message = "; ".join(f"{k.removesuffix('_se_s')} uncertain by "
                                f"{v / bin_s:.1f} bins" for k, v in wide.items())
    return Segmentation(
        **{k: float(v) for k, v in found.items()},
        end_s=float(end_s), labels=labels, status=status, message=message,
        **{k: float(v) for k, v in errors.items()},
        baseline=float(trial.baseline) if trial is not None else float("nan"),
        noise_std=float(trial.noise_std) if trial is not None else float("nan"),
        bin_s=float(bin_s), options=opts,
    )


@dataclass(frozen=True)
class SegmentationScore:
    """Agreement of predicted and true per-bin labels of one trial.

    bin_accuracy: fraction of the labelled true bins (label >= 0) whose predicted label
    matches. boundary_errors_s: (3,) predicted minus true start of press, slip and release,
    seconds, from the first bin of each label (NaN where either labelling lacks it).
    """

    bin_accuracy: float
    n_bins: int
    boundary_errors_s: np.ndarray


def segmentation_accuracy(
    pred_labels: np.ndarray, true_labels: np.ndarray, *, bin_s: float = BIN_S
) -> SegmentationScore:
    """Score predicted per-bin action labels against true ones (both (n_bins,) ints into
    ``ACTIONS``, -1 for none; true -1 bins are not scored)."""
    pred = np.asarray(pred_labels)
    true = np.asarray(true_labels)
    if pred.shape != true.shape or pred.ndim != 1:
        raise ValueError(f"label arrays must be 1-D of equal length, got {pred.shape} and "
                         f"{true.shape}")
    scored = true >= 0
    n = int(scored.sum())
    accuracy = float((pred[scored] == true[scored]).mean()) if n else float("nan")

    def first(labels: np.ndarray, k: int) -> float:
        hit = np.flatnonzero(labels == k)
        return float(hit[0]) if hit.size else float("nan")

    errors = np.array([(first(pred, k) - first(true, k)) * bin_s
                       for k in range(1, len(ACTIONS))])
    return SegmentationScore(accuracy, n, errors)


__all__ = ["STATUSES", "SegmentOptions", "Segmentation", "SegmentationScore",
           "segment_actions", "segmentation_accuracy"]
