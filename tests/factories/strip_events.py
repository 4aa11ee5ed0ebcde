"""Marker-strip events with a known slip, in memory (:func:`make_strip_events`) and as a
tactile HDF5 file (:func:`write_trials`), for the spatial tests."""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from tactile_cli.spatial import Roi, StripOptics
from tactile_cli.store import StoreWriter

W, H = 640, 480
OPTICS = StripOptics(pixel_pitch_m=9e-6, focal_length_m=3.6e-3, strip_distance_m=0.02)
STRIP_ROIS = (Roi("strip_1", 100, 120, 160, 360), Roi("strip_2", 300, 120, 360, 360),
              Roi("strip_3", 480, 120, 540, 360))


@dataclass
class StripTrial:
    """One synthetic trial: its events, regions and the truth."""

    x: np.ndarray
    y: np.ndarray
    t: np.ndarray
    p: np.ndarray
    annotations: list[tuple[float, float, str]]
    slip_speed_m_s: float
    slip_speed_px_s: float
    origin_us: int
    labels: dict = field(default_factory=dict)


def make_strip_events(
    *,
    slip_speed_m_s: float = 0.004,
    optics: StripOptics = OPTICS,
    rois: tuple[Roi, ...] = STRIP_ROIS,
    band_px: int = 12,
    strip_rate_hz: float = 20_000.0,
    noise_rate_hz: float = 20_000.0,
    press_s: tuple[float, float] = (0.3, 0.8),
    slip_s: tuple[float, float] = (0.8, 1.6),
    end_s: float = 2.0,
    origin_us: int = 0,
    direction: int = -1,
    seed: int = 0,
) -> StripTrial:
    """Positive strip events in a ``band_px`` band across each ROI whose centre sits at the
    ROI's lower part during the press and moves by ``direction * v_px`` px/s during the slip
    (``v_px`` = the speed through ``optics``), plus uniform background noise of both
    polarities over the whole sensor and marker-like negative blobs during the press.
    Timestamps are ``origin_us`` + microseconds of trial time."""
    rng = np.random.default_rng(seed)
    v_px = float(optics.m_to_px(slip_speed_m_s))
    xs, ys, ts, ps = [], [], [], []
    # strip events: press + slip regions
    for roi in rois:
        n = rng.poisson(strip_rate_hz * (slip_s[1] - press_s[0]))
        t = rng.uniform(press_s[0], slip_s[1], n)
        y_rest = roi.y1_px - 20.0 if direction < 0 else roi.y0_px + 20.0
        centre = y_rest + direction * v_px * np.clip(t - slip_s[0], 0, None)
        y = centre + rng.uniform(-band_px / 2, band_px / 2, n)
        x = rng.uniform(roi.x0_px + 2, roi.x1_px - 2, n)
        keep = (y >= roi.y0_px) & (y < roi.y1_px)
        xs.append(x[keep])
        ys.append(y[keep])
        ts.append(t[keep])
        ps.append(np.ones(int(keep.sum())))
    # marker blobs: negative events during the press, away from the strips
    for cx, cy in ((230, 60), (420, 420)):
        n = rng.poisson(5_000 * (press_s[1] - press_s[0]))
        xs.append(cx + rng.normal(0, 5, n))
        ys.append(cy + rng.normal(0, 5, n))
        ts.append(rng.uniform(*press_s, n))
        ps.append(-np.ones(n))
    n = rng.poisson(noise_rate_hz * end_s)
    xs.append(rng.uniform(0, W, n))
    ys.append(rng.uniform(0, H, n))
    ts.append(rng.uniform(0, end_s, n))
    ps.append(rng.choice([-1.0, 1.0], n))
    x = np.clip(np.concatenate(xs), 0, W - 1).astype(np.int64)
    y = np.clip(np.concatenate(ys), 0, H - 1).astype(np.int64)
    t = origin_us + np.round(np.concatenate(ts) * 1e6).astype(np.int64)
    p = np.concatenate(ps).astype(np.int8)
    order = np.argsort(t, kind="stable")
    ann = [(0.0, press_s[0], "approach"), (press_s[0], slip_s[0], "press"),
           (slip_s[0], slip_s[1], "slip"), (slip_s[1], end_s, "release")]
    return StripTrial(x[order], y[order], t[order], p[order], ann, slip_speed_m_s, v_px,
                      origin_us, {"slip_speed_m_s": slip_speed_m_s, "slip_speed_px_s": v_px})


def write_trials(path: Path, trials: dict[str, StripTrial], *, sensor_optics: bool = False,
                 with_annotations: bool = True) -> Path:
    """A tactile HDF5 file with one event trial per entry (``t_origin_us`` set)."""
    with StoreWriter(path, command="test") as w:
        extra = {}
        if sensor_optics:
            extra = {"pixel_pitch_m": OPTICS.pixel_pitch_m,
                     "focal_length_m": OPTICS.focal_length_m,
                     "strip_distance_m": OPTICS.strip_distance_m}
        s = w.add_sensor("cam", kind="event_camera", sample_rate_hz=0, width_px=W, height_px=H,
                         **extra)
        for name, tr in trials.items():
            tw = w.trial(name, labels=tr.labels,
                         annotations=tr.annotations if with_annotations else ())
            ev = tw.events(s)
            ev.append(tr.x, tr.y, tr.t, tr.p)
            ev.close(t_origin_us=tr.origin_us)
        w.commit()
    return path

