"""Height maps of what presses the gel: a ball bearing (calibration, paper 002 sec. II-B)
and the slip-test objects of sec. III-IV (a cable, a carton-box face, a fabric, hex keys).

Every map is (H, W) float32 indentation in mm (>= 0, 0 where the gel is untouched), on the
pixel grid of a :class:`~.render.GelOptics` (x = column, y = row). Objects are placed by a
centre and moved rigidly by ``shift_px`` and ``angle_deg`` (rotation about the centre);
their surface texture is drawn from ``rng`` once, in the object's own coordinates, so a
shifted object carries the same texture with it (what slip looks like to the sensor).
The gel spreads sharp edges a little: object maps are smoothed by a Gaussian of
``GEL_BLUR_PX``; the ball cap is exact, since calibration labels come from its geometry.
"""

from __future__ import annotations

import numpy as np

from .render import GelOptics

#: Object names accepted by :func:`object_height`.
OBJECT_NAMES = ("cable", "box", "fabric", "hex_key_small", "hex_key_medium", "hex_key_large")
#: Across-flats sizes of the hex keys in mm (small, medium, large; paper 002 Fig. 9).
HEX_KEY_MM = {"hex_key_small": 1.5, "hex_key_medium": 2.5, "hex_key_large": 4.0}
#: Gaussian smoothing of object maps by the elastomer, in px.
GEL_BLUR_PX = 1.0


def ball_cap(optics: GelOptics, centre_px: tuple[float, float], radius_mm: float,
             depth_mm: float) -> np.ndarray:
    """A ball bearing of ``radius_mm`` pressed ``depth_mm`` into the gel at ``centre_px``
    (x, y in px): ``H = sqrt(R^2 - r^2) - (R - d)`` inside the contact circle of radius
    ``sqrt(2 R d - d^2)`` mm, 0 outside. Returns (H, W) float32 mm."""
    if not (radius_mm > 0 and 0 < depth_mm < radius_mm):
        raise ValueError(f"`depth_mm` (={depth_mm}) must be in (0, `radius_mm` (={radius_mm}))")
    ys, xs = np.mgrid[0:optics.height_px, 0:optics.width_px].astype(np.float64)
    r2 = ((xs - centre_px[0]) ** 2 + (ys - centre_px[1]) ** 2) / optics.px_per_mm ** 2
    cap = np.sqrt(np.maximum(radius_mm ** 2 - r2, 0.0)) - (radius_mm - depth_mm)
    return np.maximum(cap, 0.0).astype(np.float32)


def contact_radius_px(optics: GelOptics, radius_mm: float, depth_mm: float) -> float:
    """Radius in px of the contact circle of a ball cap: ``sqrt(2 R d - d^2) * px_per_mm``."""
    return float(np.sqrt(2 * radius_mm * depth_mm - depth_mm ** 2) * optics.px_per_mm)


class Texture:
    """A random surface texture in object coordinates (mm): a sum of ``n`` cosines with
    wavelengths in ``wavelength_mm`` and random directions and phases, scaled to RMS
    ``rms_mm``. Fixed at construction, so evaluating it at shifted coordinates moves it."""

    def __init__(self, rng: np.random.Generator, *, n: int, wavelength_mm: tuple[float, float],
                 rms_mm: float, directions: np.ndarray | None = None) -> None:
        theta = (rng.uniform(0, np.pi, n) if directions is None
                 else rng.choice(directions, n) + rng.normal(0, 0.05, n))
        k = 2 * np.pi / rng.uniform(*wavelength_mm, n)
        self.kx, self.ky = k * np.cos(theta), k * np.sin(theta)
        self.phase = rng.uniform(0, 2 * np.pi, n)
        amp = rng.uniform(0.5, 1.0, n)
        self.amp = amp * rms_mm / np.sqrt(0.5 * np.sum(amp ** 2))

    def on_grid(self, optics: GelOptics, origin_px: tuple[float, float],
                angle_deg: float) -> np.ndarray:
        """The texture on the pixel grid, (H, W) float64 mm, for an object whose origin is
        at ``origin_px`` (x, y) and whose u axis points at ``angle_deg`` from +x.

        Each cosine's phase is affine in (x, y), so ``cos(row + col)`` factors into row and
        column terms and the whole sum is one (H, 2n) x (2n, W) product, not n full-frame
        cosines (einsum's own loop: BLAS threads cost more than they save at this size on
        a busy machine)."""
        a = np.deg2rad(angle_deg)
        c, s = np.cos(a), np.sin(a)
        # u = c dx + s dy, v = -s dx + c dy with (dx, dy) = (pixel - origin) / px_per_mm
        alpha = (self.kx * c - self.ky * s) / optics.px_per_mm  # rad per px along x
        beta = (self.kx * s + self.ky * c) / optics.px_per_mm  # rad per px along y
        gamma = self.phase - alpha * origin_px[0] - beta * origin_px[1]
        col = np.outer(np.arange(optics.width_px), alpha)  # (W, n)
        row = np.outer(np.arange(optics.height_px), beta) + gamma  # (H, n)
        rows = np.hstack([self.amp * np.cos(row), -self.amp * np.sin(row)])
        cols = np.hstack([np.cos(col), np.sin(col)])
        return np.einsum("hk,wk->hw", rows, cols)

    def __call__(self, u_mm: np.ndarray, v_mm: np.ndarray) -> np.ndarray:
        """The texture at object coordinates (mm), any shape."""
        out = np.zeros(np.shape(u_mm), dtype=np.float64)
        for kx, ky, ph, a in zip(self.kx, self.ky, self.phase, self.amp, strict=True):
            out += a * np.cos(kx * u_mm + ky * v_mm + ph)
        return out


