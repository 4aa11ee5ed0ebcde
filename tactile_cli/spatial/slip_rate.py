"""Slip velocity, displacement and speed from ROI centroids (paper 000, sec. 5.2, eqs. 20-21).

From the event-weighted centroids of the marker-strip ROIs (eq. 19, :mod:`.roi`):

- eq. 20, velocity: the centroid's rate of change, ``v(t) = d y_bar / dt``, here
  ``np.gradient`` (central differences, one-sided at the ends) of the bin series;
- eq. 21, displacement: ``d(t) = integral_{t1}^{t} v dt``, the trapezoid rule over the bins
  (the integration low-passes the noisy velocity, as the paper notes);
- the slip speed (Fig. 23): the slope of a straight line through ``y_bar(t)`` over the slip
  region. All ROIs share the slope and each has its own intercept, in one least-squares
  fit over every ROI's bins weighted by the events behind each centroid (a centroid of N
  events varies as 1/N, so the sparse bins where the slip starts count less).

Only the vertical coordinate is used, as in the paper ("only the y_bar coordinate is used to
estimate the object's slip displacement"); its sign follows the pixel grid (a falling
object moves the strips up, a negative slope), so the speed is the slope's magnitude and
the signed velocity is reported beside it. Pixels become metres through the strip optics
(eqs. 3 and 15, :mod:`.optics`).

Uncertainties: the slope's standard error is the weighted least-squares one, its scale
estimated from the residuals (bins treated as independent). The eq. 21 displacement is a
fixed linear combination ``c . y_bar`` of the region's bins, so its variance is
``sum c_i^2 sigma^2 / W_i`` with ``W_i`` the events of bin i and ``sigma`` the fit's scale.
Neither covers a bias of the centroid itself (background events inside an ROI pull it
towards the ROI's middle; a median filter removes most of them).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import asdict, dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import InputError
from ..store.trials import TactileFile, Trial
from .config import CentroidOptions, SlipOptions, SpatialConfig
from .optics import StripOptics
from .roi import (
    Roi,
    background_rate,
    event_density,
    propose_rois,
    trial_roi_centroids,
)
from .trial_events import event_trial_names, spatial_events

#: Fewest bins with a centroid in the fit region for a slope to be reported.
MIN_FIT_BINS = 5
#: A proposed slip ROI takes every pixel box with at least this share of the densest box's
#: events (and above the Poisson background test). A strip's path is sparse where the slip
#: starts (a few events per pixel row against ~1,000 mid-path), so the 5 % used for blobs
#: cut the start off: the centroid then sat on the ROI's edge until the strip came in, and
#: the eq. 21 displacement came out 8 % short in the median, up to 37 % (seeds 303 and
#: 400: 1 % gives a median 1 %, at most 8.5 %; the speed is within 0.3 % either way).
SLIP_ROI_MIN_FRACTION = 0.01


def centroid_velocity(t_s: np.ndarray, y_px: np.ndarray) -> np.ndarray:
    """Eq. 20: (n,) or (n, k) centroid px -> same-shape velocity in px/s (``np.gradient``
    along time; needs n >= 2)."""
    return np.gradient(np.asarray(y_px, dtype=np.float64), np.asarray(t_s, dtype=np.float64),
                       axis=0)


def _end_weights(t_s: np.ndarray, block: int = 256) -> np.ndarray:
    """(n,) ``c`` with eq. 21's end value ``d_end = c . y`` for bins at ``t_s``: eqs. 20-21
    applied to unit vectors, ``block`` of them at a time (memory n x block, not n x n: a
    2 s slip in 0.2 ms bins is 10,000 bins)."""
    n = t_s.shape[0]
    c = np.empty(n)
    for first in range(0, n, block):
        unit = np.zeros((n, min(block, n - first)))
        unit[first + np.arange(unit.shape[1]), np.arange(unit.shape[1])] = 1.0
        c[first:first + unit.shape[1]] = integrate_displacement(
            t_s, centroid_velocity(t_s, unit))[-1]
    return c


def integrate_displacement(t_s: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Eq. 21: cumulative trapezoid integral along axis 0 of ``v`` (n,) or (n, k) px/s from
    ``t_s[0]``; same shape in px, 0 at the first sample."""
    t_s = np.asarray(t_s, dtype=np.float64)
    v = np.asarray(v, dtype=np.float64)
    dt = np.diff(t_s).reshape(-1, *([1] * (v.ndim - 1)))
    steps = 0.5 * (v[1:] + v[:-1]) * dt
    return np.concatenate([np.zeros((1, *v.shape[1:])), np.cumsum(steps, axis=0)])


