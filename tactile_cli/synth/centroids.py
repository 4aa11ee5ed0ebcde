"""Model-based ROI centroid trajectories (paper 000, sec. 5.2, eqs. 15, 18-19).

Sec. 5.2 trains the spatial-temporal LSTM on "model-based experimental trials" of the
event-weighted ROI centroid. This module generates them from a synthetic trial's event-count
model (:mod:`tactile_cli.synth.trajectories`) and a description of the sensor (ROIs and
optics from an ROI config, ``configs/rois_marker_scene.yaml`` or a scene's ``scene.json``),
without simulating single events. Per trial, ROI and 20 ms bin:

1. **How many events.** The expected positive signal events of the bin follow the trial's
   expected net count ``mu`` as in the synth noise model,
   ``s = (1 + beta) max(mu, 0) + beta max(-mu, 0)`` (the strips open: positive events);
   a share ``roi_fraction`` of them lands in the ROIs, split evenly. Of an ROI's share,
   the fraction of the strip band that lies inside the ROI counts (a band pushed past the
   ROI's edge loses events). Background events of the positive polarity fall on the ROI in
   proportion to its area (the trial's ``background_per_bin`` over the whole sensor). Both
   counts are Poisson.
2. **Where the strip is** (the band centre, y): at rest ``rest_inset_px`` inside the ROI
   edge the slip moves away from, through approach and press; during the slip it moves at
   the trial's slip speed (m/s, drawn from ``speeds_m_s``, converted to px/s by eq. 15,
   :class:`~tactile_cli.spatial.optics.StripOptics`); after the release it returns to rest
   exponentially with the trial's press time constant ``tau_press_s`` (the markers spring
   back as they were pressed). The position of a bin is the band's mean position over the
   bin (:data:`SUBSAMPLES` instants), as a bin of events averages it: the bin that
   straddles the slip's start or the release already shows part of the turn. x: the band
   spans the ROI's width.
3. **The centroid** (eq. 19 with ``I`` = events per pixel): the strip events are uniform over
   the part of the band inside the ROI, the background events uniform over the ROI, all at
   whole pixels (:func:`floored_uniform_moments`: a wide band centred at ``c`` has its
   events' mean at ``c - 0.5``). The background events are drawn one by one (there are
   few: about 0.7 per bin and ROI for the paper's sensor); the strip events' sum of
   positions is drawn as a normal with the exact mean and variance of the sum of ``n``
   floored uniforms (about ``n L^2 / 12`` for a band of ``L`` px), so the centroid's noise
   shrinks as ``1 / sqrt(n)`` with the events of the bin. A bin with no event in an ROI
   has no centroid: NaN, with weight 0 (the stream fills it,
   :func:`tactile_cli.spatial.stream.centroid_features`).

What the model leaves out (so the scene, which simulates events, is a different generator):
marker events that might stray into an ROI, any band shape but a uniform one, polarity
noise other than Poisson, and the widening of the band by its motion within a bin.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..spatial.optics import StripOptics
from ..spatial.roi import Roi
from .config import CentroidsConfig

#: Instants per bin over which the band's position is averaged.
SUBSAMPLES = 8


@dataclass(frozen=True)
class CentroidModel:
    """The sensor and model behind the centroid trajectories of every trial.

    rois: the ROIs (eq. 18) in channel order; optics: px <-> m (eq. 15); width_px,
    height_px: the sensor grid (for the background's share per ROI); config: the drawn
    ranges; opposite_fraction: beta of the synth noise model.
    """

    rois: tuple[Roi, ...]
    optics: StripOptics
    width_px: int
    height_px: int
    config: CentroidsConfig
    opposite_fraction: float

    def __post_init__(self) -> None:
        if not self.rois:
            raise ValueError("`rois` must hold at least one ROI")

    def as_dict(self) -> dict[str, Any]:
        return {"rois": [r.as_dict() for r in self.rois], "optics": self.optics.as_dict(),
                "width_px": self.width_px, "height_px": self.height_px,
                "config": self.config.model_dump(mode="json"),
                "opposite_fraction": self.opposite_fraction}


@dataclass(frozen=True)
class CentroidTrajectory:
    """The centroid trajectories of one synthetic trial.

    centroid_px: (n_bins, n_rois, 2) float64 ``[x_bar, y_bar]`` px, NaN where the ROI had no
    event; weight: (n_bins, n_rois) float64 events in the ROI per bin (``sum I``);
    band_y_px: (n_bins, n_rois) the strip band's centre (the noise-free truth, px);
    slip_speed_m_s, slip_speed_px_s: the drawn speed (positive; the direction is
    ``direction_y``); rest_y_px: (n_rois,) band centre at rest; band_height_px and
    roi_fraction: the drawn values.
    """

    centroid_px: np.ndarray
    weight: np.ndarray
    band_y_px: np.ndarray
    slip_speed_m_s: float
    slip_speed_px_s: float
    direction_y: int
    rest_y_px: np.ndarray
    band_height_px: float
    roi_fraction: float

    def label_attrs(self) -> dict[str, float | int]:
        """Trial labels (the names of the scene's trials.csv where they mean the same)."""
        return {"slip_speed_m_s": self.slip_speed_m_s,
                "slip_speed_px_s": self.slip_speed_px_s,
                "slip_direction_y": self.direction_y,
                "band_height_px": self.band_height_px, "roi_fraction": self.roi_fraction}


def _uniform(rng: np.random.Generator, bounds: tuple[float, float]) -> float:
    low, high = bounds
    return float(low if low == high else rng.uniform(low, high))


def band_offset_px(t_s: np.ndarray, *, slip_start_s: float, release_start_s: float,
                   velocity_px_s: float, tau_return_s: float) -> np.ndarray:
    """(n,) displacement of the strip band from rest at times ``t_s``, px: 0 before the
    slip, ``velocity * (t - slip_start)`` during it, then ``exp(-(t - release) / tau)`` of
    the displacement reached, after the release."""
    t = np.asarray(t_s, dtype=np.float64)
    moved = velocity_px_s * np.clip(t - slip_start_s, 0.0, release_start_s - slip_start_s)
    return moved * np.exp(-np.maximum(t - release_start_s, 0.0) / tau_return_s)


def floored_uniform_moments(lo: np.ndarray, hi: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Mean and variance of ``floor(U)`` for ``U`` uniform on ``[lo, hi)`` (an event's whole
    pixel), elementwise; ``lo`` where ``hi <= lo`` (an empty band: mean ``floor(lo)``,
    variance 0). About ``(lo + hi) / 2 - 0.5`` and ``(hi - lo)^2 / 12`` for a wide band."""
    lo = np.asarray(lo, dtype=np.float64)
    base = np.floor(lo)  # measured from the first pixel: keeps the integrals small
    hi = np.maximum(np.asarray(hi, dtype=np.float64), lo) - base
    lo = lo - base

    def first(x: np.ndarray) -> np.ndarray:  # integral of floor(u) from 0 to x
        f = np.floor(x)
        return f * (f - 1) / 2 + f * (x - f)

    def second(x: np.ndarray) -> np.ndarray:  # integral of floor(u)^2 from 0 to x
        f = np.floor(x)
        return (f - 1) * f * (2 * f - 1) / 6 + f**2 * (x - f)

    span = hi - lo
    wide = span > 1e-9
    safe = np.where(wide, span, 1.0)
    mean = np.where(wide, (first(hi) - first(lo)) / safe, 0.0)
    square = np.where(wide, (second(hi) - second(lo)) / safe, 0.0)
    return base + mean, np.maximum(square - mean**2, 0.0)


def rest_y_px(rois: Sequence[Roi], inset_px: np.ndarray, direction_y: int) -> np.ndarray:
    """(n_rois,) band centre at rest: ``inset_px`` inside the edge the slip moves away
    from (the bottom edge ``y1`` when the strips move to smaller y)."""
    edge = np.array([r.y1_px if direction_y < 0 else r.y0_px for r in rois], dtype=np.float64)
    return edge + direction_y * np.asarray(inset_px, dtype=np.float64)


def draw_centroids(
    t_s: np.ndarray,
    expected_net: np.ndarray,
    *,
    bin_s: float,
    slip_start_s: float,
    release_start_s: float,
    tau_press_s: float,
    background_per_bin: float,
    model: CentroidModel,
    rng: np.random.Generator,
) -> CentroidTrajectory:
    """Centroid trajectories of one trial (see the module doc).

    t_s: (n_bins,) bin centres, s; bin_s: the bin width, s; expected_net: (n_bins,)
    expected net events per bin (the synth trial's ``expected``); background_per_bin:
    background events per bin and polarity over the whole sensor. Draws the per-trial
    values, then the counts and positions, from ``rng`` (advances it).
    """
    cfg, rois = model.config, model.rois
    n_rois = len(rois)
    t = np.asarray(t_s, dtype=np.float64)
    mu = np.asarray(expected_net, dtype=np.float64)
    if mu.shape != t.shape:
        raise ValueError(f"`expected_net` {mu.shape} must match `t_s` {t.shape}")
    n_bins = t.shape[0]
    speed_m_s = _uniform(rng, cfg.speeds_m_s)
    speed_px_s = float(model.optics.m_to_px(speed_m_s))
    band_h = _uniform(rng, cfg.band_height_px)
    fraction = _uniform(rng, cfg.roi_fraction)
    lo_in, hi_in = cfg.rest_inset_px
    inset = np.full(n_rois, lo_in) if lo_in == hi_in else rng.uniform(lo_in, hi_in, n_rois)
    rest = rest_y_px(rois, inset, cfg.direction_y)

    within = ((np.arange(SUBSAMPLES) + 0.5) / SUBSAMPLES - 0.5) * bin_s
    offset = band_offset_px(t[:, None] + within[None, :], slip_start_s=slip_start_s,
                            release_start_s=release_start_s,
                            velocity_px_s=cfg.direction_y * speed_px_s,
                            tau_return_s=tau_press_s).mean(axis=1)
    band_y = rest[None, :] + offset[:, None]  # (n_bins, n_rois)
    y0 = np.array([r.y0_px for r in rois], dtype=np.float64)
    y1 = np.array([r.y1_px for r in rois], dtype=np.float64)
    lo = np.maximum(band_y - band_h / 2, y0)
    hi = np.minimum(band_y + band_h / 2, y1)
    inside = np.clip(hi - lo, 0.0, None)  # px of the band within the ROI

    beta = model.opposite_fraction
    signal = (1 + beta) * np.maximum(mu, 0.0) + beta * np.maximum(-mu, 0.0)
    strip_rate = fraction * signal[:, None] / n_rois * (inside / band_h)
    n_strip = rng.poisson(strip_rate).astype(np.float64)  # (n_bins, n_rois)

    # strip events: uniform over [lo, hi) of y and over the ROI's columns of x, floored
    centre_x = np.array([r.centre_px[0] for r in rois], dtype=np.float64)
    width = np.array([r.width_px for r in rois], dtype=np.float64)
    mean_y, var_y = floored_uniform_moments(lo, hi)
    var_x = (width**2 - 1) / 12
    z = rng.standard_normal((n_bins, n_rois, 2))
    sum_x = n_strip * centre_x + np.sqrt(n_strip * var_x) * z[..., 0]
    sum_y = n_strip * mean_y + np.sqrt(n_strip * var_y) * z[..., 1]

    # background events: few, drawn one by one over each ROI's pixels
    area = np.array([r.width_px * r.height_px for r in rois], dtype=np.float64)
    bg_rate = background_per_bin * area / (model.width_px * model.height_px)
    n_bg = rng.poisson(np.broadcast_to(bg_rate, (n_bins, n_rois)))
    cell = np.repeat(np.arange(n_bins * n_rois), n_bg.ravel())
    roi_of = cell % n_rois
    lo_x = np.array([r.x0_px for r in rois])[roi_of]
    lo_y = np.array([r.y0_px for r in rois])[roi_of]
    bx = lo_x + rng.integers(0, np.array([r.width_px for r in rois])[roi_of])
    by = lo_y + rng.integers(0, np.array([r.height_px for r in rois])[roi_of])
    size = n_bins * n_rois
    sum_x += np.bincount(cell, weights=bx, minlength=size).reshape(n_bins, n_rois)
    sum_y += np.bincount(cell, weights=by, minlength=size).reshape(n_bins, n_rois)

    weight = n_strip + n_bg
    with np.errstate(invalid="ignore", divide="ignore"):
        centroid = np.stack([sum_x / weight, sum_y / weight], axis=-1)
    centroid[weight == 0] = np.nan
    return CentroidTrajectory(
        centroid_px=centroid, weight=weight, band_y_px=band_y, slip_speed_m_s=speed_m_s,
        slip_speed_px_s=speed_px_s, direction_y=cfg.direction_y, rest_y_px=rest,
        band_height_px=band_h, roi_fraction=fraction)


__all__ = ["SUBSAMPLES", "CentroidModel", "CentroidTrajectory", "band_offset_px",
           "draw_centroids", "floored_uniform_moments", "rest_y_px"]
