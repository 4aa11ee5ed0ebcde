"""Regions of interest and their event-weighted centroids (paper 000, sec. 5.2, eqs. 18-19).

- :class:`Roi`: a rectangle on the sensor grid (eq. 18, the set of pixels between its
  corners), half-open in px: ``x0_px <= x < x1_px``, ``y0_px <= y < y1_px``.
- :func:`propose_rois`: rectangles around the dense blobs of an event-density image, so a
  new sensor's strips can be found from one press instead of by hand.
- :func:`roi_centroids`: eq. 19, ``x_bar = sum x I(x, y) / sum I(x, y)`` (and ``y_bar``)
  per ROI per time bin, with ``I`` the events of the chosen polarity per pixel in the bin,
  after an optional median filter ("after performing data filtering"). Vectorised: one
  ``np.bincount`` per ROI over all bins (a loop over the few ROIs, none over events).
- :func:`trial_roi_centroids` / :func:`roi_centroid_series`: the same for one trial of a
  tactile HDF5 file (a :class:`~tactile_cli.store.trials.Trial`), read a block of bins at a
  time through the millisecond index.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Literal

import numpy as np
from scipy import ndimage

from ..errors import InputError
from ..store.trials import Trial
from ..vocabulary import BIN_S
from .frames import median_filter_frames
from .trial_events import spatial_events

Polarity = Literal["positive", "negative", "both"]
POLARITIES: tuple[str, ...] = ("positive", "negative", "both")
#: Bins read per block when a trial's centroids are computed.
CHUNK_BINS = 50


@dataclass(frozen=True)
class Roi:
    """A rectangular region of interest on the sensor grid, half-open, in px:
    ``x0_px <= x < x1_px``, ``y0_px <= y < y1_px``. The one ROI of the toolkit: the scene's
    strip ROIs (:mod:`tactile_cli.scene.layout`), the configs' (whose YAML keys are ``x0``,
    ``y0``, ``x1``, ``y1``) and the proposed ones."""

    name: str
    x0_px: int
    y0_px: int
    x1_px: int
    y1_px: int

    def __post_init__(self) -> None:
        for key in ("x0_px", "y0_px", "x1_px", "y1_px"):
            value = getattr(self, key)
            if isinstance(value, bool) or not isinstance(value, int | np.integer):
                raise ValueError(f"ROI {self.name!r}: `{key}` (={value!r}) must be a whole "
                                 "number of px")
        if self.x1_px <= self.x0_px or self.y1_px <= self.y0_px:
            raise ValueError(f"ROI {self.name!r}: needs x0 < x1 and y0 < y1 (got x "
                             f"{self.x0_px}.."
                             f"{self.x1_px}, y {self.y0_px}..{self.y1_px})")

    @property
    def width_px(self) -> int:
        return self.x1_px - self.x0_px

    @property
    def height_px(self) -> int:
        return self.y1_px - self.y0_px

    @property
    def centre_px(self) -> tuple[float, float]:
        """Pixel-centre coordinates of the rectangle's middle, (x, y)."""
        return (self.x0_px + self.x1_px - 1) / 2, (self.y0_px + self.y1_px - 1) / 2

    def contains(self, x: np.ndarray, y: np.ndarray) -> np.ndarray:
        """(n,) bool: which of the pixels (x, y) lie inside."""
        return (x >= self.x0_px) & (x < self.x1_px) & (y >= self.y0_px) & (y < self.y1_px)

    def as_dict(self) -> dict[str, int | str]:
        return {"name": self.name, "x0_px": int(self.x0_px), "y0_px": int(self.y0_px),
                "x1_px": int(self.x1_px), "y1_px": int(self.y1_px)}

    def __str__(self) -> str:
        return f"{self.name} (x {self.x0_px}..{self.x1_px}, y {self.y0_px}..{self.y1_px})"


