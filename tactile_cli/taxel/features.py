"""Slip-interface features of taxel arrays (paper 004, secs. 3 and 5.2): arrays in, arrays
out, vectorised over trials, bins and bands.

- :func:`contact_taxels`: the taxels in contact, from an at-rest segment without contact;
- :func:`above_noise_floor`: the noise-floor gate (no decision below it).

Gamma and G2 per band (``array_features``, ``multi_finger_g2``, ``band_grid``) are in
:mod:`tactile_cli.spectral`, for any multichannel stream.
"""

from __future__ import annotations

import numpy as np


def contact_taxels(rest: np.ndarray, slip: np.ndarray, threshold: float) -> np.ndarray:
    """(..., N) bool: taxels in contact during ``slip`` (..., n_s, N) judged against the
    at-rest, no-contact segment ``rest`` (..., n_r, N) (sec. 5.2.1).

    A taxel is in contact when its mean shifts by more than ``threshold`` at-rest standard
    deviations; on a dynamic-only array (no taxel's mean shifts) when its RMS about the
    mean exceeds ``threshold`` at-rest standard deviations. Fewer than two taxels found:
    all taxels (nothing to compare otherwise)."""
    sigma = np.maximum(rest.std(axis=-2), 1e-12)
    shift = np.abs(slip.mean(axis=-2) - rest.mean(axis=-2)) / sigma
    rms = slip.std(axis=-2) / sigma
    by_shift = shift > threshold
    static = by_shift.any(axis=-1, keepdims=True)
    mask = np.where(static, by_shift, rms > threshold)
    return np.where(mask.sum(axis=-1, keepdims=True) >= 2, mask, True)


def above_noise_floor(rest: np.ndarray, slip: np.ndarray, ratio: float) -> np.ndarray:
    """(...,) bool: some taxel's slip RMS (about its mean, (..., n_s, N)) exceeds its
    at-rest noise (..., n_r, N) by ``ratio``; False: the signals lie at the noise floor and
    no slip decision should be made (sec. 6)."""
    sigma = np.maximum(rest.std(axis=-2), 1e-12)
    return (slip.std(axis=-2) / sigma > ratio).any(axis=-1)
