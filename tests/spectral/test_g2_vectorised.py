"""The vectorised largest-eigenvalue path of the group square coherence (issue 15, item 6):
Householder tridiagonalisation + Laguerre across all bins at once, against LAPACK
``eigvalsh`` and a scipy pair loop, on the benchmark's windows and on adversarial inputs
(near-equal top eigenvalues, rank 1, identity-like, zero and tiny channels)."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import signal

from tactile_cli.spectral import group_square_coherence_bins, group_square_coherence_windows
from tactile_cli.spectral._coherence import (
    _householder_tridiagonal,
    _largest_eigenvalue_gram,
    _tridiagonal_top_eigenvalue,
)

RATE_HZ = 1000.0


def _hermitian(eigenvalues: np.ndarray, seed: int) -> np.ndarray:
    """Random complex Hermitian matrices (B, m, m) with the given spectra (B, m)."""
    rng = np.random.default_rng(seed)
    b, m = eigenvalues.shape
    z = rng.standard_normal((b, m, m)) + 1j * rng.standard_normal((b, m, m))
    q, _ = np.linalg.qr(z)
    return (q * eigenvalues[:, None, :]) @ np.swapaxes(q.conj(), -1, -2)


def _loop_g2(x: np.ndarray, nperseg: int = 256, noverlap: int = 128) -> np.ndarray:
    """(n_samples, N) -> (n_bins,): scipy.signal.csd per pair, eigh per bin."""
    n = x.shape[1]
    s = np.stack([np.stack([signal.csd(x[:, i], x[:, j], fs=RATE_HZ, nperseg=nperseg,
                                       noverlap=noverlap)[1] for j in range(n)], axis=-1)
                  for i in range(n)], axis=-2)                    # (bins, N, N)
    d = np.sqrt(np.einsum("kii->ki", s).real)
    with np.errstate(invalid="ignore", divide="ignore"):
        c = np.where((d[:, :, None] * d[:, None, :]) > 0,
                     s / (d[:, :, None] * d[:, None, :]), 0.0)
    lam1 = np.linalg.eigvalsh(c)[:, -1]
    return np.clip((lam1 - 1) / (n - 1), 0, 1) ** 2


@pytest.mark.parametrize("spectrum", [
    "wishart", "top_double", "top_gap_1e-10", "top_gap_1e-6", "rank1", "identity",
    "cluster_of_three", "zero", "tiny", "huge"])
def test_largest_eigenvalue_matches_eigvalsh(spectrum):
    rng = np.random.default_rng(3)
    b, m = 400, 7
    lam = np.sort(rng.uniform(0, 6, (b, m)), axis=1)
    if spectrum == "top_double":
        lam[:, -2] = lam[:, -1]
    elif spectrum == "top_gap_1e-10":
        lam[:, -2] = lam[:, -1] - 1e-10
    elif spectrum == "top_gap_1e-6":
        lam[:, -2] = lam[:, -1] - 1e-6
    elif spectrum == "rank1":
        lam[:, :-1] = 0.0
    elif spectrum == "identity":
        lam[:] = 1.0
    elif spectrum == "cluster_of_three":
        lam[:, -3:] = lam[:, -1:] + np.array([-2e-9, -1e-9, 0.0])
    elif spectrum == "zero":
        lam[:] = 0.0
    elif spectrum == "tiny":
        lam *= 1e-150
    elif spectrum == "huge":
        lam *= 1e150
    g = _hermitian(lam, seed=5) if spectrum != "identity" else \
        np.broadcast_to(np.eye(m, dtype=complex), (b, m, m)).copy()
    want = np.linalg.eigvalsh(g)[:, -1]
    got = _largest_eigenvalue_gram(g)
    np.testing.assert_allclose(got, want, rtol=1e-11, atol=1e-12 * np.abs(want).max())


def test_tridiagonal_certificate_flags_what_it_cannot_prove():
    # a start bound below lambda1 (a wrong "upper"): Laguerre lands on some root, and
    # the Sturm counts must refuse the certificate unless it is lambda1
    rng = np.random.default_rng(1)
    lam = np.sort(rng.uniform(1, 6, (300, 7)), axis=1)
    g = _hermitian(lam, seed=2)
    alpha, beta2 = _householder_tridiagonal(np.ascontiguousarray(g.transpose(1, 2, 0)))
    top, ok = _tridiagonal_top_eigenvalue(alpha, beta2, 0.5 * lam[:, -1] + 0.5 * lam[:, -2])
    good = np.abs(top - lam[:, -1]) <= 1e-11 * lam[:, -1]
    assert not (ok & ~good).any()
    top, ok = _tridiagonal_top_eigenvalue(alpha, beta2, lam.sum(axis=1))
    assert ok.all()
    np.testing.assert_allclose(top, lam[:, -1], rtol=1e-12)


def test_householder_keeps_the_spectrum():
    rng = np.random.default_rng(4)
    lam = np.sort(rng.uniform(0, 3, (50, 9)), axis=1)
    alpha, beta2 = _householder_tridiagonal(
        np.ascontiguousarray(_hermitian(lam, seed=6).transpose(1, 2, 0)))
    t = np.zeros((50, 9, 9))
    i = np.arange(9)
    t[:, i, i] = alpha.T
    t[:, i[:-1], i[1:]] = t[:, i[1:], i[:-1]] = np.sqrt(beta2.T)
    np.testing.assert_allclose(np.linalg.eigvalsh(t), lam, atol=1e-13)


def _adversarial_windows() -> dict[str, np.ndarray]:
    rng = np.random.default_rng(11)
    n_win, n, ch = 12, 1024, 20
    noise = rng.standard_normal((n_win, n, ch))
    common = rng.standard_normal((n_win, n, 1))
    out = {
        "noise": noise,
        "common_plus_noise": noise + common * rng.uniform(0, 2, (n_win, 1, 1)),
        "rank1_copies": np.repeat(common, ch, axis=2) * rng.uniform(0.5, 2, (1, 1, ch)),
        "nearly_rank1": np.repeat(common, ch, axis=2) + 1e-7 * noise,
        "two_equal_sources": common + rng.standard_normal((n_win, n, 1)) *
        (np.arange(ch) % 2 == 0),
    }
    zero = noise.copy()
    zero[:, :, :5] = 0.0
    out["zero_channels"] = zero
    tiny = noise.copy()
    tiny[:, :, 3] *= 1e-150
    tiny[:, :, 4] *= 1e-300
    out["tiny_channels"] = tiny
    out["all_zero"] = np.zeros((n_win, n, ch))
    out["large_offset"] = 1e4 + noise                                  # raw counts
    return out


@pytest.mark.parametrize("name", list(_adversarial_windows()))
def test_vectorised_windows_agree_with_lapack_path(name):
    x = _adversarial_windows()[name]
    _, ref = group_square_coherence_windows(x, RATE_HZ, method="eigvalsh")
    _, got = group_square_coherence_windows(x, RATE_HZ, method="tridiagonal")
    _, auto = group_square_coherence_windows(x, RATE_HZ)              # < 1024: LAPACK
    np.testing.assert_allclose(got, ref, rtol=0, atol=1e-9)
    np.testing.assert_allclose(auto, ref, rtol=0, atol=1e-9)
    assert np.isfinite(got).all() and got.min() >= 0.0 and got.max() <= 1.0


def test_vectorised_windows_agree_with_scipy_loop():
    rng = np.random.default_rng(0)
    x = rng.standard_normal((10, 1024, 20)) + \
        rng.standard_normal((10, 1024, 1)) * rng.uniform(0, 2, (10, 1, 1))
    _, got = group_square_coherence_windows(x, RATE_HZ, method="tridiagonal", chunk=8)
    for w in (0, 9):
        np.testing.assert_allclose(got[w], _loop_g2(x[w]), rtol=0, atol=1e-9)


@pytest.mark.parametrize(("n_ch", "nperseg", "noverlap"), [(4, 128, 64), (20, 200, 50),
                                                           (3, 64, 0)])
def test_vectorised_windows_other_shapes(n_ch, nperseg, noverlap):
    # fewer channels than segments (the N x N Gram) and steps that do not divide nperseg
    rng = np.random.default_rng(2)
    x = rng.standard_normal((9, 1000, n_ch)) + rng.standard_normal((9, 1000, 1))
    _, ref = group_square_coherence_windows(x, RATE_HZ, nperseg=nperseg, noverlap=noverlap,
                                            method="eigvalsh")
    _, got = group_square_coherence_windows(x, RATE_HZ, nperseg=nperseg, noverlap=noverlap,
                                            method="tridiagonal", chunk=4)
    np.testing.assert_allclose(got, ref, rtol=0, atol=1e-9)
    np.testing.assert_allclose(got[0], _loop_g2(x[0], nperseg, noverlap), rtol=0, atol=1e-9)


def test_bins_methods_agree():
    rng = np.random.default_rng(5)
    spectra = rng.standard_normal((3, 7, 129, 20)) + 1j * rng.standard_normal((3, 7, 129, 20))
    np.testing.assert_allclose(group_square_coherence_bins(spectra, method="tridiagonal"),
                               group_square_coherence_bins(spectra, method="eigvalsh"),
                               rtol=0, atol=1e-12)
    with pytest.raises(ValueError):
        group_square_coherence_bins(spectra, method="qr")


@pytest.mark.parametrize("method", ["auto", "tridiagonal", "eigvalsh"])
def test_windows_are_the_same_bits_for_any_worker_count(method: str) -> None:
    """Issue 30: chunks of a fixed size, each on one-threaded BLAS whatever ``workers``
    and whatever the caller's BLAS thread count: bit-identical G2."""
    from threadpoolctl import threadpool_info, threadpool_limits

    x = np.random.default_rng(11).standard_normal((7, 1024, 12))
    with threadpool_limits(limits=2, user_api="blas"):
        before = [i["num_threads"] for i in threadpool_info() if i["user_api"] == "blas"]
        _, one = group_square_coherence_windows(x, RATE_HZ, nperseg=128, chunk=2,
                                                method=method)
        # the caller's BLAS setting is given back
        assert [i["num_threads"] for i in threadpool_info()
                if i["user_api"] == "blas"] == before
    for workers in (2, 3):
        _, got = group_square_coherence_windows(x, RATE_HZ, nperseg=128, chunk=2,
                                                workers=workers, method=method)
        np.testing.assert_array_equal(got, one)