def check_rois_on_sensor(rois: Sequence[Roi], width_px: int, height_px: int, *,
                         source: str | Path | None = None) -> None:
    """Raise :class:`InputError` when an ROI is not wholly on the ``width_px`` x
    ``height_px`` grid, or when there is none or two share a name."""
    if not rois:
        raise InputError("no ROIs given; list them under `rois:` (name, x0_px, y0_px, x1_px, "
                         "y1_px)", path=source)
    names = [r.name for r in rois]
    dup = sorted({n for n in names if names.count(n) > 1})
    if dup:
        raise InputError(f"ROI names must be unique; repeated: {', '.join(dup)}", path=source)
    for r in rois:
        if r.x0_px < 0 or r.y0_px < 0 or r.x1_px > width_px or r.y1_px > height_px:
            raise InputError(f"ROI {r} lies outside the {width_px}x{height_px} px sensor; "
                             f"keep 0 <= x0 < x1 <= {width_px} and 0 <= y0 < y1 <= {height_px}",
                             path=source)


def _polarity_mask(p: np.ndarray, polarity: str) -> np.ndarray:
    if polarity == "positive":
        return p > 0
    if polarity == "negative":
        return p < 0
    if polarity == "both":
        return np.ones(p.shape, dtype=bool)
    raise ValueError(f"`polarity` (={polarity!r}) must be one of {', '.join(POLARITIES)}")


def _roi_sums(
    x: np.ndarray, y: np.ndarray, k: np.ndarray, roi: Roi, n_bins: int, median: int,
    width_px: int, height_px: int,
) -> np.ndarray:
    """(n_bins, 3) float64 ``sum I, sum x I, sum y I`` of one ROI; ``k`` the bin of each
    event (all in ``[0, n_bins)``), events already of the chosen polarity."""
    if median == 1:
        inside = roi.contains(x, y)
        kk = k[inside]
        return np.stack([
            np.bincount(kk, minlength=n_bins).astype(np.float64),
            np.bincount(kk, weights=x[inside].astype(np.float64), minlength=n_bins),
            np.bincount(kk, weights=y[inside].astype(np.float64), minlength=n_bins),
        ], axis=1)
    # the filter needs the pixels around the ROI: crop with a margin, filter, trim back
    m = median // 2
    cx0, cy0 = max(0, roi.x0_px - m), max(0, roi.y0_px - m)
    cx1, cy1 = min(width_px, roi.x1_px + m), min(height_px, roi.y1_px + m)
    w, h = cx1 - cx0, cy1 - cy0
    inside = (x >= cx0) & (x < cx1) & (y >= cy0) & (y < cy1)
    code = (k[inside] * h + (y[inside] - cy0)) * w + (x[inside] - cx0)
    crop = np.bincount(code, minlength=n_bins * h * w).reshape(n_bins, h, w)
    crop = median_filter_frames(crop.astype(np.int32), median)
    sub = crop[:, roi.y0_px - cy0: roi.y1_px - cy0,
               roi.x0_px - cx0: roi.x1_px - cx0].astype(np.float64)
    xs = np.arange(roi.x0_px, roi.x1_px, dtype=np.float64)
    ys = np.arange(roi.y0_px, roi.y1_px, dtype=np.float64)
    return np.stack([sub.sum(axis=(1, 2)), sub.sum(axis=1) @ xs, sub.sum(axis=2) @ ys], axis=1)


def roi_weight_sums(
    x: np.ndarray,
    y: np.ndarray,
    t_us: np.ndarray,
    p: np.ndarray,
    rois: Sequence[Roi],
    *,
    start_us: int,
    bin_us: int,
    n_bins: int,
    polarity: str = "positive",
    median: int = 1,
    width_px: int,
    height_px: int,
) -> np.ndarray:
    """(n_bins, n_rois, 3) float64 ``[sum I, sum x I, sum y I]`` of eq. 19 per bin and ROI.

    x, y: (n,) px; t_us: (n,) integer microseconds; p: (n,) -1/+1. Bin ``k`` holds the
    events with ``start_us + k*bin_us <= t_us < start_us + (k+1)*bin_us``; ``I`` is the
    count of events of ``polarity`` per pixel in the bin, median-filtered over
    ``median`` x ``median`` px when ``median > 1``. Sums add across blocks of events.
    """
    x = np.asarray(x, dtype=np.int64)
    y = np.asarray(y, dtype=np.int64)
    t_us = np.asarray(t_us, dtype=np.int64)
    keep = _polarity_mask(np.asarray(p), polarity)
    k = (t_us - start_us) // bin_us
    keep &= (k >= 0) & (k < n_bins)
    x, y, k = x[keep], y[keep], k[keep]
    out = np.zeros((n_bins, len(rois), 3), dtype=np.float64)
    for j, roi in enumerate(rois):  # a handful of ROIs; each is one vectorised pass
        out[:, j] = _roi_sums(x, y, k, roi, n_bins, median, width_px, height_px)
    return out


