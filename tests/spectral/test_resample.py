"""`spectral._resample`: paper 001's bandwidth study (sec. 6.4): cut-offs halved from the
4 kHz Nyquist limit of 8 kHz recordings down to 31.25 Hz, and one step of it (zero-phase
anti-alias low-pass, then resampling to twice the cut-off): a tone below the cut-off comes
through with its amplitude and phase, one above it is gone, not folded back."""

from __future__ import annotations

import numpy as np
import pytest

from tactile_cli.spectral import band_power, bandwidth_steps, limit_bandwidth, lowest_cutoff_hz

RATE = 8000.0


def _tone(f_hz: float, n: int, rate: float = RATE, amplitude: float = 1.0,
          phase: float = 0.0) -> np.ndarray:
    return amplitude * np.sin(2 * np.pi * f_hz * np.arange(n) / rate + phase)


def test_bandwidth_steps_are_the_papers():
    assert bandwidth_steps(RATE) == [4000.0, 2000.0, 1000.0, 500.0, 250.0, 125.0, 62.5,
                                     31.25]
    assert bandwidth_steps(RATE, 100.0) == [4000.0, 2000.0, 1000.0, 500.0, 250.0, 125.0]
    assert bandwidth_steps(RATE, 4000.0) == [4000.0]
    assert bandwidth_steps(1000.0, 62.5) == [500.0, 250.0, 125.0, 62.5]


@pytest.mark.parametrize(("rate", "lowest"), [(0.0, 1.0), (-8.0, 1.0), (RATE, 0.0),
                                              (RATE, 4000.5), (RATE, float("nan"))])
def test_bandwidth_steps_errors(rate, lowest):
    with pytest.raises(ValueError, match=r"^need rate_hz > 0 and 0 < lowest_hz <= rate_hz / 2"
                                         rf", got rate_hz={rate}, lowest_hz={lowest}$"):
        bandwidth_steps(rate, lowest)


def test_limit_bandwidth_keeps_a_tone_below_and_removes_one_above():
    # 1 s at 8 kHz: amplitude 1 at 100 Hz, amplitude 1 at 1300 Hz; cut-off 500 Hz ->
    # 1 kHz rate, where an unfiltered 1300 Hz tone would fold back onto 300 Hz
    n = 8000
    x = np.stack([_tone(100.0, n) + _tone(1300.0, n, phase=0.4), _tone(1300.0, n)], axis=1)
    y, rate = limit_bandwidth(x, RATE, 500.0)
    assert rate == 1000.0 and y.shape == (1000, 2) and y.dtype == np.float64
    inner = slice(100, 900)                              # away from the filters' edges
    t = np.arange(1000)[inner] / rate
    np.testing.assert_allclose(y[inner, 0], np.sin(2 * np.pi * 100.0 * t), atol=2e-3)
    assert np.abs(y[inner, 1]).max() < 1e-3
    p = band_power(y[inner], rate, [(90.0, 110.0), (290.0, 310.0)], nperseg=200)
    np.testing.assert_allclose(p[0, 0], 0.5, rtol=0.01)           # A^2 / 2 kept
    assert p[1].max() < 1e-6                                     # no alias at 300 Hz


def test_limit_bandwidth_without_resampling_keeps_the_rate():
    n = 4000
    x = _tone(200.0, n) + _tone(3000.0, n)
    y, rate = limit_bandwidth(x, RATE, 1000.0, resample=False)
    assert rate == RATE and y.shape == (n, 1)
    inner = slice(400, n - 400)
    np.testing.assert_allclose(y[inner, 0], _tone(200.0, n)[inner], atol=1e-6)


def test_limit_bandwidth_rational_ratio():
    # 2.5 kHz to a 1 kHz cut-off: resampled by 4/5 to 2 kHz
    n = 2500
    y, rate = limit_bandwidth(_tone(150.0, n, rate=2500.0), 2500.0, 1000.0)
    assert rate == 2000.0 and y.shape == (2000, 1)
    t = np.arange(2000)[200:1800] / 2000.0
    np.testing.assert_allclose(y[200:1800, 0], np.sin(2 * np.pi * 150.0 * t), atol=2e-3)


def test_limit_bandwidth_at_or_above_nyquist_returns_a_copy():
    x = np.random.default_rng(0).standard_normal((10, 3))     # too short to filter: unused
    for cutoff in (4000.0, 5000.0):
        y, rate = limit_bandwidth(x, RATE, cutoff)
        assert rate == RATE
        np.testing.assert_array_equal(y, x)
        y[0, 0] = 99.0
        assert x[0, 0] != 99.0                                  # a copy, not a view


def test_limit_bandwidth_errors():
    with pytest.raises(ValueError, match=r"^`cutoff_hz` \(=0.0\) must be positive$"):
        limit_bandwidth(np.zeros((100, 1)), RATE, 0.0)
    with pytest.raises(ValueError, match=r"^`x` has 63 samples; the anti-alias filter "
                                         r"needs >= 64$"):
        limit_bandwidth(np.zeros((63, 2)), RATE, 500.0)


def test_lowest_cutoff_is_the_reach_of_the_resampling():
    # 2 x cut-off / rate must be at least 1/1000: 2500 Hz reaches down to 1.25 Hz
    assert lowest_cutoff_hz(2500.0) == 1.25
    x = np.random.default_rng(0).standard_normal((4096, 1))
    y, rate = limit_bandwidth(x, 2500.0, lowest_cutoff_hz(2500.0))
    assert rate == pytest.approx(2.5) and y.shape == (5, 1)
    with pytest.raises(ValueError, match=r"below 1.25 Hz, the lowest cut-off"):
        limit_bandwidth(x, 2500.0, 1.2)
