"""The gel's motion between two frames, block by block: ``data.frames.change: flow``.

A camera-based tactile sensor with a marker skin or a textured gel (GelSight Mini, DIGIT with
markers) shows slip and shear as motion of the gel's pattern. Area-averaging a frame down to
a few pixels blurs the markers away; this measures their motion instead. The grey frame
(ITU-R BT.601 luma) is cut into a grid of ``rows x cols`` blocks of equal size (the
remainder of the image at the bottom and right left out), and each block's shift between
two frames is found by phase correlation: the peak of the inverse FFT of the normalised
cross-power spectrum of the two blocks (each block minus its mean and Hann-windowed), refined
to a fraction of a pixel on each axis from the peak and its larger neighbour (the
correlation of a sub-pixel shift is a sampled sinc: Foroosh, Zerubia and Berthod 2002).

Shifts are in camera pixels, ``dy`` down and ``dx`` right: where the block's content
moved. Phase correlation sees a shift modulo the block size, so a shift is only right when
it is under half a block (and, on a periodic marker grid, under half the marker pitch):
between frames a fraction of a second apart, as the frame input takes them, the gel moves
far less. A block without texture (a flat, saturated or black region) has no peak and gives
a shift near 0. Accuracy on a smoothed-noise texture in blocks of 40 x 40 px
(tests/learn/test_frame_flow.py): every block within 1.25 px for shifts up to about 5 px;
the mean over blocks biased toward 0 by up to about 13 % (content entering at the block's
edges), so read the values as motion, not as a calibrated displacement.

Cost: two FFTs and one inverse FFT of ``rows x cols`` blocks a frame pair (about 3 ms for 48
blocks of 40 x 40 px on one core), deterministic, independent of threads.
"""

from __future__ import annotations

import numpy as np

#: The smallest block side (px) a shift is measured in.
MIN_BLOCK_PX = 8
#: The cross-power spectrum's magnitudes below this are treated as this (blocks without
#: texture: no division by zero, a flat correlation, a shift near 0).
_EPS = 1e-6


def block_size(height_px: int, width_px: int, rows: int, cols: int) -> tuple[int, int]:
    """(block height, block width) in px of a ``rows x cols`` grid on a frame."""
    return height_px // rows, width_px // cols


def _spectra(grey: np.ndarray, rows: int, cols: int) -> np.ndarray:
    """(rows, cols, bh, bw) complex: the FFT of each block, mean removed, Hann-windowed."""
    bh, bw = block_size(grey.shape[0], grey.shape[1], rows, cols)
    blocks = (grey[:rows * bh, :cols * bw].astype(np.float64)
              .reshape(rows, bh, cols, bw).transpose(0, 2, 1, 3))
    blocks = blocks - blocks.mean(axis=(2, 3), keepdims=True)
    window = np.outer(np.hanning(bh), np.hanning(bw))
    return np.fft.fft2(blocks * window)


def _refine(r: np.ndarray, peak: np.ndarray, other: np.ndarray, axis: int) -> np.ndarray:
    """The peak's position along ``axis`` (0: rows, 1: columns) refined to a fraction of a
    pixel, as a signed shift (positions past half the block wrap to negative)."""
    n_rows, n_cols, size = r.shape[0], r.shape[1], r.shape[2 + axis]
    i, j = np.indices((n_rows, n_cols))
    before, after = (peak - 1) % size, (peak + 1) % size
    if axis == 0:
        c0, cm, cp = r[i, j, peak, other], r[i, j, before, other], r[i, j, after, other]
    else:
        c0, cm, cp = r[i, j, other, peak], r[i, j, other, before], r[i, j, other, after]
    # Foroosh, Zerubia and Berthod (2002): the normalised correlation of a sub-pixel
    # shift is a sampled sinc, so the peak and its larger neighbour give the fraction
    side = np.where(cp >= cm, 1.0, -1.0)
    near = np.maximum(cp, cm)
    total = near + np.where(np.abs(c0) > 1e-12, c0, 1e-12)
    delta = side * np.clip(near / total, 0.0, 0.5)
    delta = np.where(near > 0, delta, 0.0)
    shift = peak + delta
    return np.where(shift > size / 2, shift - size, shift)


def block_shifts(before: np.ndarray, after: np.ndarray, rows: int, cols: int) -> np.ndarray:
    """(rows, cols, 2) float64 shifts (dy, dx) in px of each block's content from the grey
    frame ``before`` to the grey frame ``after`` (both (H, W), the same size, blocks of at
    least :data:`MIN_BLOCK_PX` px)."""
    cross = _spectra(after, rows, cols) * np.conj(_spectra(before, rows, cols))
    cross /= np.maximum(np.abs(cross), _EPS)
    r = np.fft.ifft2(cross).real
    flat = r.reshape(rows, cols, -1)
    py, px = np.unravel_index(flat.argmax(axis=-1), r.shape[2:])
    return np.stack([_refine(r, py, px, 0), _refine(r, px, py, 1)], axis=-1)


__all__ = ["MIN_BLOCK_PX", "block_shifts", "block_size"]
