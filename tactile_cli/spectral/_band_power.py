"""Welch power spectra, band power and spectral centroid of multichannel signals."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from scipy import signal as _signal


def welch_psd(x: np.ndarray, rate_hz: float, *, nperseg: int = 256
              ) -> tuple[np.ndarray, np.ndarray]:
    """Welch power spectral density of (n,) or (n, c) samples.

    Returns ``(f_hz (m,), psd (m, c))`` in units^2/Hz (Hann segments of ``nperseg``
    samples, half overlap, mean removed per segment). ``nperseg`` is cut to ``n``.
    """
    a = np.asarray(x, dtype=np.float64)
    a = a[:, None] if a.ndim == 1 else a
    if a.ndim != 2 or a.shape[0] < 2:
        raise ValueError(f"`x` must be (n >= 2,) or (n >= 2, c), got shape {np.shape(x)}")
    if not rate_hz > 0:
        raise ValueError(f"`rate_hz` (={rate_hz}) must be positive")
    f, p = _signal.welch(a, fs=rate_hz, nperseg=min(nperseg, a.shape[0]), axis=0,
                         detrend="constant")
    return f, p


def band_power(x: np.ndarray, rate_hz: float, bands_hz: Sequence[tuple[float, float]], *,
               nperseg: int = 256) -> np.ndarray:
    """(len(bands), c) power (units^2) of (n, c) samples in each ``[lo, hi)`` Hz band:
    the Welch density integrated over the band."""
    f, p = welch_psd(x, rate_hz, nperseg=nperseg)
    df = f[1] - f[0]
    out = np.empty((len(bands_hz), p.shape[1]))
    for i, (lo, hi) in enumerate(bands_hz):
        if not 0 <= lo < hi:
            raise ValueError(f"band {i} (={lo}, {hi}) must satisfy 0 <= lo < hi")
        sel = (f >= lo) & (f < hi)
        out[i] = p[sel].sum(axis=0) * df
    return out


def spectral_centroid(x: np.ndarray, rate_hz: float, *, nperseg: int = 256,
                      f_min_hz: float = 0.0) -> np.ndarray:
    """(c,) power-weighted mean frequency (Hz) of (n, c) samples above ``f_min_hz``
    (NaN for a channel without power there)."""
    f, p = welch_psd(x, rate_hz, nperseg=nperseg)
    sel = f >= f_min_hz
    total = p[sel].sum(axis=0)
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(total > 0, (f[sel, None] * p[sel]).sum(axis=0) / total, np.nan)
