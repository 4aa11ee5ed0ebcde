"""A DIGIT-like renderer: height maps of the gel surface -> RGB tactile frames (paper 002,
sec. II-A, eq. 3: the colour at a pixel is a function R of the surface gradients there).

The sensor is modelled as a flat elastomer seen from below by a camera, lit from its sides
by three coloured LEDs that sit just above the gel plane, as in a DIGIT. A pixel's colour
is an ambient term plus, per LED, Lambert shading ``max(0, n . l)`` of the surface normal
``n`` against the direction ``l`` from the pixel to that LED, weighted by the LED's colour
and by an inverse-square fall-off with the distance to it; the sum is dimmed towards the
corners (vignetting), passed through a camera response (gamma) and quantised to 8 bits
after Gaussian camera noise. Because the LEDs are close and low, the colour of a *flat*
pixel already depends on where it is (the no-contact reference is far from uniform), which
is why the paper feeds ``(x, y)`` and colour *differences* from the reference to its MLP
(sec. II-B: "the light distribution of DIGIT is not uniform").

Conventions shared by the chain (``poisson.py`` inverts them exactly):

- pixel ``x`` is the column index (to the right), ``y`` the row index (down);
- ``height_mm`` is the indentation of the gel (mm, >= 0 where pressed, 0 flat);
- the unit normal is ``(-dH/dx, -dH/dy, 1) / norm`` with gradients in mm per mm (pixel
  steps divided by ``px_per_mm``), so a flat surface has normal ``(0, 0, 1)`` and a ball
  cap ``H = sqrt(R^2 - r^2) - (R - d)`` gets the ball's outward normal
  ``(x - xc, y - yc, sqrt(R^2 - r^2)) / R``.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from functools import lru_cache

import numpy as np

#: DIGIT's frame size (width x height, px) and sensing area: 320 px over about 20 mm.
DIGIT_WIDTH_PX = 320
DIGIT_HEIGHT_PX = 240
DIGIT_PX_PER_MM = 16.0


@dataclass(frozen=True)
class Led:
    """One light: position in mm in the sensor frame (x right, y down from the top-left
    pixel, z above the gel plane) and linear RGB colour (0-1 per channel, scaled by
    ``GelOptics.led_gain``)."""

    x_mm: float
    y_mm: float
    z_mm: float
    rgb: tuple[float, float, float]


def _digit_leds() -> tuple[Led, ...]:
    # red at the left edge, green at the right edge, blue at the bottom edge, each a little
    # outside the image and low above the gel: grazing light whose colour changes across it
    w, h = DIGIT_WIDTH_PX / DIGIT_PX_PER_MM, DIGIT_HEIGHT_PX / DIGIT_PX_PER_MM
    return (Led(-2.0, 0.45 * h, 2.5, (1.0, 0.18, 0.10)),
            Led(w + 2.0, 0.55 * h, 2.5, (0.15, 1.0, 0.20)),
            Led(0.5 * w, h + 2.0, 2.5, (0.12, 0.25, 1.0)))


@dataclass(frozen=True)
class GelOptics:
    """The simulated sensor: frame size, scale, lights and camera.

    width_px, height_px: frame size (DIGIT: 320 x 240). px_per_mm: pixels per millimetre on
    the gel (16 px/mm: DIGIT's 320 px span about 20 mm). leds: the three lights.
    ambient_rgb: light reaching every pixel regardless of shape (0-1, linear).
    led_gain: scale of every LED's contribution. falloff_mm: distance at which an LED's
    irradiance has fallen to half (inverse-square-like ``1 / (1 + (d / falloff_mm)^2)``).
    vignetting: fractional dimming at the image corners (``1 - vignetting * r^2`` with r = 1
    at a corner). gamma: camera response exponent (output = linear ** (1 / gamma)).
    noise_std: Gaussian camera noise, standard deviation in 0-255 units.
    """

    width_px: int = DIGIT_WIDTH_PX
    height_px: int = DIGIT_HEIGHT_PX
    px_per_mm: float = DIGIT_PX_PER_MM
    leds: tuple[Led, ...] = field(default_factory=_digit_leds)
    ambient_rgb: tuple[float, float, float] = (0.10, 0.10, 0.12)
    led_gain: float = 0.9
    falloff_mm: float = 12.0
    vignetting: float = 0.35
    gamma: float = 2.2
    noise_std: float = 2.0

    def __post_init__(self) -> None:
        if self.width_px < 2 or self.height_px < 2:
            raise ValueError(f"`width_px` x `height_px` (={self.width_px}x{self.height_px}) "
                             "must be at least 2x2")
        for name in ("px_per_mm", "falloff_mm", "gamma"):
            value = getattr(self, name)
            if not (np.isfinite(value) and value > 0):
                raise ValueError(f"`{name}` (={value}) must be a positive number")
        if not (np.isfinite(self.noise_std) and self.noise_std >= 0):
            raise ValueError(f"`noise_std` (={self.noise_std}) must be >= 0")

    def jittered(self, rng: np.random.Generator, *, amount: float) -> GelOptics:
        """A copy with each LED's colour scaled by ``1 + amount * N(0, 1)`` (per channel)
        and moved by ``amount * 10`` mm * N(0, 1) in x and y: a different unit of the same
        sensor model, or the same unit after its LEDs aged (``amount`` 0 returns self)."""
        if amount <= 0:
            return self
        leds = tuple(Led(led.x_mm + 10 * amount * float(rng.standard_normal()),
                         led.y_mm + 10 * amount * float(rng.standard_normal()), led.z_mm,
                         tuple(float(max(0.0, c * (1 + amount * rng.standard_normal())))
                               for c in led.rgb))  # type: ignore[arg-type]
                     for led in self.leds)
        return replace(self, leds=leds)

    def as_dict(self) -> dict[str, object]:
        """JSON-ready description (recorded in a scene's ``scene.json``)."""
        return {"width_px": self.width_px, "height_px": self.height_px,
                "px_per_mm": self.px_per_mm,
                "leds": [{"x_mm": led.x_mm, "y_mm": led.y_mm, "z_mm": led.z_mm,
                          "rgb": list(led.rgb)} for led in self.leds],
                "ambient_rgb": list(self.ambient_rgb), "led_gain": self.led_gain,
                "falloff_mm": self.falloff_mm, "vignetting": self.vignetting,
                "gamma": self.gamma, "noise_std": self.noise_std}


def surface_normals(height_mm: np.ndarray, px_per_mm: float) -> np.ndarray:
    """Unit normals of a height map.

    height_mm: (..., H, W) float heights (indentation) in mm. px_per_mm: pixels per mm.
    Returns (..., H, W, 3) float32 unit normals ``(-dH/dx, -dH/dy, 1) / norm`` with x the
    column index and y the row index and gradients in mm/mm (central differences inside,
    one-sided at the border); nz > 0, flat = (0, 0, 1). ``gradients_from_normals`` in
    ``poisson.py`` inverts it: ``(dH/dx, dH/dy) = (-nx/nz, -ny/nz)``.
    """
    h = np.asarray(height_mm, dtype=np.float64)
    if h.ndim < 2 or h.shape[-1] < 2 or h.shape[-2] < 2:
        raise ValueError(f"`height_mm` must be (..., H, W) with H, W >= 2, got shape {h.shape}")
    gy, gx = np.gradient(h, axis=(-2, -1))
    gx = gx * px_per_mm
    gy = gy * px_per_mm
    inv = 1.0 / np.sqrt(gx * gx + gy * gy + 1.0)
    return np.stack([-gx * inv, -gy * inv, inv], axis=-1).astype(np.float32)


@lru_cache(maxsize=8)
def _light_maps(optics: GelOptics) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Per LED and pixel (flat gel plane): unit direction to the LED (n_leds, H, W, 3),
    its irradiance weight (n_leds, H, W), and the vignetting map (H, W)."""
    ys, xs = np.mgrid[0:optics.height_px, 0:optics.width_px].astype(np.float64)
    x_mm, y_mm = (xs + 0.5) / optics.px_per_mm, (ys + 0.5) / optics.px_per_mm
    dirs, weights = [], []
    for led in optics.leds:
        d = np.stack([led.x_mm - x_mm, led.y_mm - y_mm, np.full_like(x_mm, led.z_mm)], -1)
        dist = np.linalg.norm(d, axis=-1)
        dirs.append(d / dist[..., None])
        weights.append(1.0 / (1.0 + (dist / optics.falloff_mm) ** 2))
    cx, cy = (optics.width_px - 1) / 2, (optics.height_px - 1) / 2
    r2 = ((xs - cx) ** 2 + (ys - cy) ** 2) / (cx * cx + cy * cy)
    vignette = 1.0 - optics.vignetting * r2
    return (np.asarray(dirs, dtype=np.float32), np.asarray(weights, dtype=np.float32),
            vignette.astype(np.float32))


def render_rgb(height_mm: np.ndarray, optics: GelOptics, *, rng: np.random.Generator | None = None,
               lighting_gain: float = 1.0, noise_std: float | None = None) -> np.ndarray:
    """Render tactile frames of gel height maps.

    height_mm: (..., H, W) indentation in mm, H x W = ``optics.height_px x width_px``.
    rng: source of the camera noise (None: no noise). lighting_gain: factor on every LED
    (a frame-to-frame flicker or exposure change). noise_std: override of
    ``optics.noise_std`` (0-255 units). Returns (..., H, W, 3) uint8 RGB.
    """
    h = np.asarray(height_mm)
    if h.shape[-2:] != (optics.height_px, optics.width_px):
        raise ValueError(f"`height_mm` is {h.shape[-1]}x{h.shape[-2]} px (width x height) but "
                         f"the optics are {optics.width_px}x{optics.height_px} px")
    normals = surface_normals(h, optics.px_per_mm)
    dirs, weights, vignette = _light_maps(optics)
    linear = np.broadcast_to(np.asarray(optics.ambient_rgb, dtype=np.float32),
                             normals.shape).copy()
    gain = np.float32(optics.led_gain * lighting_gain)
    for led, d, w in zip(optics.leds, dirs, weights, strict=True):
        shade = np.einsum("...c,...c->...", normals, d)
        np.maximum(shade, 0.0, out=shade)
        shade *= w * gain
        linear += shade[..., None] * np.asarray(led.rgb, dtype=np.float32)
    linear *= vignette[..., None]
    np.clip(linear, 0.0, 1.0, out=linear)
    image = 255.0 * linear ** np.float32(1.0 / optics.gamma)
    std = optics.noise_std if noise_std is None else float(noise_std)
    if rng is not None and std > 0:
        image += np.float32(std) * rng.standard_normal(size=image.shape, dtype=np.float32)
    return np.clip(np.rint(image), 0, 255).astype(np.uint8)


def render_reference(optics: GelOptics, *, rng: np.random.Generator | None = None,
                     lighting_gain: float = 1.0, noise_std: float | None = None) -> np.ndarray:
    """The no-contact frame: :func:`render_rgb` of a flat gel, (H, W, 3) uint8."""
    flat = np.zeros((optics.height_px, optics.width_px), dtype=np.float32)
    return render_rgb(flat, optics, rng=rng, lighting_gain=lighting_gain, noise_std=noise_std)


__all__ = ["DIGIT_HEIGHT_PX", "DIGIT_PX_PER_MM", "DIGIT_WIDTH_PX", "GelOptics", "Led",
           "render_reference", "render_rgb", "surface_normals"]
