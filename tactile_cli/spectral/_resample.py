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

#: The resampling ratio ``2 x cut-off / rate`` is the nearest fraction with at most this
#: denominator (:func:`limit_bandwidth`), so a cut-off below ``rate / (2 x this)`` has none.
MAX_RATIO_DENOMINATOR = 1000


def lowest_cutoff_hz(rate_hz: float) -> float:
    """The lowest cut-off :func:`limit_bandwidth` takes for a stream of ``rate_hz``."""
    return rate_hz / (2 * MAX_RATIO_DENOMINATOR)


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
    if not (np.isfinite(cutoff_hz) and cutoff_hz > 0):
        raise ValueError(f"`cutoff_hz` (={cutoff_hz}) must be positive")
    nyquist = rate_hz / 2
    if cutoff_hz >= nyquist * (1 - 1e-9):
        return a.copy(), float(rate_hz)
    if cutoff_hz < lowest_cutoff_hz(rate_hz):
        raise ValueError(f"`cutoff_hz` (={cutoff_hz:g}) is below {lowest_cutoff_hz(rate_hz):g} "
                         f"Hz, the lowest cut-off of a {rate_hz:g} Hz stream (its resampling "
                         f"ratio 2 x cut-off / rate is at least 1/{MAX_RATIO_DENOMINATOR})")
    if a.shape[0] < 64:
        raise ValueError(f"`x` has {a.shape[0]} samples; the anti-alias filter needs >= 64")
    sos = _signal.butter(8, cutoff_hz / nyquist, btype="low", output="sos")
    y = _signal.sosfiltfilt(sos, a, axis=0)
    if not resample:
        return y, float(rate_hz)
    ratio = Fraction(2 * cutoff_hz / rate_hz).limit_denominator(MAX_RATIO_DENOMINATOR)
    y = _signal.resample_poly(y, ratio.numerator, ratio.denominator, axis=0)
    return y, float(rate_hz * ratio)
