"""Bandwidth limitation for bandwidth studies: low-pass, then resample (paper 001, sec. 6.4).

The paper halves the signal bandwidth step by step, from the 4 kHz Nyquist limit of its
8 kHz recordings down to 31.25 Hz, with a low-pass filter. :func:`limit_bandwidth` does
one step: a zero-phase 8th-order Butterworth low-pass at the cut-off (the anti-alias
filter), then polyphase resampling to ``2 x cut-off`` (never above the input rate), so a
model sees the sample rate a sensor of that bandwidth would deliver.
"""

from __future__ import annotations

from fractions import Fraction

import numpy as np
from scipy import signal as _signal


def bandwidth_steps(rate_hz: float, lowest_hz: float = 31.25) -> list[float]:
    """Cut-offs (Hz) from the Nyquist frequency ``rate_hz / 2`` halved down to
    ``lowest_hz``: 4000, 2000, ..., 31.25 for 8 kHz."""
    if not rate_hz > 0 or not 0 < lowest_hz <= rate_hz / 2:
        raise ValueError(f"need rate_hz > 0 and 0 < lowest_hz <= rate_hz / 2, got "
                         f"rate_hz={rate_hz}, lowest_hz={lowest_hz}")
    steps = [rate_hz / 2]
    while steps[-1] / 2 >= lowest_hz * (1 - 1e-9):
        steps.append(steps[-1] / 2)
    return steps


def limit_bandwidth(x: np.ndarray, rate_hz: float, cutoff_hz: float, *,
                    resample: bool = True) -> tuple[np.ndarray, float]:
    """(n, c) samples at ``rate_hz`` -> (m, c) float64 band-limited to ``cutoff_hz``, and
    their rate (Hz): ``2 x cutoff_hz`` when ``resample`` (and lower than ``rate_hz``),
    else ``rate_hz`` with the filter alone. A cut-off at or above the Nyquist frequency
    returns the input unchanged."""
    a = np.asarray(x, dtype=np.float64)
    a = a[:, None] if a.ndim == 1 else a
    if not cutoff_hz > 0:
        raise ValueError(f"`cutoff_hz` (={cutoff_hz}) must be positive")
    nyquist = rate_hz / 2
    if cutoff_hz >= nyquist * (1 - 1e-9):
        return a.copy(), float(rate_hz)
    if a.shape[0] < 64:
        raise ValueError(f"`x` has {a.shape[0]} samples; the anti-alias filter needs >= 64")
    sos = _signal.butter(8, cutoff_hz / nyquist, btype="low", output="sos")
    y = _signal.sosfiltfilt(sos, a, axis=0)
    if not resample:
        return y, float(rate_hz)
    ratio = Fraction(2 * cutoff_hz / rate_hz).limit_denominator(1000)
    y = _signal.resample_poly(y, ratio.numerator, ratio.denominator, axis=0)
    return y, float(rate_hz * ratio)