@dataclass(frozen=True)
class SlopeFit:
    """A straight line with one slope shared by k series and one intercept per series.

    slope: px/s; slope_se: its standard error; intercepts: (k,) px at t = 0 (NaN for a
    series without points); sigma_unit: residual scale of a point of weight 1 (px), so a
    point of weight w has standard deviation ``sigma_unit / sqrt(w)``; residual_std: plain
    RMS of the residuals (px); r2: weighted fraction of the variance around the series'
    means that the line explains; n_points, dof as used.
    """

    slope: float
    slope_se: float
    intercepts: np.ndarray
    sigma_unit: float
    residual_std: float
    r2: float
    n_points: int
    dof: int


def fit_common_slope(t_s: np.ndarray, y: np.ndarray,
                     weights: np.ndarray | None = None) -> SlopeFit:
    """Weighted least squares ``y[i, j] = a_j + b t_i`` over the finite entries of (n, k)
    ``y`` with positive ``weights`` (same shape; None = all 1).

    With ``weights`` proportional to the events behind each centroid (a centroid of N events
    has variance ``s^2 / N``) this is the maximum-likelihood line; the scale ``sigma_unit``
    is estimated from the weighted residuals, so the weights need only be relative.
    Raises ValueError when fewer than k + 2 points remain or time does not vary.
    """
    t_s = np.asarray(t_s, dtype=np.float64)
    y = np.asarray(y, dtype=np.float64)
    if y.ndim == 1:
        y = y[:, None]
    wts = np.ones_like(y) if weights is None else np.asarray(weights, dtype=np.float64)
    if wts.ndim == 1:
        wts = wts[:, None]
    if wts.shape != y.shape:
        raise ValueError(f"`weights` shape {wts.shape} differs from `y` shape {y.shape}")
    ok = np.isfinite(y) & np.isfinite(wts) & (wts > 0)
    w = np.where(ok, wts, 0.0)
    used = ok.any(axis=0)
    n_points = int(ok.sum())
    dof = n_points - int(used.sum()) - 1
    if dof < 1:
        raise ValueError(f"{n_points} finite points for {int(used.sum())} series: too few "
                         "for a slope and its standard error")
    wsum = w.sum(axis=0)
    safe = np.where(used, wsum, 1.0)
    t_mean = (w * t_s[:, None]).sum(axis=0) / safe
    y_mean = (w * np.where(ok, y, 0.0)).sum(axis=0) / safe
    dt = np.where(ok, t_s[:, None] - t_mean, 0.0)
    dy = np.where(ok, y - y_mean, 0.0)
    sxx = float((w * dt * dt).sum())
    if sxx <= 0:
        raise ValueError("time does not vary within the series; no slope")
    slope = float((w * dt * dy).sum()) / sxx
    resid = np.where(ok, dy - slope * dt, 0.0)
    wrss = float((w * resid * resid).sum())
    wtss = float((w * dy * dy).sum())
    sigma2 = wrss / dof
    intercepts = np.where(used, y_mean - slope * t_mean, np.nan)
    return SlopeFit(slope, float(np.sqrt(sigma2 / sxx)), intercepts, float(np.sqrt(sigma2)),
                    float(np.sqrt((resid * resid).sum() / n_points)),
                    1.0 - wrss / wtss if wtss > 0 else float("nan"), n_points, dof)


@dataclass(frozen=True)
class SlipTrace:
    """The curves behind one trial's slip rate (Fig. 23).

    t_s: (n_bins,) bin centres, trial seconds. centroid_y_px: (n_bins, n_rois) y_bar per
    ROI (NaN where empty). intercepts_px: (n_rois,) each ROI's fitted intercept.
    aligned_y_px: (n_bins,) the ROI average after removing each ROI's intercept (NaN where
    every ROI is empty). In the slip region only (NaN elsewhere): velocity_px_s (eq. 20) and
    displacement_px (eq. 21 from the region's first bin). fitted_y_px: the line, in the fit
    region only. in_slip, in_fit: (n_bins,) bool, the bins of the slip and fit regions.
    """

    t_s: np.ndarray
    centroid_y_px: np.ndarray
    intercepts_px: np.ndarray
    aligned_y_px: np.ndarray
    velocity_px_s: np.ndarray
    displacement_px: np.ndarray
    fitted_y_px: np.ndarray
    in_slip: np.ndarray
    in_fit: np.ndarray
    rois: tuple[Roi, ...]


