"""`spectral._band_power`: Welch density, band power and spectral centroid on signals whose
answers are known: a cosine of amplitude A carries power A^2 / 2, all of it in its bin and
the two neighbours when it sits on a bin (periodic Hann), nearly all within a few bins when
it does not."""

from __future__ import annotations

import numpy as np
import pytest

from tactile_cli.spectral import band_power, spectral_centroid, welch_psd

RATE = 1024.0            # with nperseg 256: bins every 4 Hz
N = 4096


def _cos(f_hz: float, amplitude: float = 1.0, phase: float = 0.0, n: int = N) -> np.ndarray:
    return amplitude * np.cos(2 * np.pi * f_hz * np.arange(n) / RATE + phase)


def test_welch_psd_grid_and_peak_of_a_tone():
    f, p = welch_psd(_cos(100.0, 2.0), RATE)
    np.testing.assert_array_equal(f, np.fft.rfftfreq(256, 1 / RATE))
    assert p.shape == (129, 1)                                    # (n,) in -> (m, 1)
    assert f[np.argmax(p[:, 0])] == 100.0
    # periodic Hann, bin-centred: neighbours hold (1/4)^2 ... of the peak's amplitude
    # squared, i.e. a quarter of its density; the rest is rounding
    k = 25
    np.testing.assert_allclose(p[[k - 1, k + 1], 0], p[k, 0] / 4, rtol=1e-9)
    assert np.delete(p[:, 0], [k - 1, k, k + 1]).max() < 1e-20 * p[k, 0] + 1e-25


def test_welch_psd_integrates_to_the_variance_of_white_noise():
    rng = np.random.default_rng(1)
    x = rng.normal(0.0, 1.5, (1 << 16, 2))
    f, p = welch_psd(x, RATE)
    total = p.sum(axis=0) * (f[1] - f[0])
    # 511 half-overlapping segments: the estimate's relative spread is well under 1 %
    np.testing.assert_allclose(total, x.var(axis=0), rtol=0.015)


def test_welch_psd_cuts_the_segment_to_the_signal():
    f, p = welch_psd(np.random.default_rng(2).standard_normal((100, 3)), RATE)
    assert f.shape == (51,) and p.shape == (51, 3)
    np.testing.assert_array_equal(f, np.fft.rfftfreq(100, 1 / RATE))


@pytest.mark.parametrize(("x", "rate", "message"), [
    (np.zeros(1), RATE, r"^`x` must be \(n >= 2,\) or \(n >= 2, c\), got shape \(1,\)$"),
    (np.zeros((4, 2, 2)), RATE,
     r"^`x` must be \(n >= 2,\) or \(n >= 2, c\), got shape \(4, 2, 2\)$"),
    (np.zeros(10), 0.0, r"^`rate_hz` \(=0.0\) must be positive$"),
    (np.zeros(10), float("nan"), r"^`rate_hz` \(=nan\) must be positive$"),
])
def test_welch_psd_errors(x, rate, message):
    with pytest.raises(ValueError, match=message):
        welch_psd(x, rate)


def test_band_power_of_bin_centred_tones_is_a_squared_over_two():
    # channel 0: amplitude 2 at 100 Hz, channel 1: amplitude 0.5 at 300 Hz; each band
    # holds its tone's bin and both neighbours: A^2 / 2 exactly (to rounding)
    x = np.stack([_cos(100.0, 2.0, 0.3), _cos(300.0, 0.5, 1.1)], axis=1)
    p = band_power(x, RATE, [(96.0, 108.0), (296.0, 308.0), (0.0, 512.1)])
    assert p.shape == (3, 2)
    np.testing.assert_allclose(p[0, 0], 2.0, rtol=1e-9)
    np.testing.assert_allclose(p[1, 1], 0.125, rtol=1e-9)
    np.testing.assert_allclose(p[2], [2.0, 0.125], rtol=1e-9)     # the whole spectrum
    assert abs(p[0, 1]) < 1e-18 and abs(p[1, 0]) < 1e-18


def test_band_power_of_an_off_bin_tone_within_the_hann_leakage():
    # 101.37 Hz lies 0.34 bins off the grid: Hann leaks, but its sidelobes fall as the
    # cube of the distance, so +-8 bins hold all but ~1e-5 of the power, and the three
    # bins around the tone still more than 98 % of it
    x = _cos(101.37, 3.0)[:, None]
    wide = band_power(x, RATE, [(101.37 - 32, 101.37 + 32)])[0, 0]
    np.testing.assert_allclose(wide, 4.5, rtol=1e-5)
    narrow = band_power(x, RATE, [(96.0, 108.0)])[0, 0]       # bins 24, 25, 26
    assert 0.98 * 4.5 < narrow < 4.5


def test_band_power_bands_are_half_open_and_may_be_empty():
    x = _cos(100.0)[:, None]
    p = band_power(x, RATE, [(100.0, 104.0), (96.0, 100.0), (101.0, 103.0), (104.0, 108.0)])
    # [100, 104) holds bin 100 only (4/6 of the power), [96, 100) bin 96 (1/6),
    # [101, 103) no bin at all, [104, 108) bin 104 (1/6)
    np.testing.assert_allclose(p[:, 0], [0.5 * 4 / 6, 0.5 / 6, 0.0, 0.5 / 6], rtol=1e-9)
    assert band_power(x, RATE, []).shape == (0, 1)


@pytest.mark.parametrize(("band", "message"), [
    ((5.0, 5.0), r"^band 1 \(=5.0, 5.0\) must satisfy 0 <= lo < hi$"),
    ((-1.0, 5.0), r"^band 1 \(=-1.0, 5.0\) must satisfy 0 <= lo < hi$"),
    ((9.0, 5.0), r"^band 1 \(=9.0, 5.0\) must satisfy 0 <= lo < hi$"),
])
def test_band_power_rejects_bad_bands(band, message):
    with pytest.raises(ValueError, match=message):
        band_power(np.zeros((300, 1)), RATE, [(0.0, 10.0), band])


def test_spectral_centroid_of_two_tones_is_their_power_weighted_mean():
    # bin-centred tones leak symmetrically into their neighbours, so each contributes
    # its own frequency: centroid = (f1 A1^2 + f2 A2^2) / (A1^2 + A2^2)
    x = np.stack([_cos(100.0, 1.0) + _cos(300.0, 2.0, 0.7), _cos(200.0, 1.0)], axis=1)
    c = spectral_centroid(x, RATE)
    np.testing.assert_allclose(c, [(100 * 1 + 300 * 4) / 5, 200.0], rtol=1e-9)


def test_spectral_centroid_above_a_floor_and_without_power():
    x = np.stack([_cos(100.0, 1.0) + _cos(300.0, 2.0), np.zeros(N), np.full(N, 7.0)], axis=1)
    c = spectral_centroid(x, RATE, f_min_hz=200.0)
    assert c[0] == pytest.approx(300.0, rel=1e-9)     # the 100 Hz tone left out
    # silence, and a constant (its mean removed per segment): NaN, no warning
    assert np.isnan(c[1]) and np.isnan(c[2])
