"""Where the scene's events land on the sensor, and the optics that turn slip into pixels.

Paper 000, sec. 3.3 and eq. 15: a strip deflection ``Delta y`` (m) moves the imaged aperture
by ``Delta H = (2 f / delta) Delta y`` on the chip, i.e. ``2 f / (delta * pitch)`` pixels per
metre (f = 3.6 mm, pitch = 9 um, delta the strip-to-camera distance). The scene takes the
slip displacement as that deflection, so a slip speed in m/s becomes a strip speed in px/s
by the same factor (and ``tactile_cli.spatial.optics`` inverts it exactly).

Layout: a grid of marker blobs (discs) receives the negative events; each marker strip is a
band ``width_px`` wide and ``band_height_px`` high that receives the positive events and
moves along y during the slip. A strip's region of interest (ROI) is the rectangle its band
can sweep in the longest slip the config allows, plus a margin, so the event-weighted
centroid of an ROI is the band centre (plus a few background events).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

from ..spatial.roi import Roi

if TYPE_CHECKING:
    from .config import MarkerSceneConfig


def slip_px_per_m(*, focal_length_m: float, strip_distance_m: float,
                  pixel_pitch_m: float) -> float:
    """Pixels of image motion per metre of strip travel, ``2 f / (delta * pitch)`` (eq. 15)."""
    return 2.0 * focal_length_m / (strip_distance_m * pixel_pitch_m)


@dataclass(frozen=True)
class SceneLayout:
    """The resolved geometry of the scene.

    marker_xy_px: (n_markers, 2) float64 blob centres (x, y); strip_x0_px: (n_strips,) int64
    left edge of each strip; rois: one per strip, in the same order.
    """

    width_px: int
    height_px: int
    marker_xy_px: np.ndarray
    marker_radius_px: float
    strip_x0_px: np.ndarray
    strip_width_px: int
    strip_rest_y_px: float
    band_height_px: int
    px_per_m: float
    rois: tuple[Roi, ...]

    def as_dict(self) -> dict[str, Any]:
        return {
            "markers": {"xy_px": self.marker_xy_px.tolist(),
                        "radius_px": self.marker_radius_px},
            "strips": {"x0_px": self.strip_x0_px.tolist(), "width_px": self.strip_width_px,
                       "rest_y_px": self.strip_rest_y_px,
                       "band_height_px": self.band_height_px},
            "rois": [roi.as_dict() for roi in self.rois],
        }


def scene_layout(config: MarkerSceneConfig) -> SceneLayout:
    """The geometry of ``config``; raises ValueError naming the key when a marker or an
    ROI leaves the sensor or a marker overlaps an ROI."""
    s = config.sensor
    width, height = s.width_px, s.height_px
    px_per_m = slip_px_per_m(focal_length_m=s.focal_length_m,
                             strip_distance_m=s.strip_distance_m, pixel_pitch_m=s.pixel_pitch_m)
    st = config.strips
    travel_px = max(config.slip.speeds_m_s) * px_per_m * config.timing.slip_s[1]
    half = st.band_height_px / 2
    if config.slip.direction_y < 0:
        y_lo, y_hi = st.rest_y_px - travel_px - half, st.rest_y_px + half
    else:
        y_lo, y_hi = st.rest_y_px - half, st.rest_y_px + travel_px + half
    y0 = math.floor(y_lo) - st.roi_margin_px
    y1 = math.ceil(y_hi) + st.roi_margin_px
    if y0 < 0 or y1 > height:
        raise ValueError(
            f"strips: the strip ROIs span y {y0}..{y1} px (band {st.band_height_px} px at "
            f"rest_y_px={st.rest_y_px}, up to {travel_px:.1f} px of slip travel), outside the "
            f"{height} px sensor; move strips.rest_y_px, lower slip.speeds_m_s or "
            "timing.slip_s, or raise sensor.strip_distance_m")
    x0 = np.array([math.floor(x - st.width_px / 2) for x in st.x_px], dtype=np.int64)
    rois = []
    for i, left in enumerate(x0):
        if left < 0 or left + st.width_px > width:
            raise ValueError(f"strips.x_px[{i}] (={st.x_px[i]}): the strip spans x "
                             f"{left}..{left + st.width_px} px, outside the {width} px sensor")
        rois.append(Roi(f"strip{i + 1}", int(left), y0, int(left + st.width_px), y1))
    mk = config.markers
    xy = np.array([(x, y) for y in mk.y_px for x in mk.x_px], dtype=np.float64)
    r = mk.radius_px
    for x, y in xy:
        if x - r < 0 or x + r >= width or y - r < 0 or y + r >= height:
            raise ValueError(f"markers: the blob at ({x:g}, {y:g}) px with radius_px={r:g} "
                             f"leaves the {width}x{height} px sensor")
        for roi in rois:
            # nearest point of the ROI rectangle to the disc centre
            nx = min(max(x, roi.x0_px), roi.x1_px)
            ny = min(max(y, roi.y0_px), roi.y1_px)
            if (nx - x) ** 2 + (ny - y) ** 2 < r * r:
                raise ValueError(
                    f"markers: the blob at ({x:g}, {y:g}) px overlaps {roi.name}'s ROI x "
                    f"{roi.x0_px}..{roi.x1_px}, y {roi.y0_px}..{roi.y1_px} px (its negative "
                    "events would bias the strip centroid); move markers.x_px/y_px or strips")
    return SceneLayout(width, height, xy, float(r), x0, st.width_px, float(st.rest_y_px),
                       st.band_height_px, px_per_m, tuple(rois))


__all__ = ["SceneLayout", "scene_layout", "slip_px_per_m"]