@dataclass
class SlipRate:
    """Slip speed and displacement of one trial; ``status`` is ``ok`` or why not.

    slip_start_s/slip_end_s: the slip region (annotated or from labels, see region_source);
    fit_start_s/fit_end_s: the part the line is fitted to (the slip region shortened by the
    config's ``edge_trim_s`` at both ends). velocity_px_s (+ _se): signed slope of the
    centroid's y (image rows grow downwards); speed_m_s (+ _se): its magnitude in m/s
    through the optics. displacement_m (+ _se): eq. 21, the integral of the eq. 20 velocity
    over the slip region's bins, from the first bin centre to the last
    (displacement_start_s..displacement_end_s); displacement_fit_m (+ _se): the speed times
    that same span. background_px_hz: the background subtracted from the centroids (events
    per pixel per second; None: none). truth_speed_m_s: the trial label ``slip_speed_m_s``
    when present, with speed_rel_error = speed / truth - 1.
    """

    trial: str
    status: str = "ok"
    message: str = ""
    region_source: str = ""
    slip_start_s: float = float("nan")
    slip_end_s: float = float("nan")
    fit_start_s: float = float("nan")
    fit_end_s: float = float("nan")
    n_bins: int = 0
    n_rois_used: int = 0
    velocity_px_s: float = float("nan")
    velocity_se_px_s: float = float("nan")
    speed_m_s: float = float("nan")
    speed_se_m_s: float = float("nan")
    displacement_m: float = float("nan")
    displacement_se_m: float = float("nan")
    displacement_fit_m: float = float("nan")
    displacement_fit_se_m: float = float("nan")
    displacement_start_s: float = float("nan")
    displacement_end_s: float = float("nan")
    r2: float = float("nan")
    residual_std_px: float = float("nan")
    strip_m_per_px: float = float("nan")
    truth_speed_m_s: float | None = None
    speed_rel_error: float | None = None
    background_px_hz: float | None = None
    rois: list[dict[str, Any]] = field(default_factory=list)

    def as_dict(self) -> dict[str, Any]:
        out = asdict(self)
        for k, v in out.items():  # JSON has no NaN
            if isinstance(v, float) and not np.isfinite(v):
                out[k] = None
        return out