def centroids_from_sums(sums: np.ndarray) -> np.ndarray:
    """(..., 3) ``[sum I, sum x I, sum y I]`` -> (..., 2) ``[x_bar, y_bar]`` (eq. 19), NaN
    where ``sum I`` is 0 (no events: the centroid is undefined, not the ROI's corner)."""
    w = sums[..., :1]
    with np.errstate(invalid="ignore", divide="ignore"):
        c = sums[..., 1:] / w
    c[np.broadcast_to(w <= 0, c.shape)] = np.nan
    return c


@dataclass(frozen=True)
class RoiCentroids:
    """Event-weighted centroids of each ROI per time bin of one trial.

    t_s: (n_bins,) bin centres, seconds from the trial's time origin.
    centroid_px: (n_bins, n_rois, 2) float64 ``[x_bar, y_bar]`` in px, NaN in empty bins.
    weight: (n_bins, n_rois) float64 ``sum I`` (events after filtering) per bin and ROI.
    rois: the ROIs, in column order. bin_s: bin width (s). polarity, median: as computed.
    """

    t_s: np.ndarray
    centroid_px: np.ndarray
    weight: np.ndarray
    rois: tuple[Roi, ...]
    bin_s: float
    polarity: str
    median: int


def trial_roi_centroids(
    trial: Trial,
    rois: Sequence[Roi],
    *,
    bin_s: float = BIN_S,
    polarity: str = "positive",
    median: int = 1,
    start_s: float = 0.0,
    end_s: float | None = None,
    background_px_hz: float = 0.0,
    chunk_bins: int = CHUNK_BINS,
) -> RoiCentroids:
    """Eq. 19 per ROI per bin of ``bin_s`` over ``[start_s, end_s)`` of one trial.

    ``end_s`` defaults to the trial's end. ``background_px_hz`` (events of ``polarity`` per
    pixel per second, e.g. from :func:`background_rate`) is subtracted from every pixel
    of every bin before the centroid is taken (:func:`subtract_background`); it needs
    ``median == 1``. Raises :class:`InputError` for a trial without events or an ROI off
    the sensor.
    """
    if background_px_hz and median != 1:
        raise ValueError("`background_px_hz` applies to unfiltered counts only (median == 1); "
                         "the median filter already removes isolated background events")
    bin_us = round(bin_s * 1e6)
    if bin_us < 1 or abs(bin_us - bin_s * 1e6) > 1e-6 * bin_s * 1e6:
        raise ValueError(f"`bin_s` (={bin_s}) must be a positive whole number of microseconds")
    rois = tuple(rois)
    te = spatial_events(trial)
    width_px, height_px = te.sensor.width_px, te.sensor.height_px
    check_rois_on_sensor(rois, width_px, height_px)
    stop_s = te.end_s if end_s is None else end_s
    start_us = te.to_us(start_s)
    n_bins = max(0, -(-(te.to_us(stop_s) - start_us) // bin_us))
    sums = np.zeros((n_bins, len(rois), 3), dtype=np.float64)
    for first in range(0, n_bins, chunk_bins):
        n = min(chunk_bins, n_bins - first)
        t0 = start_us + first * bin_us
        ev = te.window_us(t0, t0 + n * bin_us)
        sums[first:first + n] = roi_weight_sums(
            ev.x, ev.y, ev.t_us, ev.p, rois, start_us=t0, bin_us=bin_us, n_bins=n,
            polarity=polarity, median=median, width_px=width_px, height_px=height_px,
        )
    if background_px_hz:
        sums = subtract_background(sums, rois, background_px_hz * bin_us * 1e-6)
    t_s = start_s + (np.arange(n_bins) + 0.5) * bin_us * 1e-6
    centroid, weight = drop_outside(centroids_from_sums(sums), sums[..., 0], rois)
    return RoiCentroids(t_s, centroid, weight, rois, bin_us * 1e-6, polarity, median)


def drop_outside(centroid: np.ndarray, weight: np.ndarray, rois: Sequence[Roi]
                 ) -> tuple[np.ndarray, np.ndarray]:
    """(n_bins, n_rois, 2) centroids and (n_bins, n_rois) weights with every centroid that
    lies outside its ROI made NaN and its weight 0 (new arrays). Events inside an ROI cannot
    have their centroid outside it; after a background subtraction a bin whose remainder
    is mostly noise can, and then it is no centroid."""
    lo = np.array([[r.x0_px, r.y0_px] for r in rois], dtype=np.float64)
    hi = np.array([[r.x1_px - 1, r.y1_px - 1] for r in rois], dtype=np.float64)
    with np.errstate(invalid="ignore"):
        outside = ((centroid < lo) | (centroid > hi)).any(axis=-1)
    centroid = np.where(outside[..., None], np.nan, centroid)
    return centroid, np.where(outside, 0.0, weight)


#: A bin keeps its centroid after background subtraction only when the events left exceed
#: this many standard deviations of the background count expected in the ROI.
MIN_BACKGROUND_SNR = 2.0


def subtract_background(sums: np.ndarray, rois: Sequence[Roi], per_px: float) -> np.ndarray:
    """Remove a uniform background of ``per_px`` events per pixel per bin from (n_bins,
    n_rois, 3) eq. 19 sums: ``sum I -= per_px * area``, ``sum x I -= per_px * sum_ROI x``,
    ``sum y I -= per_px * sum_ROI y``. Uniform background events pull a centroid towards
    the ROI's middle, most where the signal is sparse; after the subtraction the centroid
    is unbiased for such a background. Bins whose remainder ``sum I`` is not above the
    background's own counting noise (:data:`MIN_BACKGROUND_SNR` Poisson standard
    deviations of the ``per_px * area`` events expected) get weight 0: their centroid
    becomes NaN instead of the ratio of two noise terms, which lands anywhere (an ROI with
    1.3 background events per bin and 0.05 events left gave centroids 40,000 px away)."""
    expected = np.array([[r.width_px * r.height_px,
                          r.height_px * (r.x0_px + r.x1_px - 1) * r.width_px / 2,
                          r.width_px * (r.y0_px + r.y1_px - 1) * r.height_px / 2] for r in rois],
                        dtype=np.float64).reshape(len(rois), 3)
    out = sums - per_px * expected[None]
    noise = np.sqrt(per_px * expected[:, 0])  # (n_rois,) Poisson sd of the ROI's background
    out[out[..., 0] <= np.maximum(MIN_BACKGROUND_SNR * noise, 0.0)[None]] = 0.0
    return out


def background_rate(trial: Trial, *, region: str = "approach",
                    polarity: str = "positive") -> float | None:
    """Events of ``polarity`` per pixel per second over the whole sensor during the trial's
    annotated ``region`` (the approach, before contact: background only), or None when the
    trial has no such annotation or it is empty. Assumes the background is uniform over
    the sensor."""
    te = spatial_events(trial)
    span = trial.annotation(region)
    if span is None or span.end_s <= span.start_s:
        return None
    ev = te.window(span.start_s, span.end_s)
    n = int(_polarity_mask(ev.p, polarity).sum())
    return n / (te.sensor.width_px * te.sensor.height_px * (span.end_s - span.start_s))


def roi_centroid_series(
    trial: Trial, rois: Sequence[Roi], bin_s: float = BIN_S, *,
    polarity: str = "positive", median: int = 1,
) -> tuple[np.ndarray, np.ndarray]:
    """Centroid trajectories of one trial as model features.

    Returns ``(t_s, centroid_px)``: (n_bins,) bin centres in trial seconds and
    (n_bins, n_rois, 2) float64 ``[x_bar, y_bar]`` px per ROI (eq. 19), NaN in bins where
    an ROI has no events of ``polarity``.
    """
    c = trial_roi_centroids(trial, rois, bin_s=bin_s, polarity=polarity, median=median)
    return c.t_s, c.centroid_px


# -- proposing ROIs -----------------------------------------------------------------------
def propose_rois(
    density: np.ndarray,
    *,
    n_rois: int | None = None,
    smooth_px: int = 5,
    false_alarm: float = 1e-6,
    min_fraction: float = 0.05,
    min_area_px: int = 20,
    pad_px: tuple[int, int] = (0, 0),
    prefix: str = "roi",
) -> list[Roi]:
    """Rectangles around the dense blobs of an event-density image.

    density: (height_px, width_px) events per pixel (e.g. the positive events of a press).
    Events are counted in a ``smooth_px`` x ``smooth_px`` box around every pixel; the
    background count per box is the median over the image (uniform noise dominates most of
    the grid), and a box is part of a blob when its count is one a Poisson background would
    reach with probability below ``false_alarm`` and at least ``min_fraction`` of the
    densest box's count. Each connected blob of at least ``min_area_px`` px becomes the
    bounding rectangle of its pixels, grown by ``pad_px = (pad_x, pad_y)`` and clipped to
    the grid. The ``n_rois`` blobs holding the most events are kept (all when None), named
    ``{prefix}_1..`` from left to right (then top to bottom).
    """
    from scipy.stats import poisson

    density = np.asarray(density, dtype=np.float64)
    if density.ndim != 2:
        raise ValueError(f"`density` must be (height_px, width_px), got shape {density.shape}")
    if not 0 < false_alarm < 1 or not 0 <= min_fraction < 1:
        raise ValueError(f"`false_alarm` (={false_alarm}) must lie in (0, 1) and "
                         f"`min_fraction` (={min_fraction}) in [0, 1)")
    height_px, width_px = density.shape
    box = ndimage.uniform_filter(density, size=smooth_px, mode="constant") * smooth_px ** 2
    background = max(float(np.median(box)), 1e-3)
    peak = float(box.max())
    level = max(float(poisson.isf(false_alarm, background)), min_fraction * peak)
    labels, n = ndimage.label(box > level)
    if n == 0:
        return []
    index = np.arange(1, n + 1)
    area = ndimage.sum_labels(np.ones_like(density), labels, index)
    events = ndimage.sum_labels(density, labels, index)
    slices = ndimage.find_objects(labels)
    order = [i for i in np.argsort(-events, kind="stable") if area[i] >= min_area_px]
    if n_rois is not None:
        order = order[:n_rois]
    boxes = []
    for i in order:
        sy, sx = slices[i]
        boxes.append((max(0, sy.start - pad_px[1]), max(0, sx.start - pad_px[0]),
                      min(height_px, sy.stop + pad_px[1]), min(width_px, sx.stop + pad_px[0])))
    boxes.sort(key=lambda b: (b[1], b[0]))
    return [Roi(f"{prefix}_{i + 1}", int(x0), int(y0), int(x1), int(y1))
            for i, (y0, x0, y1, x1) in enumerate(boxes)]


def event_density(
    trial: Trial, *, regions: Sequence[str] = ("press",), polarity: str = "positive",
) -> np.ndarray:
    """(height_px, width_px) int64 events of ``polarity`` per pixel over the trial's
    annotated ``regions`` (the press by default); InputError when the trial lacks one."""
    te = spatial_events(trial)
    w, h = te.sensor.width_px, te.sensor.height_px
    density = np.zeros(h * w, dtype=np.int64)
    for region in regions:
        span = trial.annotation(region)
        if span is None:
            raise InputError(f"trial has no {region!r} annotation to propose ROIs from; "
                             "give the ROIs with `config`", path=trial.path, where=trial.where)
        t = span.start_s
        while t < span.end_s:  # one-second blocks keep memory bounded on long regions
            ev = te.window(t, min(t + 1.0, span.end_s))
            keep = _polarity_mask(ev.p, polarity)
            density += np.bincount(ev.y[keep] * w + ev.x[keep], minlength=h * w)
            t += 1.0
    return density.reshape(h, w)
