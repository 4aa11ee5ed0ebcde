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

Rank deficiency: a CSD matrix averaged over ``n_avg`` segment-bin products has rank at most
``n_avg``; with ``n_avg < n_channels`` independent noise still shows lambda1 >= N / n_avg
and G2 is biased upward (:func:`g2_noise_floor` gives the expected value). Results carry
the count so callers can flag it.
"""

from __future__ import annotations

import numpy as np

_TINY = 1e-300


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


def group_square_coherence_bins(spectra: np.ndarray) -> np.ndarray:
    """G2 per bin from segment spectra (..., n_seg, n_bins, N) -> (..., n_bins).

    The same value as ``group_square_coherence(csd)`` bin by bin, computed from the
    segments normalised per channel: C = Y^H Y with Y (n_seg x N), whose non-zero
    eigenvalues are those of Y Y^H (n_seg x n_seg); the smaller one is solved."""
    x = np.moveaxis(np.asarray(spectra), -3, -2)                   # (..., bins, seg, N)
    power = (x.real ** 2 + x.imag ** 2).sum(axis=-2)                # (..., bins, N)
    inv = np.where(power > 0, 1.0 / np.sqrt(np.maximum(power, _TINY)), 0.0)
    y = np.ascontiguousarray(x * inv[..., None, :])
    n_seg, n = y.shape[-2], y.shape[-1]
    if n_seg < n:
        gram = y @ np.swapaxes(y.conj(), -1, -2)                     # (..., bins, seg, seg)
    else:
        gram = np.swapaxes(y.conj(), -1, -2) @ y                     # (..., bins, N, N)
    lam1 = np.linalg.eigvalsh(gram)[..., -1]
    return _g2_from_lambda(lam1, n)


def group_square_coherence_windows(x: np.ndarray, rate_hz: float, *, nperseg: int = 256,
                                   noverlap: int | None = None, chunk: int = 16,
                                   workers: int = 1) -> tuple[np.ndarray, np.ndarray]:
    """G2 per Welch bin of many windows ``x`` (n_windows, n_samples, N): ``f_hz
    (n_bins,)`` and ``g2`` (n_windows, n_bins), the same values as
    :func:`segment_spectra` + :func:`group_square_coherence_bins`, computed ``chunk``
    windows at a time (small arrays stay in cache) on ``workers`` threads (numpy's FFT,
    products and eigensolvers release the GIL)."""
    a = np.asarray(x, dtype=np.float64)
    if a.ndim != 3:
        raise ValueError(f"`x` must be (n_windows, n_samples, n_channels), got shape {a.shape}")
    if chunk < 1 or workers < 1:
        raise ValueError(f"`chunk` (={chunk}) and `workers` (={workers}) must be >= 1")
    f = np.fft.rfftfreq(nperseg, 1.0 / rate_hz)

    def part(start: int) -> np.ndarray:
        _, spectra = segment_spectra(a[start:start + chunk], rate_hz, nperseg=nperseg,
                                     noverlap=noverlap)
        return group_square_coherence_bins(spectra)

    starts = range(0, len(a), chunk)
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
