"""Cross-spectra, power ratio and group square coherence of multichannel windows (paper 004,
secs. 3.1-3.2 and appendix A), vectorised over windows, frequency bins and channels.

Every function takes windows ``x`` of shape ``(..., n_samples, n_channels)`` (any number of
leading batch axes: trials, windows) and works on Welch segments: Hann (periodic) segments
of ``nperseg`` samples every ``nperseg - noverlap`` samples, the mean removed per segment,
one-sided density scaling as :func:`scipy.signal.csd` (so ``csd[..., k, i, j]`` equals
``scipy.signal.csd(x_i, x_j)[k]``).

- :func:`segment_spectra`: the scaled FFT of every segment, ``(..., n_seg, n_bins, n_ch)``;
- :func:`cross_spectral_matrix`: the Welch cross-spectral density matrix per bin;
- :func:`band_sums`: any set of bin ranges summed through cumulative sums (all bands at once);
- :func:`local_ensemble_power`: L(f, w) and E(f, w) of eqs. 4-5, with the phase advance of
  eq. 7 for sequentially sampled channels (``delays_s``);
- :func:`power_ratio`: Gamma = E / (N_c L) (eq. 6), in [0, 1] by Cauchy-Schwarz;
- :func:`coherence_matrix`: the complex coherence C_ij = S_ij / sqrt(S_ii S_jj) (eq. 11);
- :func:`group_square_coherence`: G2 = ((lambda1 - 1) / (N - 1))^2 (eq. 34) from a CSD matrix;
- :func:`group_square_coherence_bins`: G2 per bin straight from the segments, through the
  smaller of the channel (N x N) and segment (n_seg x n_seg) Gram matrices: both have the
  same non-zero eigenvalues, so with fewer segments than channels only n_seg x n_seg
  eigenproblems are solved; :func:`group_square_coherence_windows`: the same for many
  windows, in cache-sized chunks, optionally on several threads.

Largest eigenvalue of many small Gram matrices (:func:`_largest_eigenvalue_gram`): LAPACK
``eigvalsh`` costs ~3 us per 7 x 7 matrix in call overhead, so for a thousand matrices or
more the matrices are reduced to real tridiagonal form by Householder reflections written
as array operations across all matrices at once (:func:`_householder_tridiagonal`), then
lambda1 of each is found by Laguerre's iteration from above, also across all at once
(:func:`_tridiagonal_top_eigenvalue`). Sturm counts certify each result within 1e-12 x
trace; the uncertified ones are solved by ``eigvalsh`` (none on the benchmark or on the
adversarial windows of the tests; top eigenvalues closer than ~1e-4 x trace, where
Laguerre converges only linearly within 8 steps, go there).

Rank deficiency: a CSD matrix averaged over ``n_avg`` segment-bin products has rank at most
``n_avg``; with ``n_avg < n_channels`` independent noise still shows lambda1 >= N / n_avg
and G2 is biased upward (:func:`g2_noise_floor` gives the expected value). Results carry
the count so callers can flag it.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from threadpoolctl import ThreadpoolController

_TINY = 1e-300
_CACHE_MATRICES = 1024     # 7 x 7 complex matrices per Householder block
_MIN_VECTORISED = 1024     # fewer matrices: LAPACK eigvalsh is faster ("auto")
_FFT_WINDOWS = 4           # windows per FFT + Gram block (arrays of ~0.6 MB)
_HH_WINDOWS = 16           # windows per Householder call (a multiple of _FFT_WINDOWS)
_BLAS: ThreadpoolController | None = None


def _blas_controller() -> ThreadpoolController:
    """threadpoolctl's controller of the loaded BLAS libraries, found once (~3 ms; a
    limit then costs ~15 us)."""
    global _BLAS
    if _BLAS is None:
        from threadpoolctl import ThreadpoolController

        _BLAS = ThreadpoolController()
    return _BLAS


def welch_segment_count(n_samples: int, nperseg: int, noverlap: int) -> int:
    """Number of Welch segments of ``nperseg`` samples, ``noverlap`` shared, in
    ``n_samples`` (scipy's count: no padding, no boundary extension)."""
    _check_segments(n_samples, nperseg, noverlap)
    return (n_samples - noverlap) // (nperseg - noverlap)


def _check_segments(n_samples: int, nperseg: int, noverlap: int) -> None:
    if nperseg < 2:
        raise ValueError(f"`nperseg` (={nperseg}) must be >= 2")
    if not 0 <= noverlap < nperseg:
        raise ValueError(f"`noverlap` (={noverlap}) must be >= 0 and below `nperseg` "
                         f"(={nperseg})")
    if n_samples < nperseg:
        raise ValueError(f"windows of {n_samples} samples are shorter than `nperseg` "
                         f"(={nperseg})")


def segment_spectra(x: np.ndarray, rate_hz: float, *, nperseg: int = 256,
                    noverlap: int | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Scaled one-sided FFT of every Welch segment.

    x: (..., n_samples, n_channels). Returns ``f_hz (n_bins,)`` and ``spectra`` complex128
    (..., n_seg, n_bins, n_channels), scaled so that the Welch CSD is
    ``mean over segments of conj(X_i) X_j`` (density, units^2/Hz, as scipy.signal.csd).
    ``noverlap`` defaults to ``nperseg // 2``.
    """
    a = np.asarray(x, dtype=np.float64)
    if a.ndim < 2:
        raise ValueError(f"`x` must be (..., n_samples, n_channels), got shape {a.shape}")
    if not rate_hz > 0:
        raise ValueError(f"`rate_hz` (={rate_hz}) must be positive")
    noverlap = nperseg // 2 if noverlap is None else int(noverlap)
    n = a.shape[-2]
    n_seg = welch_segment_count(n, nperseg, noverlap)
    step = nperseg - noverlap
    # channel-major, segments as a strided view (no copy until the FFT)
    chan = np.ascontiguousarray(np.swapaxes(a, -1, -2))           # (..., ch, n)
    segs = np.lib.stride_tricks.sliding_window_view(chan, nperseg, axis=-1)[
        ..., : n_seg * step : step, :]                              # (..., ch, seg, nperseg)
    taper = np.hanning(nperseg + 1)[:-1]                           # periodic Hann
    spectra = np.fft.rfft(segs * taper, axis=-1)                   # (..., ch, seg, bins)
    # removing each segment's mean before the taper = subtracting mean * FFT(taper), which
    # is non-zero in bins 0 and 1 only (periodic Hann)
    taper_fft = np.fft.rfft(taper)[:2]
    spectra[..., :2] -= segs.mean(axis=-1)[..., None] * taper_fft
    scale = np.full(spectra.shape[-1], 1.0 / (rate_hz * float((taper ** 2).sum())))
    scale[1:] *= 2.0                                               # one-sided
    if nperseg % 2 == 0:
        scale[-1] /= 2.0                                           # Nyquist bin once
    spectra *= np.sqrt(scale)
    spectra = np.moveaxis(spectra, -3, -1)                          # (..., seg, bins, ch)
    return np.fft.rfftfreq(nperseg, 1.0 / rate_hz), spectra


def cross_spectral_matrix(x: np.ndarray, rate_hz: float, *, nperseg: int = 256,
                          noverlap: int | None = None) -> tuple[np.ndarray, np.ndarray, int]:
    """Welch cross-spectral density matrices.

    x: (..., n_samples, n_channels). Returns ``f_hz (n_bins,)``, ``csd`` complex128
    (..., n_bins, n_channels, n_channels) with ``csd[..., k, i, j]`` =
    ``scipy.signal.csd(x_i, x_j)[k]`` (units^2/Hz), and the segment count.
    """
    f, spectra = segment_spectra(x, rate_hz, nperseg=nperseg, noverlap=noverlap)
    n_seg = spectra.shape[-3]
    csd = np.einsum("...ski,...skj->...kij", spectra.conj(), spectra) / n_seg
    return f, csd, n_seg


def band_sums(values: np.ndarray, lo_bin: np.ndarray, hi_bin: np.ndarray, *,
              axis: int = -3) -> np.ndarray:
    """Sum of ``values`` over the bins ``lo_bin[b] .. hi_bin[b]`` (inclusive) for every
    band b at once, through one cumulative sum along ``axis`` (the bin axis); the band axis
    replaces the bin axis. ``lo_bin``, ``hi_bin``: (n_bands,) integer bin indices."""
    v = np.moveaxis(np.asarray(values), axis, 0)
    lo = np.asarray(lo_bin, dtype=np.int64)
    hi = np.asarray(hi_bin, dtype=np.int64)
    if lo.shape != hi.shape or lo.ndim != 1:
        raise ValueError("`lo_bin` and `hi_bin` must be 1-D and of one length")
    if len(lo) and (lo.min() < 0 or hi.max() >= v.shape[0] or (hi < lo).any()):
        raise ValueError(f"bands must satisfy 0 <= lo_bin <= hi_bin < {v.shape[0]}")
    cum = np.concatenate([np.zeros_like(v[:1]), np.cumsum(v, axis=0)], axis=0)
    return np.moveaxis(cum[hi + 1] - cum[lo], 0, axis)


def _steering(f_hz: np.ndarray, delays_s: np.ndarray | None, n_channels: int) -> np.ndarray:
    """(n_bins, n_channels) phase factors that undo each channel's sampling delay."""
    if delays_s is None:
        return np.ones((len(f_hz), n_channels), dtype=np.complex128)
    d = np.asarray(delays_s, dtype=np.float64)
    if d.shape != (n_channels,):
        raise ValueError(f"`delays_s` must hold one delay per channel ({n_channels}), got "
                         f"shape {d.shape}")
    # channel i sampled delta_i late: its DFT carries exp(+2 pi j f delta_i); undo it
    return np.exp(-2j * np.pi * f_hz[:, None] * d[None, :])


def local_ensemble_power(csd: np.ndarray, f_hz: np.ndarray, lo_bin: np.ndarray,
                         hi_bin: np.ndarray, *, delays_s: np.ndarray | None = None,
                         contact: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """L(f, w) and E(f, w) (eqs. 4, 5 and 7) of each band from CSD matrices.

    csd: (..., n_bins, N, N). ``delays_s`` (N,): each channel's sampling delay (s) within
    one sampling period (sequential sampling), undone by a phase advance (eq. 7).
    ``contact`` (..., N) boolean: the taxels in contact (default all). Returns ``local``,
    ``ensemble`` (..., n_bands) in units^2/Hz summed over the band's bins.
    """
    s = np.asarray(csd)
    n = s.shape[-1]
    v = _steering(np.asarray(f_hz, dtype=np.float64), delays_s, n)    # (bins, N)
    if contact is not None:
        v = v * np.asarray(contact, dtype=np.float64)[..., None, :]
    local_bins = np.einsum("...kii,...ki->...k", s, np.abs(v) ** 2).real
    ens_bins = np.einsum("...ki,...kij,...kj->...k", v.conj(), s, v).real
    return (band_sums(local_bins, lo_bin, hi_bin, axis=-1),
            band_sums(ens_bins, lo_bin, hi_bin, axis=-1))


def power_ratio(local: np.ndarray, ensemble: np.ndarray, n_contact: np.ndarray | int
                ) -> np.ndarray:
    """Gamma = E / (N_c L) (eq. 6), in [0, 1]; NaN where ``local`` is zero."""
    loc = np.asarray(local, dtype=np.float64)
    nc = np.asarray(n_contact, dtype=np.float64)
    with np.errstate(invalid="ignore", divide="ignore"):
        g = np.asarray(ensemble, dtype=np.float64) / (nc * loc)
    g = np.where(loc > 0, g, np.nan)
    return np.clip(g, 0.0, 1.0)   # rounding only: Cauchy-Schwarz bounds it


def coherence_matrix(csd: np.ndarray) -> np.ndarray:
    """Complex coherence C_ij = S_ij / sqrt(S_ii S_jj) of (..., N, N) CSD matrices (0 where
    a channel has no power)."""
    s = np.asarray(csd)
    d = np.sqrt(np.maximum(np.einsum("...ii->...i", s).real, 0.0))
    inv = np.where(d > 0, 1.0 / np.maximum(d, _TINY), 0.0)
    return s * inv[..., :, None] * inv[..., None, :]


def _g2_from_lambda(lam1: np.ndarray, n: int) -> np.ndarray:
    if n < 2:
        raise ValueError(f"group coherence needs at least 2 channels, got {n}")
    return np.clip((lam1 - 1.0) / (n - 1), 0.0, 1.0) ** 2


def group_square_coherence(csd: np.ndarray) -> np.ndarray:
    """G2 = ((lambda1(C) - 1) / (N - 1))^2 (eq. 34) of (..., N, N) CSD matrices -> (...,).

    lambda1 is the largest eigenvalue of the coherence matrix C (N >= 2); G2 lies in
    [0, 1]: 1 for channels that are filtered copies of one source, near 0 for independent
    channels, the magnitude-squared coherence for N = 2."""
    c = coherence_matrix(csd)
    lam1 = np.linalg.eigvalsh(c)[..., -1]
    return _g2_from_lambda(lam1, c.shape[-1])


def _householder_tridiagonal(a: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Householder reduction of Hermitian matrices stored matrix-axes first, ``a`` complex
    (m, m, B) (B matrices along the last, contiguous axis; overwritten), to real symmetric
    tridiagonal matrices with the same eigenvalues: diagonal ``alpha`` (m, B) and squared
    off-diagonal ``beta2`` (m - 1, B) (the off-diagonal's phases do not change the
    eigenvalues). Elementwise array operations across all B matrices at once (no per-matrix
    LAPACK call); backward stable like LAPACK's ``zhetrd``."""
    m, _, nb = a.shape
    alpha = np.empty((m, nb))
    beta2 = np.empty((max(m - 1, 0), nb))
    with np.errstate(divide="ignore", invalid="ignore"):
        for k in range(m - 2):
            alpha[k] = a[k, k].real
            x = a[k + 1:, k]                                        # (r, B) below diagonal
            s = (x.real ** 2 + x.imag ** 2).sum(axis=0)             # ||x||^2
            beta2[k] = s
            nrm = np.sqrt(s)
            x0 = x[0]
            ax0 = np.abs(x0)
            v = x.copy()                                            # v = x + phase ||x|| e1
            v[0] = x0 + np.where(ax0 > 0, x0 / ax0, 1.0) * nrm
            vhv = 2.0 * (s + ax0 * nrm)
            tau = np.where(vhv > 0, 2.0 / vhv, 0.0)                 # H = I - tau v v^H
            a22 = a[k + 1:, k + 1:]
            p = tau * np.einsum("ijb,jb->ib", a22, v)
            w = p - (0.5 * tau * np.einsum("ib,ib->b", v.conj(), p).real) * v
            outer = v[:, None, :] * w.conj()[None, :, :]
            a22 -= outer                                            # A - v w^H - w v^H
            np.conjugate(outer, out=outer)
            a22 -= outer.swapaxes(0, 1)
    for k in range(max(m - 2, 0), m):
        alpha[k] = a[k, k].real
    if m >= 2:
        beta2[m - 2] = np.abs(a[m - 1, m - 2]) ** 2
    return alpha, beta2


def _sturm_count_above(alpha: np.ndarray, beta2: np.ndarray, s: np.ndarray) -> np.ndarray:
    """Number of eigenvalues above ``s`` (B,) of each tridiagonal matrix (alpha (m, B),
    beta2 (m - 1, B)): the negative pivots of s I - T (LDL^T, exact for a matrix within a
    few ulps of T)."""
    d = s - alpha[0]
    count = (d < 0).astype(np.int64)
    for i in range(1, alpha.shape[0]):
        d = (s - alpha[i]) - beta2[i - 1] / np.where(d == 0, _TINY, d)
        count += d < 0
    return count


def _tridiagonal_top_eigenvalue(alpha: np.ndarray, beta2: np.ndarray, upper: np.ndarray, *,
                                max_iter: int = 8, rtol: float = 1e-12
                                ) -> tuple[np.ndarray, np.ndarray]:
    """Largest eigenvalue of symmetric tridiagonal matrices (alpha (m, B), beta2 (m - 1, B),
    ``upper`` (B,) any upper bound of it, e.g. the trace of a positive semidefinite matrix)
    by Laguerre's iteration from above on det(x I - T), all B at once.

    For a polynomial with real roots Laguerre's iteration from above the largest root
    descends to it monotonically, cubically for a simple root. Returns ``lam`` (B,) and
    ``certified`` (B,) bool: Sturm counts prove lambda1 in (lam - tol, lam + tol] with
    ``tol = rtol * upper``; the caller solves the rest exactly."""
    m = alpha.shape[0]
    upper = np.asarray(upper, dtype=np.float64)
    scale = np.where(upper > 0, upper, 1.0)                         # work on T / upper
    alpha = alpha / scale
    beta2 = beta2 / scale ** 2
    beta = np.sqrt(beta2)
    rad = np.zeros_like(alpha)                                      # Gershgorin radii
    rad[:-1] += beta
    rad[1:] += beta
    zero = upper <= 0                                               # zero matrix
    upper = np.where(zero, 0.0, 1.0)
    frob = np.sqrt((alpha ** 2).sum(axis=0) + 2.0 * beta2.sum(axis=0))   # >= lambda1 too
    x = np.minimum(np.minimum((alpha + rad).max(axis=0), upper), frob)
    x = x * (1.0 + 1e-13) + 1e-300                                  # strictly above
    n = float(m)
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        for _ in range(max_iter):
            # pivots d_i of x I - T and their first two derivatives in x:
            # G = p'/p = sum d_i'/d_i, H = -G' = sum (d_i'/d_i)^2 - d_i''/d_i
            d = x - alpha[0]
            dp = np.ones_like(x)
            dpp = np.zeros_like(x)
            e = 1.0 / d
            g = e.copy()
            grad = g.copy()
            hess = g * g
            for i in range(1, m):
                t = beta2[i - 1] * e
                dpp = t * e * (dpp - 2.0 * dp * g)
                dp = 1.0 + t * g
                d = (x - alpha[i]) - t
                e = 1.0 / d
                g = dp * e
                grad += g
                hess += g * g - dpp * e
            step = n / (grad + np.sqrt(np.maximum((n - 1.0) * (n * hess - grad * grad),
                                                  0.0)))
            step = np.where(np.isfinite(step), step, 0.0)
            x = x - step
            if not (step > rtol * 1e-3 * upper).any():
                break
        tol = rtol * upper
        certified = (_sturm_count_above(alpha, beta2, x + tol) == 0) & \
            (_sturm_count_above(alpha, beta2, x - tol) >= 1)
    return np.where(zero, 0.0, x * scale), certified | zero


def _largest_eigenvalue_gram(gram: np.ndarray) -> np.ndarray:
    """Largest eigenvalue of positive semidefinite Hermitian matrices ``gram`` (..., m, m)
    -> (...,): Householder tridiagonalisation + Laguerre, vectorised across all matrices,
    exact ``numpy.linalg.eigvalsh`` for any whose result is not certified (within
    1e-12 x trace)."""
    g = np.asarray(gram)
    m = g.shape[-1]
    flat = g.reshape(-1, m, m)
    if m == 1:
        return flat[:, 0, 0].real.reshape(g.shape[:-2])
    alpha = np.empty((m, len(flat)))
    beta2 = np.empty((m - 1, len(flat)))
    step = max(1, _CACHE_MATRICES * 49 // (m * m))                 # ~0.8 MB per block
    for s in range(0, len(flat), step):
        alpha[:, s:s + step], beta2[:, s:s + step] = _tridiagonal_gram(flat[s:s + step])
    return _top_eigenvalue_checked(alpha, beta2, flat).reshape(g.shape[:-2])


def _tridiagonal_gram(flat: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(B, m, m) Hermitian -> the tridiagonal ``alpha`` (m, B), ``beta2`` (m - 1, B) of
    :func:`_householder_tridiagonal` (on a matrix-axes-first copy)."""
    return _householder_tridiagonal(np.ascontiguousarray(flat.transpose(1, 2, 0)))


def _top_eigenvalue_checked(alpha: np.ndarray, beta2: np.ndarray, flat: np.ndarray
                            ) -> np.ndarray:
    """lambda1 (B,) of the positive semidefinite matrices ``flat`` (B, m, m) from their
    tridiagonal forms; ``eigvalsh`` of ``flat`` where Laguerre's result is not certified."""
    trace = alpha.sum(axis=0)                                       # = trace(flat)
    lam, ok = _tridiagonal_top_eigenvalue(alpha, beta2, trace)
    if not ok.all():
        bad = np.flatnonzero(~ok)
        lam[bad] = np.linalg.eigvalsh(flat[bad])[:, -1]
    return lam


def group_square_coherence_bins(spectra: np.ndarray, *, method: str = "auto") -> np.ndarray:
    """G2 per bin from segment spectra (..., n_seg, n_bins, N) -> (..., n_bins).

    The same value as ``group_square_coherence(csd)`` bin by bin, computed from the
    segments normalised per channel: C = Y^H Y with Y (n_seg x N), whose non-zero
    eigenvalues are those of Y Y^H (n_seg x n_seg); the smaller one is solved.
    ``method``: "eigvalsh" (LAPACK per matrix, exact), "tridiagonal"
    (:func:`_largest_eigenvalue_gram`: vectorised across all bins, within 1e-12 x N of
    it, certified, eigvalsh where not) or "auto" (tridiagonal from 1024 matrices on, where
    it is faster)."""
    x = np.moveaxis(np.asarray(spectra), -3, -2)                   # (..., bins, seg, N)
    power = (x.real ** 2 + x.imag ** 2).sum(axis=-2)                # (..., bins, N)
    inv = np.where(power > 0, 1.0 / np.sqrt(np.where(power > 0, power, 1.0)), 0.0)
    y = np.ascontiguousarray(x * inv[..., None, :])
    return _g2_from_normalised(y, method)


def _g2_from_normalised(y: np.ndarray, method: str) -> np.ndarray:
    """G2 from channel-normalised segments y (..., n_seg, N) (unit norm over segments, or
    zero) through the smaller Gram matrix."""
    if method not in ("auto", "eigvalsh", "tridiagonal"):
        raise ValueError(f"`method` must be 'auto', 'eigvalsh' or 'tridiagonal', got "
                         f"{method!r}")
    n_seg, n = y.shape[-2], y.shape[-1]
    if n_seg < n:
        gram = y @ np.swapaxes(y.conj(), -1, -2)                     # (..., seg, seg)
    else:
        gram = np.swapaxes(y.conj(), -1, -2) @ y                     # (..., N, N)
    n_mat = int(np.prod(gram.shape[:-2]))
    if method == "eigvalsh" or (method == "auto" and n_mat < _MIN_VECTORISED):
        lam1 = np.linalg.eigvalsh(gram)[..., -1]
    else:
        lam1 = _largest_eigenvalue_gram(gram)
    return _g2_from_lambda(lam1, n)


def _normalised_segments(a: np.ndarray, nperseg: int, noverlap: int) -> np.ndarray:
    """Windows a (w, n_samples, N) -> channel-normalised segment spectra y complex
    (w, n_bins, n_seg, N): Hann (periodic) segments, mean removed, one-sided FFT, each
    channel scaled to unit norm over the segments per bin (0 for a channel without power
    in the bin). The density scaling of :func:`segment_spectra` is left out: it is one
    factor per bin and cancels in the coherence."""
    from scipy import fft as sfft

    n = a.shape[1]
    n_seg = welch_segment_count(n, nperseg, noverlap)
    step = nperseg - noverlap
    taper = np.hanning(nperseg + 1)[:-1]
    # (w, seg, nperseg, N): each segment a contiguous block of the window, channels last
    segs = np.swapaxes(np.lib.stride_tricks.sliding_window_view(a, nperseg, axis=1)[
        :, : n_seg * step : step], -1, -2)
    spec = sfft.rfft(segs * taper[:, None], axis=-2)                # (w, seg, bins, N)
    # segment means from sums over blocks of gcd(step, nperseg) samples
    blk = math.gcd(step, nperseg)
    used = (n_seg - 1) * step + nperseg
    sums = np.zeros((a.shape[0], used // blk + 1, a.shape[2]))
    np.cumsum(np.ones(blk) @ a[:, :used].reshape(a.shape[0], used // blk, blk, a.shape[2]),
              axis=1, out=sums[:, 1:])                              # (BLAS: ~8x sum())
    first = np.arange(n_seg) * (step // blk)
    mean = (sums[:, first + nperseg // blk] - sums[:, first]) / nperseg   # (w, seg, N)
    spec[:, :, :2] -= mean[:, :, None, :] * np.fft.rfft(taper)[:2, None]
    power = (spec.real ** 2 + spec.imag ** 2).sum(axis=1)           # (w, bins, N)
    inv = np.where(power > 0, 1.0 / np.sqrt(np.where(power > 0, power, 1.0)), 0.0)
    y = np.empty((a.shape[0], spec.shape[2], n_seg, a.shape[2]), dtype=np.complex128)
    np.multiply(spec.transpose(0, 2, 1, 3), inv[:, :, None, :], out=y)
    return y


def group_square_coherence_windows(x: np.ndarray, rate_hz: float, *, nperseg: int = 256,
                                   noverlap: int | None = None, chunk: int = 128,
                                   workers: int = 1, method: str = "auto"
                                   ) -> tuple[np.ndarray, np.ndarray]:
    """G2 per Welch bin of many windows ``x`` (n_windows, n_samples, N): ``f_hz
    (n_bins,)`` and ``g2`` (n_windows, n_bins), the same values (to ~1e-14) as
    :func:`segment_spectra` + :func:`group_square_coherence_bins`.

    ``chunk`` windows are solved together: their spectra and Gram matrices made 4 windows
    at a time and Householder tridiagonal forms 16 at a time (in cache), then the
    largest eigenvalues of all ``chunk`` x n_bins matrices in one vectorised Laguerre call
    (certified within 1e-12 x N, exact ``eigvalsh`` for the rest). Chunks run on
    ``workers`` threads (numpy's and scipy's FFT, products and ufuncs release the GIL).
    ``method``: "tridiagonal" as just described, "auto" (the default) the same but LAPACK
    ``eigvalsh`` per bin for a chunk of fewer than 1024 matrices (one window alone: faster
    there), "eigvalsh" the reference path
    (:func:`segment_spectra` + :func:`group_square_coherence_bins` with LAPACK)."""
    a = np.asarray(x, dtype=np.float64)
    if a.ndim != 3:
        raise ValueError(f"`x` must be (n_windows, n_samples, n_channels), got shape {a.shape}")
    if chunk < 1 or workers < 1:
        raise ValueError(f"`chunk` (={chunk}) and `workers` (={workers}) must be >= 1")
    if not rate_hz > 0:
        raise ValueError(f"`rate_hz` (={rate_hz}) must be positive")
    noverlap = nperseg // 2 if noverlap is None else int(noverlap)
    _check_segments(a.shape[1], nperseg, noverlap)
    if a.shape[2] < 2:
        raise ValueError(f"group coherence needs at least 2 channels, got {a.shape[2]}")
    f = np.fft.rfftfreq(nperseg, 1.0 / rate_hz)

    def part(start: int) -> np.ndarray:
        block = a[start:start + chunk]
        if method == "eigvalsh":
            _, spectra = segment_spectra(block, rate_hz, nperseg=nperseg, noverlap=noverlap)
            return group_square_coherence_bins(spectra, method="eigvalsh")
        n_seg, n, nb = welch_segment_count(a.shape[1], nperseg, noverlap), a.shape[2], len(f)
        m = min(n_seg, n)
        lapack = m == 1 or (method == "auto" and len(block) * nb < _MIN_VECTORISED)
        gram = np.empty((len(block), nb, m, m), dtype=np.complex128)
        alpha = np.empty((m, len(block) * nb))
        beta2 = np.empty((m - 1, len(block) * nb))
        for s in range(0, len(block), _FFT_WINDOWS):
            y = _normalised_segments(block[s:s + _FFT_WINDOWS], nperseg, noverlap)
            g = gram[s:s + _FFT_WINDOWS]
            if n_seg < n:
                np.matmul(y, np.swapaxes(y.conj(), -1, -2), out=g)
            else:
                np.matmul(np.swapaxes(y.conj(), -1, -2), y, out=g)
            done = s + g.shape[0]
            if not lapack and (done % _HH_WINDOWS == 0 or done == len(block)):
                # tridiagonal forms of the last _HH_WINDOWS windows' matrices (still in
                # cache; fewer matrices per call would pay numpy's per-call overhead)
                first = (done - 1) // _HH_WINDOWS * _HH_WINDOWS
                cols = slice(first * nb, done * nb)
                alpha[:, cols], beta2[:, cols] = _tridiagonal_gram(
                    gram[first:done].reshape(-1, m, m))
        if lapack:
            return _g2_from_lambda(np.linalg.eigvalsh(gram)[..., -1], n)
        lam = _top_eigenvalue_checked(alpha, beta2, gram.reshape(-1, m, m))
        return _g2_from_lambda(lam.reshape(len(block), nb), n)

    if method not in ("auto", "eigvalsh", "tridiagonal"):
        raise ValueError(f"`method` must be 'auto', 'eigvalsh' or 'tridiagonal', got "
                         f"{method!r}")
    # Bit-identical for every `workers`: the chunks are `chunk` windows from multiples of
    # `chunk`, and every chunk runs with one-threaded BLAS (a BLAS call's summation order
    # may change with its own thread count), workers=1 included; workers only share out
    # the chunks.
    starts = range(0, len(a), chunk)
    with _blas_controller().limit(limits=1, user_api="blas"):
        if workers == 1:
            parts = [part(s) for s in starts]
        else:
            from concurrent.futures import ThreadPoolExecutor

            with ThreadPoolExecutor(workers) as pool:
                parts = list(pool.map(part, starts))
    return f, np.concatenate(parts) if parts else np.empty((0, len(f)))


def g2_noise_floor(n_channels: int, n_averages: int, *, trials: int = 200,
                   seed: int = 0) -> float:
    """Mean G2 of independent complex Gaussian channels whose CSD matrix averages
    ``n_averages`` segment-bin products: the upward bias of G2 for incoherent signals
    (large when ``n_averages`` is below ``n_channels``: the matrix is rank-deficient)."""
    if n_channels < 2 or n_averages < 1:
        raise ValueError("`n_channels` must be >= 2 and `n_averages` >= 1")
    rng = np.random.default_rng(seed)
    z = rng.standard_normal((trials, n_averages, n_channels)) + \
        1j * rng.standard_normal((trials, n_averages, n_channels))
    csd = np.einsum("tsi,tsj->tij", z.conj(), z)
    return float(group_square_coherence(csd).mean())