def slip_rate_from_centroids(
    t_s: np.ndarray,
    centroid_y_px: np.ndarray,
    weight: np.ndarray | None = None,
    *,
    slip_start_s: float,
    slip_end_s: float,
    optics: StripOptics,
    edge_trim_s: float = 0.0,
    trial: str = "",
) -> tuple[SlipRate, SlipTrace | None]:
    """Speed and displacement from (n_bins, n_rois) centroid y (px) at bin centres ``t_s``;
    ``weight`` (n_bins, n_rois) the events behind each centroid (``sum I`` of eq. 19; None =
    equal weights).

    The line is fitted over ``[slip_start_s + edge_trim_s, slip_end_s - edge_trim_s)``;
    velocity and displacement (eqs. 20-21) cover the bins of ``[slip_start_s,
    slip_end_s)``. Never raises for a poor trial: a result whose ``status`` is not ``ok``
    and a message instead.
    """
    t_s = np.asarray(t_s, dtype=np.float64)
    y = np.asarray(centroid_y_px, dtype=np.float64)
    if y.ndim == 1:
        y = y[:, None]
    wts = np.ones_like(y) if weight is None else np.asarray(weight, dtype=np.float64)
    if wts.ndim == 1:
        wts = wts[:, None]
    wts = np.where(np.isfinite(y), wts, 0.0)
    fit_start_s, fit_end_s = slip_start_s + edge_trim_s, slip_end_s - edge_trim_s
    res = SlipRate(trial=trial, slip_start_s=float(slip_start_s), slip_end_s=float(slip_end_s),
                   fit_start_s=float(fit_start_s), fit_end_s=float(fit_end_s),
                   strip_m_per_px=optics.strip_m_per_px)
    in_slip = (t_s >= slip_start_s) & (t_s < slip_end_s)
    in_fit = (t_s >= fit_start_s) & (t_s < fit_end_s)
    yf = y[in_fit]
    res.n_bins = int(in_fit.sum())
    res.n_rois_used = int((np.isfinite(yf).sum(axis=0) >= 2).sum())
    have = int(np.isfinite(yf).any(axis=1).sum())
    if have < MIN_FIT_BINS:
        res.status = "too_few_bins"
        res.message = (f"{have} bins with ROI events in the fit region "
                       f"[{fit_start_s:.3f}, {fit_end_s:.3f}) s; need {MIN_FIT_BINS}")
        return res, None
    try:
        fit = fit_common_slope(t_s[in_fit], yf, wts[in_fit])
    except ValueError as exc:
        res.status = "fit_failed"
        res.message = str(exc)
        return res, None
    # the ROIs' event-weighted average with each ROI's intercept removed: one trajectory
    # for eqs. 20-21, whose bin i has variance sigma_unit^2 / W_i (W_i its events)
    offsets = np.where(np.isfinite(fit.intercepts), fit.intercepts, 0.0)
    w_bin = wts.sum(axis=1)
    aligned = np.full(t_s.shape, np.nan)
    has = w_bin > 0
    aligned[has] = (wts * np.where(wts > 0, y - offsets, 0.0)).sum(axis=1)[has] / w_bin[has]
    ts = t_s[in_slip]
    a_slip = aligned[in_slip]
    good = np.isfinite(a_slip)
    # empty bins inside the region are bridged linearly (the velocity needs every bin), and
    # take the variance of their neighbours the same way
    a_filled = np.interp(ts, ts[good], a_slip[good])
    var_bin = np.interp(ts, ts[good], fit.sigma_unit ** 2 / w_bin[in_slip][good])
    v = centroid_velocity(ts, a_filled)
    d = integrate_displacement(ts, v)
    # eq. 21 is linear in the centroid series, d_end = c . y, so var(d_end) = sum c_i^2 var_i
    c = _end_weights(ts)
    m = optics.strip_m_per_px
    span_s = float(ts[-1] - ts[0])
    res.velocity_px_s = fit.slope
    res.velocity_se_px_s = fit.slope_se
    res.speed_m_s = abs(fit.slope) * m
    res.speed_se_m_s = fit.slope_se * m
    res.displacement_m = abs(float(d[-1])) * m
    res.displacement_se_m = float(np.sqrt((c * c * var_bin).sum())) * m
    res.displacement_fit_m = abs(fit.slope) * span_s * m
    res.displacement_fit_se_m = fit.slope_se * span_s * m
    res.displacement_start_s, res.displacement_end_s = float(ts[0]), float(ts[-1])
    res.r2 = fit.r2
    res.residual_std_px = fit.residual_std
    velocity = np.full(t_s.shape, np.nan)
    displacement = np.full(t_s.shape, np.nan)
    fitted = np.full(t_s.shape, np.nan)
    velocity[in_slip] = v
    displacement[in_slip] = d
    fitted[in_fit] = fit.slope * t_s[in_fit]
    trace = SlipTrace(t_s, y, fit.intercepts, aligned, velocity, displacement, fitted, in_slip,
                      in_fit, ())
    return res, trace


@dataclass(frozen=True)
class SlipRateEstimate:
    """One trial's result and, when it could be computed, the curves behind it."""

    result: SlipRate
    trace: SlipTrace | None


def resolve_optics(config: SpatialConfig | None, sensor_optics: dict[str, float], *,
                   path: str | Path) -> StripOptics:
    """The config's optics, else the sensor's ``pixel_pitch_m``, ``focal_length_m`` and
    ``strip_distance_m`` attributes; InputError naming what is missing otherwise."""
    if config is not None and config.optics is not None:
        return config.optics
    keys = ("pixel_pitch_m", "focal_length_m", "strip_distance_m")
    missing = [k for k in keys if k not in sensor_optics]
    if missing:
        raise InputError(f"no optics to convert px to m: the sensor lacks {', '.join(missing)} "
                         "and no config gave them; pass `config=CONFIG` with an `optics:` "
                         "section (pixel_pitch_m, focal_length_m, strip_distance_m)", path=path)
    return StripOptics(*(sensor_optics[k] for k in keys))


def _slip_region(trial: Trial) -> tuple[tuple[float, float] | None, str]:
    span = trial.annotation("slip")
    if span is not None:
        return (span.start_s, span.end_s), "annotations"
    lab = trial.labels
    if "slip_start_s" in lab and "release_start_s" in lab:
        try:
            return (float(lab["slip_start_s"]), float(lab["release_start_s"])), "labels"
        except (TypeError, ValueError):
            pass
    return None, ""