def _object_frame(optics: GelOptics, centre_px: tuple[float, float],
                  shift_px: tuple[float, float], angle_deg: float) -> tuple[np.ndarray, np.ndarray]:
    """Pixel grid in the object's coordinates (mm): u along its axis, v across it."""
    ys, xs = np.mgrid[0:optics.height_px, 0:optics.width_px].astype(np.float64)
    dx = (xs - centre_px[0] - shift_px[0]) / optics.px_per_mm
    dy = (ys - centre_px[1] - shift_px[1]) / optics.px_per_mm
    a = np.deg2rad(angle_deg)
    return np.cos(a) * dx + np.sin(a) * dy, -np.sin(a) * dx + np.cos(a) * dy


def _smooth_step(x: np.ndarray, width: float) -> np.ndarray:
    """0 for x <= -width, 1 for x >= width, a cosine ramp between."""
    t = np.clip((x + width) / (2 * width), 0.0, 1.0)
    return 0.5 - 0.5 * np.cos(np.pi * t)


def object_height(name: str, optics: GelOptics, *, centre_px: tuple[float, float],
                  shift_px: tuple[float, float] = (0.0, 0.0), angle_deg: float = 0.0,
                  depth_mm: float, rng: np.random.Generator) -> np.ndarray:
    """The gel indentation under object ``name`` (one of :data:`OBJECT_NAMES`).

    centre_px: object centre (x, y) in px; shift_px: rigid displacement (px); angle_deg:
    rotation about the centre (degrees, x towards y); depth_mm: how far the object is
    pressed in (mm, > 0). rng draws the object's texture and must be seeded the same for
    every frame of one object. Returns (H, W) float32 mm, >= 0.

    - ``cable``: a 3.5 mm thick cylinder crossing the view along the object's axis, with a
      fine helical-braid texture;
    - ``box``: a flat carton face of 14 x 10 mm with rounded edges and a paper grain;
    - ``fabric``: a woven texture (two thread directions, 0.6-1 mm period) over the whole
      view, under a broad pressure dome;
    - ``hex_key_small|medium|large``: a hexagonal bar (1.5, 2.5, 4 mm across flats) pressed
      corner-first, its tip near the centre.
    """
    from scipy.ndimage import gaussian_filter

    if name not in OBJECT_NAMES:
        raise ValueError(f"`name` (={name!r}) is not one of {', '.join(OBJECT_NAMES)}")
    if not depth_mm > 0:
        raise ValueError(f"`depth_mm` (={depth_mm}) must be positive")
    u, v = _object_frame(optics, centre_px, shift_px, angle_deg)
    origin = (centre_px[0] + shift_px[0], centre_px[1] + shift_px[1])

    def tex(t: Texture) -> np.ndarray:
        return t.on_grid(optics, origin, angle_deg)

    if name == "cable":
        radius = 1.75
        texture = Texture(rng, n=12, wavelength_mm=(0.5, 1.2), rms_mm=0.012,
                          directions=np.array([0.6, -0.6]))
        surface = np.sqrt(np.maximum(radius ** 2 - v ** 2, 0.0)) - (radius - depth_mm)
        height = np.where(np.abs(v) < radius, surface + tex(texture), 0.0)
    elif name == "box":
        texture = Texture(rng, n=24, wavelength_mm=(0.3, 2.0), rms_mm=0.010)
        face = _smooth_step(7.0 - np.abs(u), 0.8) * _smooth_step(5.0 - np.abs(v), 0.8)
        height = face * (depth_mm + tex(texture))
    elif name == "fabric":
        weave = Texture(rng, n=8, wavelength_mm=(0.6, 1.0), rms_mm=0.030,
                        directions=np.array([0.0, np.pi / 2]))
        fuzz = Texture(rng, n=16, wavelength_mm=(0.25, 0.6), rms_mm=0.008)
        dome = np.exp(-(u ** 2 + v ** 2) / (2 * 6.0 ** 2))
        height = dome * depth_mm + dome * (tex(weave) + tex(fuzz))
    else:
        across = HEX_KEY_MM[name]
        half = across / np.sqrt(3.0)  # corner-to-centre of a hexagon with that across-flats
        # corner pressed first: the profile across the bar is a 120-degree wedge
        wedge = depth_mm - np.abs(v) / np.tan(np.deg2rad(60.0))
        along = _smooth_step(u + 1.0, 0.3)  # tip of the key at u = -1 mm, bar towards +u
        height = np.where(np.abs(v) < half, wedge, 0.0) * along
    height = gaussian_filter(np.maximum(height, 0.0), GEL_BLUR_PX, mode="nearest")
    return height.astype(np.float32)


__all__ = ["GEL_BLUR_PX", "HEX_KEY_MM", "OBJECT_NAMES", "Texture", "ball_cap",
           "contact_radius_px", "object_height"]
