"""Friction-induced fingertip vibration and the accelerometer chain (paper 001, secs. 3-4).

Sources, per recording (accelerations in g at ``rate_hz``):

- **Surface following.** A contact that moves at speed ``v`` over a surface of height
  profile ``h(x)`` is accelerated normal to the surface by ``v^2 h''(x)`` (the ``dv/dt h'``
  term is left out). Each surface is a seeded random profile whose spatial spectrum is a
  Gaussian around ``1 / wavelength_mm`` (relative width ``relative_bandwidth``), scaled
  to the texture's ``roughness_nm`` and cut at a 100 um wavelength so that 0.35 m/s stays
  below the 4 kHz Nyquist frequency. Rougher surfaces give stronger vibration; faster
  motion gives stronger and higher-pitched vibration (temporal frequency = v / wavelength).
  Slippage rubs the object over both fingertips (one profile per face, at the object's
  position, gain ``slip_gain``); sliding rubs the slider over the object and reaches both
  fingertips through it (one profile, at the slider's position on the object, gain
  ``slide_gain``). The tangential (friction) part is a second profile realisation of the
  same surface.
- **Impact.** When the slider reaches a stop it rings the bar's bending mode (``mode_hz``,
  ``mode_q``), peak ``impact_g_per_m_s`` x closing speed: the start of a slip.
- **Motor hum.** While the motor turns (and, at 30 %, while it holds at a dead point) the
  frame excites the bar's mode with narrow-band noise of ``motor_hum_g`` x rps / 0.48.
- **Pad.** Everything reaches the accelerometer through the fingertip pad: a second-order
  low-pass resonance (``pad_resonance_hz``, ``pad_q``, gain ``pad_gain``).

Axes: x points along the object's motion at gripper angle 0; the gripper angle alpha
rotates the tangential vibration into x (cos alpha) and y (sin alpha); z is normal to the
pad. The right fingertip faces the left one, so its y and z axes are mirrored. Gravity
along the motion axis adds a constant offset. The sensor adds white noise (``noise_g``
RMS), the first-order analogue low-pass (``lowpass_hz``), and the ADC quantises
acceleration / full scale to ``adc_bits`` and clips it to [-1, 1].
"""

from __future__ import annotations

import numpy as np
from scipy import signal as _signal

from .config import TextureConfig, VibroSceneConfig

G_M_S2 = 9.80665
#: Shortest surface wavelength kept (m): 0.35 m/s / 100 um = 3.5 kHz < 4 kHz Nyquist.
MIN_WAVELENGTH_M = 100e-6
_PROFILE_STEP_M = 10e-6


def surface_curvature(texture: TextureConfig, x_min_m: float, x_max_m: float,
                      rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    """``(x_m (p,), h''(x) (p,) in 1/m)``: the second derivative of a random surface
    profile covering ``[x_min_m, x_max_m]`` with the texture's RMS height and spectrum."""
    span = x_max_m - x_min_m + 2e-3
    n = int(2 ** np.ceil(np.log2(span / _PROFILE_STEP_M)))
    k = np.fft.rfftfreq(n, _PROFILE_STEP_M)                      # cycles per m
    k0 = 1.0 / (texture.wavelength_mm * 1e-3)
    shape = np.exp(-0.5 * ((k - k0) / (texture.relative_bandwidth * k0)) ** 2)
    shape[(k > 1.0 / MIN_WAVELENGTH_M) | (k == 0)] = 0.0
    spec = shape * (rng.normal(size=k.size) + 1j * rng.normal(size=k.size))
    h = np.fft.irfft(spec, n)
    h *= texture.roughness_nm * 1e-9 / max(h.std(), 1e-300)
    curvature = np.fft.irfft(np.fft.rfft(h) * -(2 * np.pi * k) ** 2, n)
    x = x_min_m - 1e-3 + np.arange(n) * _PROFILE_STEP_M
    return x, curvature


def follow(x_grid: np.ndarray, curvature: np.ndarray, position_m: np.ndarray,
           speed_m_s: np.ndarray) -> np.ndarray:
    """(n,) acceleration (g) of a contact at ``position_m`` moving at ``speed_m_s``:
    ``v^2 h''(x) / g``."""
    return speed_m_s ** 2 * np.interp(position_m, x_grid, curvature) / G_M_S2


def resonance(x: np.ndarray, rate_hz: float, f0_hz: float, q: float, *,
              band_pass: bool = False) -> np.ndarray:
    """Second-order resonance (bilinear transform) applied along axis 0: a low-pass with
    unit gain at DC, or a band-pass with unit gain at ``f0_hz``."""
    w0 = 2 * np.pi * f0_hz
    num = [w0 / q, 0.0] if band_pass else [w0 ** 2]
    b, a = _signal.bilinear(num, [1.0, w0 / q, w0 ** 2], fs=rate_hz)
    _, h = _signal.freqz(b, a, worN=[f0_hz if band_pass else 0.0], fs=rate_hz)
    return _signal.lfilter(b / max(abs(h[0]), 1e-12), a, x, axis=0)


def first_order_lowpass(x: np.ndarray, rate_hz: float, cutoff_hz: float) -> np.ndarray:
    """The analogue RC low-pass (bilinear transform, pre-warped at the cut-off), axis 0."""
    b, a = _signal.butter(1, cutoff_hz, btype="low", fs=rate_hz)
    zi = _signal.lfilter_zi(b, a).reshape((-1,) + (1,) * (x.ndim - 1)) * x[:1]
    return _signal.lfilter(b, a, x, axis=0, zi=zi)[0]  # settled on the first sample


def ring_downs(n: int, rate_hz: float, impacts: np.ndarray, f_hz: float, q: float,
               g_per_m_s: float) -> np.ndarray:
    """(n,) sum of decaying sinusoids (g) at the bar's mode, one per impact row
    (time s, closing speed m/s)."""
    out = np.zeros(n)
    tau = q / (np.pi * f_hz)
    length = min(n, int(6 * tau * rate_hz) + 1)
    t = np.arange(length) / rate_hz
    kernel = np.sin(2 * np.pi * f_hz * t) * np.exp(-t / tau)
    for t0, speed in impacts:
        i = int(round(t0 * rate_hz))
        if i < n:
            m = min(length, n - i)
            out[i: i + m] += g_per_m_s * speed * kernel[:m]
    return out


def hum(n: int, rate_hz: float, f_hz: float, q: float, level: np.ndarray,
        rng: np.random.Generator) -> np.ndarray:
    """(n,) narrow-band noise around ``f_hz`` with RMS ``level`` (n,) g."""
    raw = resonance(rng.normal(size=n), rate_hz, f_hz, q, band_pass=True)
    return raw / max(raw.std(), 1e-12) * level


def sensor(accel_g: np.ndarray, cfg: VibroSceneConfig, rng: np.random.Generator) -> np.ndarray:
    """(n, 6) acceleration (g) at the sensing element -> (n, 6) float32 CSV values: noise,
    first-order low-pass, ADC quantisation of acceleration / full scale, clipped to [-1, 1]."""
    noisy = accel_g + rng.normal(scale=cfg.noise_g, size=accel_g.shape)
    filtered = first_order_lowpass(noisy, cfg.rate_hz, cfg.lowpass_hz)
    levels = 2 ** (cfg.adc_bits - 1) - 1
    return (np.round(np.clip(filtered / cfg.full_scale_g, -1, 1) * levels) / levels
            ).astype(np.float32)
