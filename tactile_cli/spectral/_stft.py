"""Short-time Fourier spectrograms of windows, with paper 001's STFT settings (sec. 5.3).

The paper turns each channel of a window into a spectrogram (STFT step = half the STFT
length), stacks the channels' matrices row by row and feeds the image to a CNN that needs
at least 9 rows and columns, so windows of 25 and 10 samples get no CNN. STFT lengths per
window length (samples)::

    400: 80, 40, 20, 10      200: 40, 20, 10      100: 20, 10      50: 10

The CNN of :mod:`tactile_cli.learn.models` (``cnn2d_spectrogram``) computes the same
transform in torch (``n_fft`` = STFT length, ``hop`` = :func:`stft_hop`); this numpy
version is for looking at data and for tests.
"""

from __future__ import annotations

import numpy as np

#: STFT lengths (samples) that paper 001 used for each window length (samples).
STFT_LENGTHS: dict[int, tuple[int, ...]] = {400: (80, 40, 20, 10), 200: (40, 20, 10),
                                            100: (20, 10), 50: (10,)}


def stft_lengths(window: int) -> tuple[int, ...]:
    """The STFT lengths paper 001 used for windows of ``window`` samples (empty: no CNN)."""
    if window < 1:
        raise ValueError(f"`window` (={window}) must be >= 1")
    return STFT_LENGTHS.get(int(window), ())


def stft_hop(n_fft: int) -> int:
    """Samples between STFT frames: half the STFT length (paper 001, sec. 5.3)."""
    if n_fft < 2:
        raise ValueError(f"`n_fft` (={n_fft}) must be >= 2")
    return n_fft // 2


def spectrogram(windows: np.ndarray, n_fft: int, *, hop: int | None = None,
                log: bool = True) -> np.ndarray:
    """(k, w, c) windows -> (k, c * (n_fft // 2 + 1), n_frames) float32 spectrograms.

    Hann-windowed magnitude STFT of each channel without padding (frames start every
    ``hop`` samples, default :func:`stft_hop`; ``n_frames = 1 + (w - n_fft) // hop``), the
    channels' matrices stacked row by row (channel 0's frequency rows first), as the paper
    does. ``log``: ``log(1 + |X|)`` instead of ``|X|``.
    """
    x = np.asarray(windows, dtype=np.float64)
    if x.ndim != 3:
        raise ValueError(f"`windows` must be (k, w, c), got shape {x.shape}")
    hop = stft_hop(n_fft) if hop is None else hop
    k, w, c = x.shape
    if not 2 <= n_fft <= w:
        raise ValueError(f"`n_fft` (={n_fft}) must be between 2 and the window (={w})")
    if hop < 1:
        raise ValueError(f"`hop` (={hop}) must be >= 1")
    starts = np.arange(0, w - n_fft + 1, hop)
    frames = x[:, starts[:, None] + np.arange(n_fft), :]           # (k, t, n_fft, c)
    taper = np.hanning(n_fft + 1)[:-1]                              # periodic Hann
    mag = np.abs(np.fft.rfft(frames * taper[None, None, :, None], axis=2))  # (k, t, f, c)
    if log:
        mag = np.log1p(mag)
    return mag.transpose(0, 3, 2, 1).reshape(k, c * (n_fft // 2 + 1), len(starts)) \
        .astype(np.float32)
