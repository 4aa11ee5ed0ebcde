"""`spectral._array_features`: per-band Gamma and G2 of sensor arrays (paper 004, secs.
3.1-3.2): the band grid of the best-band search, the paper's (f, w) of a band (eq. 4: bins
k = (f - w) / f0 .. (f + w) / f0), G2 of the taxels in contact, single-array features of
copies and of noise, and the fingers' virtual taxels on hand-built spectra."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from tactile_cli.spectral import (
    ArrayFeatures,
    array_features,
    band_centre_width_hz,
    band_grid,
    cross_spectral_matrix,
    finger_ensembles,
    g2_noise_floor,
    group_square_coherence,
    masked_g2,
    multi_finger_g2,
    segment_spectra,
)

RATE = 1000.0


def _random_csd(shape: tuple[int, ...], n: int, rank: int, seed: int) -> np.ndarray:
    """Positive semidefinite Hermitian (*shape, n, n) matrices of the given rank."""
    rng = np.random.default_rng(seed)
    z = rng.standard_normal((*shape, rank, n)) + 1j * rng.standard_normal((*shape, rank, n))
    return np.einsum("...si,...sj->...ij", z.conj(), z)


# -- bands ------------------------------------------------------------------------------------
def test_band_grid_lists_every_narrow_band_without_dc():
    lo, hi = band_grid(5, 2)
    assert lo.tolist() == [1, 1, 2, 2, 3, 3, 4]
    assert hi.tolist() == [1, 2, 2, 3, 3, 4, 4]
    lo, hi = band_grid(9, 100)                      # no limit: every band of bins 1..8
    assert len(lo) == 8 * 9 // 2 and set(zip(lo.tolist(), hi.tolist(), strict=True)) == {
        (a, b) for a in range(1, 9) for b in range(a, 9)}
    lo, hi = band_grid(9, 1)
    assert lo.tolist() == hi.tolist() == list(range(1, 9))
    assert band_grid(1, 3)[0].shape == (0,)


def test_band_centre_and_half_width_follow_eq_4():
    # bins every 10 Hz; bins 2..4 are 20, 30, 40 Hz: centre f = 30, and eq. 4 runs over
    # k = (f - w) / f0 .. (f + w) / f0 = 2 .. 4, so w = 10
    f = np.arange(0.0, 500.0, 10.0)
    lo, hi = np.array([2, 7, 1, 3]), np.array([4, 7, 2, 10])
    centre, width = band_centre_width_hz(f, lo, hi)
    np.testing.assert_allclose(centre, [30.0, 70.0, 15.0, 65.0])
    np.testing.assert_allclose(width, [10.0, 0.0, 5.0, 35.0])
    np.testing.assert_allclose((centre - width) / 10.0, lo)
    np.testing.assert_allclose((centre + width) / 10.0, hi)


# -- masked G2 --------------------------------------------------------------------------------
def test_masked_g2_is_g2_of_the_unmasked_channels():
    csd = _random_csd((6,), 7, rank=3, seed=0)
    mask = np.array([True, False, True, True, False, True, False])
    got = masked_g2(csd, mask)
    assert got.shape == (6,)
    np.testing.assert_allclose(got, group_square_coherence(csd[:, mask][:, :, mask]),
                               rtol=1e-10, atol=1e-14)
    np.testing.assert_allclose(masked_g2(csd, np.ones(7, bool)),
                               group_square_coherence(csd), rtol=1e-10, atol=1e-14)


def test_masked_g2_with_a_mask_per_matrix():
    csd = _random_csd((3, 4), 5, rank=2, seed=1)
    rng = np.random.default_rng(2)
    mask = rng.random((3, 4, 5)) < 0.7
    mask[..., :2] = True                                 # at least two channels each
    got = masked_g2(csd, mask)
    assert got.shape == (3, 4)
    for i in range(3):
        for j in range(4):
            m = mask[i, j]
            want = group_square_coherence(csd[i, j][np.ix_(m, m)][None])[0]
            assert got[i, j] == pytest.approx(want, rel=1e-10, abs=1e-14)
    # a mask for the leading axis only, broadcast over the second
    per_row = masked_g2(csd, mask[:, :1])
    for j in range(4):
        np.testing.assert_allclose(per_row[:, j], masked_g2(csd[:, j], mask[:, 0]))


def test_masked_g2_is_nan_without_two_channels():
    csd = _random_csd((3,), 4, rank=4, seed=3)
    mask = np.array([[False] * 4, [False, True, False, False], [True, True, False, False]])
    got = masked_g2(csd, mask)
    assert np.isnan(got[0]) and np.isnan(got[1]) and np.isfinite(got[2])


# -- one array ---------------------------------------------------------------------------------
def test_array_features_of_copies_and_of_noise():
    rng = np.random.default_rng(4)
    n_ch, n, nperseg = 6, 2048, 128
    source = rng.standard_normal((3, n, 1))
    copies = source * np.ones(n_ch)
    noise = rng.standard_normal((3, n, n_ch))
    lo, hi = np.array([1, 10, 20]), np.array([64, 10, 29])
    feat = array_features(copies, RATE, lo, hi, nperseg=nperseg)
    assert isinstance(feat, ArrayFeatures)
    n_seg = (n - 64) // 64
    assert feat.gamma.shape == feat.g2.shape == (3, 3)
    assert feat.spectra.shape == (3, n_seg, 65, n_ch)
    np.testing.assert_array_equal(feat.f_hz, np.fft.rfftfreq(nperseg, 1 / RATE))
    np.testing.assert_array_equal(feat.n_averages, n_seg * np.array([64, 1, 10]))
    np.testing.assert_allclose(feat.gamma, 1.0, rtol=1e-12)
    np.testing.assert_allclose(feat.g2, 1.0, rtol=1e-10)
    feat = array_features(noise, RATE, lo, hi, nperseg=nperseg)
    assert np.abs(feat.gamma - 1 / n_ch).max() < 0.05
    # the one-bin band: G2 scatters about the noise floor of its 31 averages; the full
    # band, 64 times as many, lies far lower
    floor = g2_noise_floor(n_ch, int(feat.n_averages[1]))
    assert 0.25 * floor < feat.g2[:, 1].min() and feat.g2[:, 1].max() < 4 * floor
    assert feat.g2[:, 0].max() < 0.1 * floor
    with pytest.raises(dataclasses.FrozenInstanceError):
        feat.g2 = feat.gamma                                     # type: ignore[misc]


def test_array_features_only_count_the_taxels_in_contact():
    # taxels 0-3 share one source, 4-5 are loud independent noise: with contact 0-3 the
    # array is coherent, with all six it is not
    rng = np.random.default_rng(5)
    x = np.concatenate([rng.standard_normal((2, 1024, 1)) * np.ones(4),
                        5 * rng.standard_normal((2, 1024, 2))], axis=-1)
    lo, hi = np.array([1]), np.array([64])
    contact = np.array([True] * 4 + [False] * 2)
    some = array_features(x, RATE, lo, hi, nperseg=128, contact=contact)
    np.testing.assert_allclose(some.gamma, 1.0, rtol=1e-12)
    np.testing.assert_allclose(some.g2, 1.0, rtol=1e-10)
    every = array_features(x, RATE, lo, hi, nperseg=128)
    assert every.gamma.max() < 0.5 and every.g2.max() < 0.5
    # a contact mask per window
    per_window = array_features(x, RATE, lo, hi, nperseg=128,
                                contact=np.stack([contact, np.ones(6, bool)]))
    np.testing.assert_allclose(per_window.g2[:, 0], [some.g2[0, 0], every.g2[1, 0]])
    # one taxel in contact: no coherence of a group
    one = array_features(x, RATE, lo, hi, nperseg=128, contact=np.eye(6, dtype=bool)[0])
    assert np.isnan(one.g2).all()


def test_array_features_undo_sequential_sampling_delays():
    # one source, 5 taxels sampled 0.2 ms apart: Gamma falls without eq. 7's advance and
    # comes back to 1 with it (a source of tones, so it can be sampled at any instant)
    rng = np.random.default_rng(6)
    f, a, ph = rng.uniform(200, 450, 40), rng.uniform(0.5, 1, 40), rng.uniform(0, 6.3, 40)
    delays = np.arange(5) * 0.2e-3
    t = np.arange(4096)[:, None] / RATE + delays
    x = (a * np.cos(2 * np.pi * f * t[..., None] + ph)).sum(axis=-1)
    lo, hi = np.array([52]), np.array([115])                      # 203-449 Hz
    plain = array_features(x, RATE, lo, hi, nperseg=256)
    fixed = array_features(x, RATE, lo, hi, nperseg=256, delays_s=delays)
    assert plain.gamma[0] < 0.8 and fixed.gamma[0] > 0.99


# -- across arrays -----------------------------------------------------------------------------
def _features(spectra: np.ndarray, f_hz: np.ndarray) -> ArrayFeatures:
    nb = np.zeros(1)
    return ArrayFeatures(f_hz, nb, nb, nb, spectra)


def test_finger_ensembles_sum_the_contact_taxels_of_each_finger():
    # hand-built spectra (n_seg 2, bins 3, taxels 3) of two fingers
    f = np.array([0.0, 100.0, 200.0])
    a = np.arange(18, dtype=complex).reshape(2, 3, 3) * (1 + 1j)
    b = np.ones((2, 3, 3), dtype=complex) * np.array([1.0, 10.0, 100.0])
    contacts = [np.array([True, False, True]), np.array([False, True, True])]
    got = finger_ensembles([_features(a, f), _features(b, f)], None, contacts)
    assert got.shape == (2, 3, 2)
    np.testing.assert_array_equal(got[..., 0], a[..., 0] + a[..., 2])
    np.testing.assert_array_equal(got[..., 1], np.full((2, 3), 110.0))
    # delays: each taxel advanced by exp(-2 pi j f delta) before the sum (eq. 7)
    delays = np.array([0.0, 1.25e-3, 2.5e-3])
    got = finger_ensembles([_features(a, f), _features(b, f)], delays, contacts)
    turn = np.exp(-2j * np.pi * f[:, None] * delays)              # (bins, taxels)
    np.testing.assert_allclose(got[..., 0], a[..., 0] + a[..., 2] * turn[:, 2])
    np.testing.assert_allclose(got[..., 1], np.broadcast_to(10 * turn[:, 1] + 100 * turn[:, 2],
                                                            (2, 3)))
    np.testing.assert_allclose(got[:, 1, 1], 10 * np.exp(-0.25j * np.pi) - 100j)


def test_finger_ensembles_with_batch_axes_and_contact_per_window():
    f = np.array([0.0, 50.0])
    rng = np.random.default_rng(7)
    s = rng.standard_normal((4, 3, 2, 5)) + 1j * rng.standard_normal((4, 3, 2, 5))
    contact = rng.random((4, 5)) < 0.5
    got = finger_ensembles([_features(s, f)], None, [contact])
    assert got.shape == (4, 3, 2, 1)
    for w in range(4):
        np.testing.assert_allclose(got[w, ..., 0], s[w][..., contact[w]].sum(axis=-1))
    with pytest.raises(ValueError):
        finger_ensembles([_features(s, f)], None, [contact, contact])


def test_multi_finger_g2_is_the_band_coherence_across_fingers():
    rng = np.random.default_rng(8)
    n_seg, n_bins = 20, 9
    common = rng.standard_normal((n_seg, n_bins)) + 1j * rng.standard_normal((n_seg, n_bins))
    other = rng.standard_normal((n_seg, n_bins)) + 1j * rng.standard_normal((n_seg, n_bins))
    # the same finger twice (scaled, turned): G2 = 1 in every band
    same = np.stack([common, 3j * common], axis=-1)
    lo, hi = np.array([1, 1, 4]), np.array([1, 8, 6])
    np.testing.assert_allclose(multi_finger_g2(same, lo, hi), 1.0, rtol=1e-12)
    # two fingers: G2 = |sum S12|^2 / (sum S11 sum S22) over the band's bins
    mixed = np.stack([common, common + 2 * other], axis=-1)
    got = multi_finger_g2(mixed, lo, hi)
    for b in range(3):
        k = slice(lo[b], hi[b] + 1)
        s12 = (mixed[:, k, 0].conj() * mixed[:, k, 1]).sum()
        s11 = (np.abs(mixed[:, k, 0]) ** 2).sum()
        s22 = (np.abs(mixed[:, k, 1]) ** 2).sum()
        assert got[b] == pytest.approx(abs(s12) ** 2 / (s11 * s22), rel=1e-10)
    assert 0.05 < got[1] < 0.5


def test_multi_finger_g2_from_array_features_end_to_end():
    # two fingers of 4 taxels: one shared source on both -> G2 across fingers ~ 1;
    # each finger its own source -> G2 near 0 (about 1 / n_averages for two channels)
    rng = np.random.default_rng(9)
    lo, hi = np.array([1, 5]), np.array([64, 8])
    contact = np.ones(4, bool)

    def across(x1: np.ndarray, x2: np.ndarray) -> np.ndarray:
        feats = [array_features(x, RATE, lo, hi, nperseg=128) for x in (x1, x2)]
        return multi_finger_g2(finger_ensembles(feats, None, [contact, contact]), lo, hi)

    shared = rng.standard_normal((2048, 1))
    g = across(shared * [1, 2, 3, 4] + 0.01 * rng.standard_normal((2048, 4)),
               shared * [4, 3, 2, 1] + 0.01 * rng.standard_normal((2048, 4)))
    assert g.shape == (2,) and g.min() > 0.99
    g = across(rng.standard_normal((2048, 1)) * np.ones(4),
               rng.standard_normal((2048, 1)) * np.ones(4))
    assert g.max() < 0.1 and g[0] < g[1]                        # more averages, less bias


def test_segment_and_csd_agree_with_array_features():
    # the features' spectra are segment_spectra's, their G2 that of the band-summed CSD
    rng = np.random.default_rng(10)
    x = rng.standard_normal((700, 3)) + rng.standard_normal((700, 1))
    lo, hi = np.array([2]), np.array([20])
    feat = array_features(x, RATE, lo, hi, nperseg=100, noverlap=30)
    _, spectra = segment_spectra(x, RATE, nperseg=100, noverlap=30)
    np.testing.assert_array_equal(feat.spectra, spectra)
    _, csd, _ = cross_spectral_matrix(x, RATE, nperseg=100, noverlap=30)
    want = group_square_coherence(csd[2:21].sum(axis=0)[None])[0]
    assert feat.g2[0] == pytest.approx(want, rel=1e-10)
