"""Pixels on the event camera -> metres of marker-strip travel (paper 000, eqs. 3, 14, 15).

The chain, with units:

1. A displacement of ``n_px`` pixels on the sensor array is a physical length on the chip,
   ``Delta H = n_px * pixel_pitch_m`` (metres on the image plane). The DVXplorer Mini's
   pixels are 9 um: 640 x 480 px is 5.76 x 4.32 mm (sec. 3.3).
2. Eq. 3, ``H = (f / delta) * FOV``: the lens maps an object of size FOV at distance
   ``delta`` (the strip-to-camera distance after calibration, metres) onto ``H`` on the
   chip; the magnification is ``f / delta`` (``f`` the focal length, 3.6 mm in the paper).
3. Eq. 15, ``Delta A_s = w_s * Delta H = w_s * (f / delta) * Delta FOV =
   w_s * (2 f / delta) * Delta y_max``: the strip's maximal deflection ``Delta y_max``
   changes the imaged field by ``Delta FOV = 2 * Delta y_max`` (the aperture opens on both
   sides), so ``Delta H = (2 f / delta) * Delta y_max`` and, inverted,
   ``Delta y_max = Delta H * delta / (2 f)``. (Eq. 14 is the same opening seen as the
   marker's angular aperture area ``l_2^2 Delta theta``; the strip width ``w_s`` cancels.)

So one pixel of centroid motion is ``pixel_pitch_m * strip_distance_m / (2 *
focal_length_m)`` metres of strip travel, and a centroid rate in px/s times that factor is
the slip speed in m/s. The scene (``tactile simulate marker-events``) converts its slip
speeds to px/s with the same relation, so the round trip is exact by construction; on a
real sensor ``strip_distance_m`` is the calibrated delta.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass

import numpy as np

#: DVXplorer Mini pixel pitch (paper 000, sec. 3.3), metres.
PAPER_PIXEL_PITCH_M = 9e-6
#: Lens focal length of the paper's sensor (sec. 3.2), metres.
PAPER_FOCAL_LENGTH_M = 3.6e-3


@dataclass(frozen=True)
class StripOptics:
    """Optics of a marker-strip sensor.

    pixel_pitch_m: pixel size on the chip (m); focal_length_m: lens focal length (m);
    strip_distance_m: delta, the strip-to-camera distance (m).
    """

    pixel_pitch_m: float
    focal_length_m: float
    strip_distance_m: float

    def __post_init__(self) -> None:
        for name, value in asdict(self).items():
            if not (isinstance(value, int | float) and not isinstance(value, bool)
                    and np.isfinite(value) and value > 0):
                raise ValueError(f"`{name}` (={value!r}) must be a positive number of metres")

    @property
    def chip_m_per_px(self) -> float:
        """Delta H per pixel: metres on the image plane (step 1)."""
        return self.pixel_pitch_m

    @property
    def magnification(self) -> float:
        """f / delta of eq. 3: image size per object size (dimensionless)."""
        return self.focal_length_m / self.strip_distance_m

    @property
    def strip_m_per_px(self) -> float:
        """Metres of strip deflection per pixel of centroid motion (eq. 15 inverted):
        ``pixel_pitch_m * strip_distance_m / (2 * focal_length_m)``."""
        return self.chip_m_per_px / (2.0 * self.magnification)

    def px_to_m(self, px: np.ndarray | float) -> np.ndarray | float:
        """Centroid motion in px (or px/s) -> strip travel in m (or m/s)."""
        return px * self.strip_m_per_px

    def m_to_px(self, m: np.ndarray | float) -> np.ndarray | float:
        """Strip travel in m (or m/s) -> centroid motion in px (or px/s)."""
        return m / self.strip_m_per_px

    def as_dict(self) -> dict[str, float]:
        return asdict(self)
