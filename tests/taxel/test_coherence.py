"""Spectral features of paper 004 (tactile_cli.spectral): the appendix-A properties of the
group square coherence, the power ratio and the vectorised paths against scipy."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import signal

from tactile_cli.spectral import (
    band_sums,
    cross_spectral_matrix,
    g2_noise_floor,
    group_square_coherence,
    group_square_coherence_bins,
    local_ensemble_power,
    power_ratio,
    segment_spectra,
    welch_segment_count,
)

RATE_HZ = 1000.0


def _g2(x: np.ndarray, nperseg: int = 128) -> np.ndarray:
    _, csd, _ = cross_spectral_matrix(x, RATE_HZ, nperseg=nperseg)
    return group_square_coherence(csd)


def test_cross_spectral_matrix_matches_scipy_csd():
    x = np.random.default_rng(0).standard_normal((1024, 4))
    f, csd, n_seg = cross_spectral_matrix(x, RATE_HZ, nperseg=256, noverlap=128)
    assert n_seg == 7 == welch_segment_count(1024, 256, 128)
    for i, j in ((0, 1), (2, 3), (1, 1)):
        f_ref, ref = signal.csd(x[:, i], x[:, j], fs=RATE_HZ, nperseg=256, noverlap=128)
        np.testing.assert_allclose(f, f_ref)
        np.testing.assert_allclose(csd[:, i, j], ref, rtol=1e-10, atol=1e-15)


def test_g2_equals_pairwise_msc_for_two_channels():
    rng = np.random.default_rng(1)
    common = rng.standard_normal(4096)
    x = np.column_stack([common + 0.7 * rng.standard_normal(4096),
                         np.convolve(common, [0.5, 0.3, 0.2], "same")
                         + rng.standard_normal(4096)])
    _, msc = signal.coherence(x[:, 0], x[:, 1], fs=RATE_HZ, nperseg=128)
    np.testing.assert_allclose(_g2(x), msc, atol=1e-10)


def test_g2_is_one_for_filtered_copies_of_one_source():
    rng = np.random.default_rng(2)
    source = rng.standard_normal(8192)
    filters = [signal.butter(2, c, fs=RATE_HZ) for c in (100, 200, 300, 400)]
    x = np.column_stack([source] + [signal.lfilter(b, a, source) for b, a in filters]
                        + [np.roll(source, 3)])
    g2 = _g2(x)[1:40]   # below every filter's corner: no bin without power
    assert g2.min() > 0.99


def test_g2_is_near_zero_for_independent_noise():
    x = np.random.default_rng(3).standard_normal((32768, 8))
    g2 = _g2(x)
    assert g2.mean() < 0.01
    assert 0.0 <= g2.min() and g2.max() <= 1.0


@pytest.mark.parametrize("seed", range(5))
def test_g2_and_gamma_lie_in_unit_interval(seed):
    rng = np.random.default_rng(seed)
    x = rng.standard_normal((2048, 6)) * rng.uniform(0.01, 100, 6) \
        + rng.uniform(0, 3) * rng.standard_normal((2048, 1))
    f, csd, _ = cross_spectral_matrix(x, RATE_HZ, nperseg=64)
    g2 = group_square_coherence(csd)
    assert ((g2 >= 0) & (g2 <= 1)).all()
    lo = np.arange(1, len(f))
    local, ensemble = local_ensemble_power(csd, f, lo, lo, delays_s=rng.uniform(0, 1e-3, 6))
    gamma = power_ratio(local, ensemble, 6)
    assert ((gamma >= 0) & (gamma <= 1)).all()


def test_gamma_extremes_common_and_independent():
    rng = np.random.default_rng(4)
    common = np.repeat(rng.standard_normal((4096, 1)), 5, axis=1)
    indep = rng.standard_normal((4096, 5))
    for x, lo_hi in ((common, (0.999, 1.0)), (indep, (0.15, 0.25))):
        f, csd, _ = cross_spectral_matrix(x, RATE_HZ, nperseg=128)
        local, ensemble = local_ensemble_power(csd, f, np.array([1]), np.array([len(f) - 1]))
        gamma = power_ratio(local, ensemble, 5)[0]
        assert lo_hi[0] <= gamma <= lo_hi[1]


def test_bin_path_equals_matrix_path_with_and_without_rank_deficiency():
    rng = np.random.default_rng(5)
    for n_samples, n_ch in ((1024, 20), (4096, 6)):
        x = rng.standard_normal((3, n_samples, n_ch)) + rng.standard_normal((3, n_samples, 1))
        _, spectra = segment_spectra(x, RATE_HZ, nperseg=256, noverlap=128)
        _, csd, _ = cross_spectral_matrix(x, RATE_HZ, nperseg=256, noverlap=128)
        np.testing.assert_allclose(group_square_coherence_bins(spectra),
                                   group_square_coherence(csd), atol=1e-12)


def test_rank_deficient_g2_is_biased_upward():
    few, many = g2_noise_floor(20, 7), g2_noise_floor(20, 140)
    assert few > 0.04 and many < 0.01 and few > 5 * many
    # the paper's timing setting has 7 segments for 20 channels
    assert welch_segment_count(1024, 256, 128) < 20


def test_sequential_sampling_correction_restores_the_ensemble():
    fs, n_ch = 100.0, 10
    delays = np.arange(n_ch) * 0.9e-3
    t = np.arange(4000) / fs
    x = np.column_stack([np.sin(2 * np.pi * 40 * (t + d)) + np.sin(2 * np.pi * 23 * (t + d))
                         for d in delays])
    f, csd, _ = cross_spectral_matrix(x, fs, nperseg=256)
    band = (np.array([1]), np.array([len(f) - 1]))
    raw = power_ratio(*local_ensemble_power(csd, f, *band), n_ch)[0]
    fixed = power_ratio(*local_ensemble_power(csd, f, *band, delays_s=delays), n_ch)[0]
    assert fixed > 0.999 and raw < 0.9


def test_band_sums_equal_explicit_sums():
    v = np.random.default_rng(6).standard_normal((2, 17, 3))
    lo, hi = np.array([0, 3, 5]), np.array([0, 9, 16])
    got = band_sums(v, lo, hi, axis=1)
    want = np.stack([v[:, a:b + 1].sum(axis=1) for a, b in zip(lo, hi, strict=True)], axis=1)
    np.testing.assert_allclose(got, want, atol=1e-12)
    with pytest.raises(ValueError):
        band_sums(v, np.array([4]), np.array([2]), axis=1)


def test_windows_path_equals_per_window_path_on_threads():
    from tactile_cli.spectral import group_square_coherence_windows

    x = np.random.default_rng(7).standard_normal((5, 1024, 20))
    f, g2 = group_square_coherence_windows(x, RATE_HZ, nperseg=256, noverlap=128, chunk=2,
                                           workers=2)
    _, spectra = segment_spectra(x, RATE_HZ, nperseg=256, noverlap=128)
    assert g2.shape == (5, len(f)) == (5, 129)
    np.testing.assert_allclose(g2, group_square_coherence_bins(spectra), rtol=0, atol=1e-12)
    _, one = group_square_coherence_windows(x, RATE_HZ, nperseg=256, noverlap=128, chunk=2)
    np.testing.assert_array_equal(g2, one)                       # threads change nothing
