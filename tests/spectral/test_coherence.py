"""`spectral._coherence`: Welch cross-spectra, L/E/Gamma (paper 004, eqs. 4-7), the complex
coherence (eq. 11) and the group square coherence G2 (eq. 34) on cases with known answers:
scipy's own csd and coherence, filtered copies of one source (G2 = 1, Gamma = 1 once the
sequential-sampling delays are undone), independent noise (Gamma ~ 1 / N, G2 at its noise
floor), equicorrelated and rank-one matrices whose eigenvalues are known in closed form.

The vectorised eigenvalue path against LAPACK is in ``test_g2_vectorised.py``."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import signal

from tactile_cli.spectral import (
    band_sums,
    coherence_matrix,
    cross_spectral_matrix,
    g2_noise_floor,
    group_square_coherence,
    group_square_coherence_bins,
    group_square_coherence_windows,
    local_ensemble_power,
    power_ratio,
    segment_spectra,
    welch_segment_count,
)

RATE = 1000.0


def _tones(t_s: np.ndarray, seed: int = 0, n_tones: int = 60) -> np.ndarray:
    """A broadband source that can be sampled at any instant: ``n_tones`` cosines of
    random frequency (5-450 Hz), amplitude and phase, evaluated at ``t_s`` (any shape)."""
    rng = np.random.default_rng(seed)
    f = rng.uniform(5.0, 450.0, n_tones)
    a = rng.uniform(0.5, 1.0, n_tones)
    ph = rng.uniform(0, 2 * np.pi, n_tones)
    return (a * np.cos(2 * np.pi * f * t_s[..., None] + ph)).sum(axis=-1)


def _sequential(n_samples: int, delays_s: np.ndarray, seed: int = 0) -> np.ndarray:
    """(n_samples, N): one source, channel i sampled ``delays_s[i]`` after each tick."""
    t = np.arange(n_samples)[:, None] / RATE + delays_s[None, :]
    return _tones(t, seed)


# -- Welch segments --------------------------------------------------------------------------
@pytest.mark.parametrize(("n", "nperseg", "noverlap", "count"), [
    (1024, 256, 128, 7), (256, 256, 0, 1), (1000, 200, 50, 6), (1023, 256, 128, 6),
    (300, 64, 63, 237)])
def test_welch_segment_count(n, nperseg, noverlap, count):
    assert welch_segment_count(n, nperseg, noverlap) == count
    # every counted segment fits, one more would not
    step = nperseg - noverlap
    assert (count - 1) * step + nperseg <= n < count * step + nperseg


@pytest.mark.parametrize(("args", "message"), [
    ((100, 1, 0), r"^`nperseg` \(=1\) must be >= 2$"),
    ((100, 16, 16), r"^`noverlap` \(=16\) must be >= 0 and below `nperseg` \(=16\)$"),
    ((100, 16, -1), r"^`noverlap` \(=-1\) must be >= 0 and below `nperseg` \(=16\)$"),
    ((100, 128, 64), r"^windows of 100 samples are shorter than `nperseg` \(=128\)$"),
])
def test_welch_segment_count_errors(args, message):
    with pytest.raises(ValueError, match=message):
        welch_segment_count(*args)


def test_segment_spectra_give_scipys_csd():
    rng = np.random.default_rng(1)
    x = rng.standard_normal((1024, 3)) + 2.0
    f, spectra = segment_spectra(x, RATE)
    assert spectra.shape == (7, 129, 3) and spectra.dtype == np.complex128
    np.testing.assert_array_equal(f, np.fft.rfftfreq(256, 1 / RATE))
    csd01 = (spectra[..., 0].conj() * spectra[..., 1]).mean(axis=0)
    np.testing.assert_allclose(csd01, signal.csd(x[:, 0], x[:, 1], fs=RATE)[1],
                               rtol=1e-10, atol=1e-14)
    # each segment's mean is removed: an offset per channel changes nothing
    _, shifted = segment_spectra(x + np.array([5.0, -3.0, 1e3]), RATE)
    np.testing.assert_allclose(shifted, spectra, atol=1e-9)


def test_segment_spectra_batch_axes_and_errors():
    rng = np.random.default_rng(2)
    x = rng.standard_normal((2, 3, 300, 4))
    _, batch = segment_spectra(x, RATE, nperseg=64, noverlap=16)
    assert batch.shape == (2, 3, 5, 33, 4)
    _, one = segment_spectra(x[1, 2], RATE, nperseg=64, noverlap=16)
    np.testing.assert_allclose(batch[1, 2], one, rtol=1e-12, atol=1e-15)
    with pytest.raises(ValueError, match=r"^`x` must be \(\.\.\., n_samples, n_channels\), "
                                         r"got shape \(300,\)$"):
        segment_spectra(x[0, 0, :, 0], RATE)
    with pytest.raises(ValueError, match=r"^`rate_hz` \(=-1.0\) must be positive$"):
        segment_spectra(x, -1.0)
    with pytest.raises(ValueError, match=r"^windows of 300 samples are shorter than "
                                         r"`nperseg` \(=512\)$"):
        segment_spectra(x, RATE, nperseg=512)


def test_cross_spectral_matrix_is_scipys_csd_of_every_pair():
    rng = np.random.default_rng(3)
    x = rng.standard_normal((2, 900, 3))
    x[..., 2] += x[..., 0]
    f, csd, n_seg = cross_spectral_matrix(x, RATE, nperseg=128, noverlap=32)
    assert csd.shape == (2, 65, 3, 3) and n_seg == welch_segment_count(900, 128, 32) == 9
    for w in range(2):
        for i in range(3):
            for j in range(3):
                fs, want = signal.csd(x[w, :, i], x[w, :, j], fs=RATE, nperseg=128,
                                      noverlap=32)
                np.testing.assert_allclose(csd[w, :, i, j], want, rtol=1e-10, atol=1e-14)
    np.testing.assert_array_equal(f, fs)
    np.testing.assert_allclose(csd, np.swapaxes(csd.conj(), -1, -2), atol=0)   # Hermitian
    _, psd = signal.welch(x, fs=RATE, nperseg=128, noverlap=32, axis=1)     # (2, 65, 3)
    np.testing.assert_allclose(np.einsum("...kii->...ki", csd).real, psd, rtol=1e-10)


# -- band sums --------------------------------------------------------------------------------
def test_band_sums_equal_direct_sums_along_any_axis():
    rng = np.random.default_rng(4)
    v = rng.standard_normal((3, 10, 2))
    lo, hi = np.array([0, 2, 5, 9, 3]), np.array([9, 2, 7, 9, 4])
    got = band_sums(v, lo, hi, axis=1)
    assert got.shape == (3, 5, 2)
    for b, (a, z) in enumerate(zip(lo, hi, strict=True)):
        np.testing.assert_allclose(got[:, b], v[:, a:z + 1].sum(axis=1), rtol=1e-12,
                                   atol=1e-12)
    # the default: the bin axis third from the end (CSD matrices (..., bins, N, N))
    m = rng.standard_normal((4, 10, 2, 2))
    np.testing.assert_allclose(band_sums(m, lo, hi), band_sums(m, lo, hi, axis=1))
    assert band_sums(m, np.zeros(0, int), np.zeros(0, int)).shape == (4, 0, 2, 2)


@pytest.mark.parametrize(("lo", "hi", "message"), [
    ([0, 1], [2], r"^`lo_bin` and `hi_bin` must be 1-D and of one length$"),
    ([[0]], [[1]], r"^`lo_bin` and `hi_bin` must be 1-D and of one length$"),
    ([0], [10], r"^bands must satisfy 0 <= lo_bin <= hi_bin < 10$"),
    ([-1], [3], r"^bands must satisfy 0 <= lo_bin <= hi_bin < 10$"),
    ([4], [3], r"^bands must satisfy 0 <= lo_bin <= hi_bin < 10$"),
])
def test_band_sums_errors(lo, hi, message):
    with pytest.raises(ValueError, match=message):
        band_sums(np.zeros((10, 3)), np.array(lo), np.array(hi), axis=0)


# -- L, E and Gamma (eqs. 4-7) ------------------------------------------------------------------
def test_local_and_ensemble_power_are_eqs_4_and_7():
    # straight from the segments: L = sum_k sum_i |p_i(k)|^2, E = sum_k |sum_i p_i(k)
    # exp(-2 pi j f_k delta_i)|^2 (segment-averaged), over the contact taxels
    rng = np.random.default_rng(5)
    x = rng.standard_normal((1024, 4)) + rng.standard_normal((1024, 1))
    delays = np.array([0.0, 0.25, 0.5, 0.75]) / RATE
    contact = np.array([True, True, False, True])
    f, p = segment_spectra(x, RATE)
    _, csd, _ = cross_spectral_matrix(x, RATE)
    lo, hi = np.array([1, 10, 40]), np.array([128, 20, 40])
    local, ens = local_ensemble_power(csd, f, lo, hi, delays_s=delays, contact=contact)
    pc = p[..., contact] * np.exp(-2j * np.pi * f[:, None] * delays[contact])
    for b in range(3):
        k = slice(lo[b], hi[b] + 1)
        np.testing.assert_allclose(local[b], (np.abs(pc[:, k]) ** 2).mean(axis=0).sum(),
                                   rtol=1e-12)
        np.testing.assert_allclose(ens[b], (np.abs(pc[:, k].sum(axis=-1)) ** 2)
                                   .mean(axis=0).sum(), rtol=1e-12)


def test_gamma_is_one_for_copies_and_one_over_n_for_independent_noise():
    rng = np.random.default_rng(6)
    n_ch = 5
    common = np.repeat(rng.standard_normal((4096, 1)), n_ch, axis=1) * [1, 2, 3, 4, 5]
    noise = rng.standard_normal((4096, n_ch))
    lo, hi = np.array([1, 30]), np.array([128, 60])

    def gamma(x: np.ndarray) -> np.ndarray:
        f, csd, _ = cross_spectral_matrix(x, RATE)
        return power_ratio(*local_ensemble_power(csd, f, lo, hi), n_ch)

    np.testing.assert_allclose(gamma(common[:, :1] * np.ones(n_ch)), 1.0, rtol=1e-12)
    # copies at gains g_i: Gamma = (sum g)^2 / (N sum g^2) = 15^2 / (5 * 55) (Cauchy-Schwarz)
    np.testing.assert_allclose(gamma(common), 225 / 275, rtol=1e-12)
    np.testing.assert_allclose(gamma(noise), 1 / n_ch, atol=0.03)


def test_sequential_sampling_delays_are_undone():
    # one source, 8 taxels sampled one after another within each 1 ms tick: the relative
    # phases cancel part of the ensemble power; eq. 7's advance restores Gamma = 1
    delays = np.arange(8) / 8 / RATE
    x = _sequential(4096, delays)
    f, csd, _ = cross_spectral_matrix(x, RATE)
    lo, hi = np.array([77, 25]), np.array([115, 51])          # 300-450 Hz, 100-200 Hz
    local, ens = local_ensemble_power(csd, f, lo, hi)
    plain = power_ratio(local, ens, 8)
    local, ens = local_ensemble_power(csd, f, lo, hi, delays_s=delays)
    corrected = power_ratio(local, ens, 8)
    assert (corrected > 0.995).all()
    assert plain[0] < 0.85 and plain[1] < corrected[1]
    # G2 per bin does not care: a delay is a constant phase per channel there (paper 004,
    # sec. 5.2), in every bin of the bands that carries the source's power
    g2 = group_square_coherence(csd)
    power = np.einsum("kii->k", csd).real
    bins = np.r_[25:52, 77:116]
    assert g2[bins][power[bins] > 1e-2 * power.max()].min() > 0.999


def test_contact_limits_l_and_e_to_the_taxels_in_contact():
    rng = np.random.default_rng(7)
    source = rng.standard_normal((2048, 1))
    x = np.concatenate([np.repeat(source, 3, axis=1), 10 * rng.standard_normal((2048, 2))],
                       axis=1)
    f, csd, _ = cross_spectral_matrix(x, RATE)
    contact = np.array([[True, True, True, False, False], [True] * 5])
    local, ens = local_ensemble_power(csd, f, np.array([1]), np.array([128]),
                                      contact=contact)
    assert local.shape == (2, 1)
    power = np.einsum("kii->i", csd[1:]).real                # the band: bins 1-128
    np.testing.assert_allclose(local[:, 0], [power[:3].sum(), power.sum()], rtol=1e-12)
    gamma = power_ratio(local, ens, contact.sum(axis=-1)[:, None])
    np.testing.assert_allclose(gamma[0], 1.0, rtol=1e-12)
    assert gamma[1, 0] < 0.5


def test_local_ensemble_power_rejects_a_delay_per_wrong_channel():
    csd = np.zeros((5, 3, 3), dtype=complex)
    with pytest.raises(ValueError, match=r"^`delays_s` must hold one delay per channel "
                                         r"\(3\), got shape \(2,\)$"):
        local_ensemble_power(csd, np.arange(5.0), np.array([0]), np.array([4]),
                             delays_s=np.zeros(2))


def test_power_ratio_of_known_powers():
    local = np.array([2.0, 4.0, 0.0, 1.0, 3.0])
    ensemble = np.array([6.0, 4.0, 0.0, 3.0 * (1 + 1e-15), 0.0])
    got = power_ratio(local, ensemble, 3)
    np.testing.assert_allclose(got[[0, 1, 4]], [1.0, 1 / 3, 0.0], rtol=1e-15)
    assert np.isnan(got[2])                                    # no local power: NaN
    assert got[3] == 1.0                                       # rounding clipped to 1
    np.testing.assert_allclose(power_ratio(local[:2], ensemble[:2], np.array([3, 1])),
                               [1.0, 1.0])


# -- coherence and G2 (eqs. 11 and 34) ----------------------------------------------------------
def test_coherence_matrix_normalises_and_zeroes_silent_channels():
    rng = np.random.default_rng(8)
    x = rng.standard_normal((1024, 3))
    x[:, 1] = 3 * x[:, 0] + 0.5 * x[:, 1]
    x[:, 2] = 0.0
    _, csd, _ = cross_spectral_matrix(x, RATE)
    c = coherence_matrix(csd)
    np.testing.assert_allclose(np.einsum("kii->ki", c)[:, :2][1:], 1.0, rtol=1e-12)
    assert (c[:, 2, :] == 0).all() and (c[:, :, 2] == 0).all()
    assert np.abs(c).max() <= 1 + 1e-12
    # |C_01|^2 is scipy's magnitude-squared coherence
    _, msc = signal.coherence(x[:, 0], x[:, 1], fs=RATE)
    np.testing.assert_allclose(np.abs(c[1:, 0, 1]) ** 2, msc[1:], rtol=1e-9)


def test_g2_of_two_channels_is_their_magnitude_squared_coherence():
    # paper 004, appendix: for N = 2, G2 = |C_12|^2
    rng = np.random.default_rng(9)
    a = rng.standard_normal(4096)
    b = signal.lfilter([1, 0.5], [1, -0.3], a) + rng.standard_normal(4096)
    _, csd, _ = cross_spectral_matrix(np.stack([a, b], axis=1), RATE)
    _, msc = signal.coherence(a, b, fs=RATE)
    np.testing.assert_allclose(group_square_coherence(csd)[1:], msc[1:], rtol=1e-9)


@pytest.mark.parametrize("rho", [0.0, 0.3, 0.9, 1.0])
def test_g2_of_an_equicorrelated_matrix_is_rho_squared(rho):
    # C = (1 - rho) I + rho 1 1^T: lambda1 = 1 + (N - 1) rho, so G2 = rho^2; scaling the
    # channels (S = D C D) changes nothing
    n = 6
    c = (1 - rho) * np.eye(n) + rho * np.ones((n, n))
    d = np.diag(np.arange(1.0, n + 1))
    assert group_square_coherence((d @ c @ d)[None]) == pytest.approx([rho ** 2], abs=1e-12)


def test_g2_is_one_for_rank_one_and_zero_for_diagonal_matrices():
    rng = np.random.default_rng(10)
    v = rng.standard_normal((4, 7)) + 1j * rng.standard_normal((4, 7))
    rank1 = v[:, :, None] * v.conj()[:, None, :]
    np.testing.assert_allclose(group_square_coherence(rank1), 1.0, rtol=1e-12)
    diag = np.einsum("bi,ij->bij", rng.uniform(0.1, 5.0, (4, 7)), np.eye(7))
    np.testing.assert_allclose(group_square_coherence(diag), 0.0, atol=1e-24)
    with pytest.raises(ValueError, match=r"^group coherence needs at least 2 channels, "
                                         r"got 1$"):
        group_square_coherence(np.ones((3, 1, 1)))


def test_g2_of_filtered_copies_is_one_and_of_noise_near_its_floor():
    # the same source through six different filters (plus 0.1 % noise): G2 ~ 1 in
    # every bin that carries signal; independent channels: the per-bin mean G2 is the
    # noise floor of 6 channels and 8 segments (no overlap: independent averages)
    rng = np.random.default_rng(11)
    n_ch, nperseg = 6, 64
    s = rng.standard_normal((40, 512))
    copies = np.stack([signal.lfilter([1, 0.1 * k], [1, -0.1 * k], s, axis=1)
                       for k in range(n_ch)], axis=-1)
    copies += 1e-3 * rng.standard_normal(copies.shape)
    _, g_copies = group_square_coherence_windows(copies, RATE, nperseg=nperseg, noverlap=0)
    assert g_copies[:, 1:].min() > 0.99
    noise = rng.standard_normal((40, 512, n_ch))
    f, g_noise = group_square_coherence_windows(noise, RATE, nperseg=nperseg, noverlap=0)
    assert g_noise.shape == (40, len(f)) == (40, 33)
    floor = g2_noise_floor(n_ch, 8, trials=4000)
    np.testing.assert_allclose(g_noise[:, 1:-1].mean(), floor, rtol=0.05)
    assert g_noise[:, 1:-1].mean() < 0.1


def test_group_square_coherence_bins_equals_g2_of_the_csd():
    rng = np.random.default_rng(12)
    for n_seg, n_ch in ((3, 7), (9, 4)):            # segment Gram / channel Gram
        x = rng.standard_normal((2, 128 * (n_seg + 1) // 2, n_ch)) + \
            rng.standard_normal((2, 128 * (n_seg + 1) // 2, 1))
        _, spectra = segment_spectra(x, RATE, nperseg=128)
        assert spectra.shape[-3] == n_seg
        _, csd, _ = cross_spectral_matrix(x, RATE, nperseg=128)
        want = group_square_coherence(csd)
        for method in ("auto", "eigvalsh", "tridiagonal"):
            got = group_square_coherence_bins(spectra, method=method)
            assert got.shape == (2, 65)
            np.testing.assert_allclose(got, want, rtol=0, atol=1e-10)
    with pytest.raises(ValueError, match=r"^`method` must be 'auto', 'eigvalsh' or "
                                         r"'tridiagonal', got 'qr'$"):
        group_square_coherence_bins(spectra, method="qr")


def test_group_square_coherence_windows_equals_the_reference_path():
    rng = np.random.default_rng(13)
    x = rng.standard_normal((5, 700, 4)) + rng.standard_normal((5, 700, 1))
    f, g = group_square_coherence_windows(x, RATE, nperseg=100, noverlap=40, chunk=2)
    f_ref, spectra = segment_spectra(x, RATE, nperseg=100, noverlap=40)
    np.testing.assert_array_equal(f, f_ref)
    np.testing.assert_allclose(g, group_square_coherence_bins(spectra), rtol=0, atol=1e-10)
    f, empty = group_square_coherence_windows(np.zeros((0, 700, 4)), RATE, nperseg=100)
    assert empty.shape == (0, 51)


@pytest.mark.parametrize(("shape", "kwargs", "message"), [
    ((700, 4), {}, r"^`x` must be \(n_windows, n_samples, n_channels\), got shape "
                   r"\(700, 4\)$"),
    ((2, 700, 4), {"chunk": 0}, r"^`chunk` \(=0\) and `workers` \(=1\) must be >= 1$"),
    ((2, 700, 4), {"workers": 0}, r"^`chunk` \(=128\) and `workers` \(=0\) must be >= 1$"),
    ((2, 700, 4), {"rate_hz": 0.0}, r"^`rate_hz` \(=0.0\) must be positive$"),
    ((2, 100, 4), {}, r"^windows of 100 samples are shorter than `nperseg` \(=256\)$"),
    ((2, 700, 1), {}, r"^group coherence needs at least 2 channels, got 1$"),
    ((2, 700, 4), {"method": "qr"}, r"^`method` must be 'auto', 'eigvalsh' or "
                                    r"'tridiagonal', got 'qr'$"),
])
def test_group_square_coherence_windows_errors(shape, kwargs, message):
    rate = kwargs.pop("rate_hz", RATE)
    with pytest.raises(ValueError, match=message):
        group_square_coherence_windows(np.zeros(shape), rate, **kwargs)


# -- the noise floor --------------------------------------------------------------------------
def test_g2_noise_floor_known_values_and_trend():
    # one average: every CSD matrix has rank one, so G2 = 1 exactly
    assert g2_noise_floor(5, 1) == pytest.approx(1.0, abs=1e-12)
    floors = [g2_noise_floor(6, n) for n in (3, 6, 12, 48, 400)]
    assert all(a > b for a, b in zip(floors, floors[1:], strict=False))
    assert floors[-1] < 0.01
    # two channels: G2 is the squared coherence estimate, whose mean for independent
    # channels over n averages is 1 / n
    np.testing.assert_allclose(g2_noise_floor(2, 10, trials=20000), 0.1, rtol=0.03)
    # seeded: the same value twice, another seed another estimate
    assert g2_noise_floor(6, 8, seed=3) == g2_noise_floor(6, 8, seed=3)
    assert g2_noise_floor(6, 8, seed=3) != g2_noise_floor(6, 8, seed=4)


@pytest.mark.parametrize(("n_channels", "n_averages"), [(1, 5), (4, 0)])
def test_g2_noise_floor_errors(n_channels, n_averages):
    with pytest.raises(ValueError, match=r"^`n_channels` must be >= 2 and `n_averages` "
                                         r">= 1$"):
        g2_noise_floor(n_channels, n_averages)