def _truth(labels: dict[str, Any]) -> float | None:
    value = labels.get("slip_speed_m_s")
    if value is None or value == "":
        return None
    try:
        v = float(value)
    except (TypeError, ValueError):
        return None
    return v if np.isfinite(v) else None


def estimate_slip_rate(
    trial: Trial,
    config: SpatialConfig | None = None,
) -> SlipRateEstimate:
    """Eqs. 19-21 and the Fig. 23 slope for one trial of a tactile HDF5 file.

    ROIs and optics come from ``config``; without one (or one without optics) the optics
    come from the sensor's attributes, and without ROIs they are proposed from the
    positive-event density of the trial's slip region, which covers the strips' whole path
    (:func:`~.roi.propose_rois`, padded by 10 px). Input errors (trial without events, ROI
    off the sensor, no optics) raise :class:`InputError`; a trial whose slip cannot be
    measured returns a result whose ``status`` says why.
    """
    te = spatial_events(trial)
    if config is not None:
        config.check_sensor(te.sensor.width_px, te.sensor.height_px)
    optics = resolve_optics(config, te.sensor.optics, path=trial.path)
    span, source = _slip_region(trial)
    truth = _truth(trial.labels)
    opts = config.centroid if config is not None else CentroidOptions()
    polarity, median, bin_s = opts.polarity, opts.median, opts.bin_s
    edge_trim_s = config.slip.edge_trim_s if config is not None else SlipOptions().edge_trim_s
    res = SlipRate(trial=trial.name, strip_m_per_px=optics.strip_m_per_px,
                   truth_speed_m_s=truth)
    if span is None:
        res.status = "no_slip_region"
        res.message = ("the trial has no `slip` annotation and no slip_start_s/"
                       "release_start_s labels")
        return SlipRateEstimate(res, None)
    if config is None or not config.rois:
        density = event_density(trial, regions=("slip",), polarity=polarity)
        rois: Sequence[Roi] = propose_rois(density, pad_px=(10, 10),
                                           min_fraction=SLIP_ROI_MIN_FRACTION)
        if not rois:
            res.status = "no_rois"
            res.message = "no dense event region to propose ROIs from; give the ROIs with `config`"
            return SlipRateEstimate(res, None)
    else:
        rois = config.rois
    background = None
    note = ""
    if opts.subtract_background:
        background = background_rate(trial, region="approach", polarity=polarity)
        if background is None:
            note = "no approach annotation: background not subtracted"
    # centroids only where they are used: the slip region plus a margin for the plot
    margin = max(0.5, 0.25 * (span[1] - span[0]))
    c = trial_roi_centroids(trial, rois, bin_s=bin_s, polarity=polarity, median=median,
                            start_s=max(0.0, span[0] - margin), end_s=span[1] + margin,
                            background_px_hz=background or 0.0)
    out, trace = slip_rate_from_centroids(c.t_s, c.centroid_px[..., 1], c.weight,
                                          slip_start_s=span[0],
                                          slip_end_s=span[1], edge_trim_s=edge_trim_s,
                                          optics=optics, trial=trial.name)
    out.region_source = source
    out.truth_speed_m_s = truth
    out.background_px_hz = background
    if note and out.status == "ok":
        out.message = note
    out.rois = [r.as_dict() for r in rois]
    if truth is not None and truth > 0 and out.status == "ok":
        out.speed_rel_error = out.speed_m_s / truth - 1.0
    if trace is not None:
        trace = replace(trace, rois=tuple(rois))
    return SlipRateEstimate(out, trace)


def estimate_slip_rates(
    path: str | Path,
    config: SpatialConfig | None = None,
    *,
    trials: Sequence[str] | None = None,
) -> list[SlipRateEstimate]:
    """:func:`estimate_slip_rate` for every trial with events (or the ones named), the
    file opened once."""
    with TactileFile(path) as tf:
        known = event_trial_names(tf)
        names = known if not trials else list(trials)
        for name in names:
            if name not in known:
                raise InputError(f"no trial {name!r} with events; see `tactile info {path}`",
                                 path=path)
        chosen = [tf.trial(name) for name in names]  # as named, repeats included
        for trial in chosen:  # every trial's input checked before the first is measured
            te = spatial_events(trial)
            if config is not None:
                config.check_sensor(te.sensor.width_px, te.sensor.height_px)
            resolve_optics(config, te.sensor.optics, path=path)
        return [estimate_slip_rate(trial, config) for trial in chosen]
