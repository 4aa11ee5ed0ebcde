"""Per-band power ratio and group square coherence of sensor arrays (paper 004, secs. 3.1-3.2):
the combinations of :mod:`._coherence` that a classifier of any multichannel stream uses.

- :func:`band_grid`: every band of 1 .. ``max_bins`` Welch bins (a best-band search);
- :func:`band_centre_width_hz`: the paper's (f, w) of each band;
- :func:`masked_g2`: G2 (eq. 34) of a subset of channels (the ones in contact);
- :func:`array_features`: Gamma (eq. 6, with the sequential-sampling correction of eq. 7)
  and G2 of one array's windows, per band;
- :func:`finger_ensembles`, :func:`multi_finger_g2`: G2 across arrays (fingers), each array
  one delay-corrected virtual channel.

Arrays in, arrays out (numpy only), vectorised over windows, bins and bands; first used by
the taxel chain (:mod:`tactile_cli.taxel`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ._coherence import (
    band_sums,
    coherence_matrix,
    local_ensemble_power,
    power_ratio,
    segment_spectra,
)


def band_grid(n_bins: int, max_bins: int) -> tuple[np.ndarray, np.ndarray]:
    """Every band of consecutive Welch bins 1 .. n_bins - 1 (DC left out) at most
    ``max_bins`` wide: ``(lo_bin, hi_bin)`` (n_bands,) inclusive indices."""
    lo, hi = np.meshgrid(np.arange(1, n_bins), np.arange(1, n_bins), indexing="ij")
    keep = (hi >= lo) & (hi - lo < max_bins)
    return lo[keep], hi[keep]


def band_centre_width_hz(f_hz: np.ndarray, lo_bin: np.ndarray, hi_bin: np.ndarray
                         ) -> tuple[np.ndarray, np.ndarray]:
    """The paper's (f, w) of each band: centre and half-width (Hz) of the bins' span, so
    that the band's bins are k = (f - w) / f0 .. (f + w) / f0 as in eq. 4 (w = 0 for a
    band of one bin)."""
    df = float(f_hz[1] - f_hz[0])
    return (f_hz[lo_bin] + f_hz[hi_bin]) / 2, (hi_bin - lo_bin) * df / 2


def masked_g2(csd: np.ndarray, mask: np.ndarray) -> np.ndarray:
    """G2 (eq. 34) of the channels in ``mask`` (..., N) of CSD matrices (..., N, N) -> (...,)
    (``mask`` broadcast against the matrices' leading axes): the coherence matrix with the
    other rows and columns zeroed has the same largest eigenvalue as the masked channels'
    own."""
    c = coherence_matrix(csd)
    m = np.asarray(mask).astype(np.float64)
    c = c * m[..., :, None] * m[..., None, :]
    n = np.asarray(mask).sum(axis=-1).astype(np.float64)
    lam1 = np.linalg.eigvalsh(c)[..., -1]
    with np.errstate(invalid="ignore", divide="ignore"):
        g = np.clip((lam1 - 1) / (n - 1), 0.0, 1.0) ** 2
    return np.where(n >= 2, g, np.nan)


@dataclass(frozen=True)
class ArrayFeatures:
    """Gamma and single-finger G2 of one array per band: ``gamma``, ``g2`` (..., n_bands);
    ``n_averages`` (n_bands,): segment-bin products behind each band's CSD matrix (below
    the contact taxel count the matrix is rank-deficient and G2 biased upward)."""

    f_hz: np.ndarray
    gamma: np.ndarray
    g2: np.ndarray
    n_averages: np.ndarray
    spectra: np.ndarray


def array_features(x: np.ndarray, rate_hz: float, lo_bin: np.ndarray, hi_bin: np.ndarray, *,
                   nperseg: int, noverlap: int | None = None,
                   delays_s: np.ndarray | None = None,
                   contact: np.ndarray | None = None) -> ArrayFeatures:
    """Gamma and G2 of windows ``x`` (..., n_samples, N) in the bands ``lo_bin..hi_bin``.

    Welch segments of ``nperseg`` samples, ``noverlap`` shared (default half).
    ``delays_s`` (N,): sampling delays for eq. 7 (None: simultaneous); ``contact``
    (..., N) bool: taxels in contact (default all)."""
    f, spectra = segment_spectra(x, rate_hz, nperseg=nperseg, noverlap=noverlap)
    n_seg = spectra.shape[-3]
    csd = np.einsum("...ski,...skj->...kij", spectra.conj(), spectra) / n_seg
    n = x.shape[-1]
    mask = np.ones(x.shape[:-2] + (n,), dtype=bool) if contact is None \
        else np.broadcast_to(contact, x.shape[:-2] + (n,))
    local, ensemble = local_ensemble_power(csd, f, lo_bin, hi_bin, delays_s=delays_s,
                                           contact=mask)
    gamma = power_ratio(local, ensemble, mask.sum(axis=-1)[..., None])
    band_csd = band_sums(csd, lo_bin, hi_bin, axis=-3)
    g2 = masked_g2(band_csd, mask[..., None, :])
    return ArrayFeatures(f, gamma, g2, n_seg * (np.asarray(hi_bin) - lo_bin + 1), spectra)


def finger_ensembles(features: list[ArrayFeatures], delays_s: np.ndarray | None,
                     contacts: list[np.ndarray]) -> np.ndarray:
    """(..., n_seg, n_bins, fingers): each finger's contact taxels summed into one
    virtual taxel in the frequency domain, sampling delays undone (eq. 7)."""
    out = []
    for feat, contact in zip(features, contacts, strict=True):
        n = feat.spectra.shape[-1]
        if delays_s is None:
            v = np.ones((len(feat.f_hz), n), dtype=np.complex128)
        else:
            v = np.exp(-2j * np.pi * feat.f_hz[:, None] * np.asarray(delays_s)[None, :])
        w = v * np.asarray(contact, dtype=np.float64)[..., None, None, :]
        out.append((feat.spectra * w).sum(axis=-1))
    return np.stack(out, axis=-1)


def multi_finger_g2(spectra: np.ndarray, lo_bin: np.ndarray, hi_bin: np.ndarray
                    ) -> np.ndarray:
    """G2 across fingers per band from per-finger spectra (..., n_seg, n_bins, fingers)
    -> (..., n_bands)."""
    n_seg = spectra.shape[-3]
    csd = np.einsum("...ski,...skj->...kij", spectra.conj(), spectra) / n_seg
    band_csd = band_sums(csd, lo_bin, hi_bin, axis=-3)
    mask = np.ones(band_csd.shape[:-2] + (spectra.shape[-1],), dtype=bool)
    return masked_g2(band_csd, mask)
