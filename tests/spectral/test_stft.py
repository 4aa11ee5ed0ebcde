"""`spectral._stft`: paper 001's STFT settings (sec. 5.3) and the numpy spectrogram.

The paper slides the STFT by half its length and needs at least nine columns for its CNN;
windows of 400, 200, 100 and 50 samples get STFT lengths 80/40/20/10, 40/20/10, 20/10 and
10, windows of 25 and 10 none."""

from __future__ import annotations

import numpy as np
import pytest

from tactile_cli.spectral import STFT_LENGTHS, spectrogram, stft_hop, stft_lengths


def _frames(window: int, n_fft: int) -> int:
    """Columns of an unpadded STFT of ``window`` samples with the paper's hop."""
    return 1 + (window - n_fft) // stft_hop(n_fft)


def test_stft_lengths_are_the_papers():
    assert STFT_LENGTHS == {400: (80, 40, 20, 10), 200: (40, 20, 10), 100: (20, 10),
                            50: (10,)}
    for window, lengths in STFT_LENGTHS.items():
        assert stft_lengths(window) == lengths
    assert stft_lengths(25) == () and stft_lengths(10) == () and stft_lengths(1) == ()


def test_stft_lengths_are_those_that_give_the_cnn_nine_columns():
    # the paper's reason for its table: of 80, 40, 20, 10 exactly the lengths whose
    # spectrogram has >= 9 columns; windows of 25 and 10 samples have none
    for window in (400, 200, 100, 50, 25, 10):
        fit = tuple(n for n in (80, 40, 20, 10) if n <= window and _frames(window, n) >= 9)
        assert stft_lengths(window) == fit, window
    for window, lengths in STFT_LENGTHS.items():
        assert _frames(window, lengths[0]) == 9          # the longest: exactly nine


def test_stft_lengths_rejects_an_empty_window():
    with pytest.raises(ValueError, match=r"^`window` \(=0\) must be >= 1$"):
        stft_lengths(0)


@pytest.mark.parametrize(("n_fft", "hop"), [(80, 40), (40, 20), (20, 10), (10, 5), (2, 1),
                                            (11, 5), (3, 1)])
def test_stft_hop_is_half_the_length(n_fft, hop):
    assert stft_hop(n_fft) == hop


def test_stft_hop_rejects_lengths_below_two():
    with pytest.raises(ValueError, match=r"^`n_fft` \(=1\) must be >= 2$"):
        stft_hop(1)


def test_spectrogram_shape_and_channel_order():
    # channel 0 a cosine on bin 3 of a 40-sample STFT, channel 1 on bin 7: rows of
    # channel 0 come first, 21 rows per channel, 1 + (200 - 40) // 20 = 9 columns
    k, w, n_fft = 2, 200, 40
    t = np.arange(w)
    x = np.zeros((k, w, 2))
    x[:, :, 0] = np.cos(2 * np.pi * 3 * t / n_fft)
    x[:, :, 1] = 2.0 * np.cos(2 * np.pi * 7 * t / n_fft)
    s = spectrogram(x, n_fft, log=False)
    assert s.shape == (k, 2 * 21, 9) and s.dtype == np.float32
    rows = n_fft // 2 + 1
    assert (s[:, :rows].argmax(axis=1) == 3).all()
    assert (s[:, rows:].argmax(axis=1) == 7).all()
    # periodic Hann of n samples: a bin-centred cosine of amplitude A gives A n / 4 on its
    # bin and A n / 8 on each neighbour, nothing elsewhere
    np.testing.assert_allclose(s[:, 3], 40 / 4, rtol=1e-6)
    np.testing.assert_allclose(s[:, [2, 4]], 40 / 8, rtol=1e-6)
    np.testing.assert_allclose(s[:, rows + 7], 2 * 40 / 4, rtol=1e-6)
    others = np.ones(rows, dtype=bool)
    others[[2, 3, 4]] = False
    assert np.abs(s[:, :rows][:, others]).max() < 1e-5


def test_spectrogram_constant_keeps_its_mean_and_log_is_log1p():
    # no mean removal: a constant c gives c n / 2 at DC and c n / 4 in bin 1
    x = np.full((1, 50, 1), 3.0)
    s = spectrogram(x, 10, log=False)
    assert s.shape == (1, 6, 1 + (50 - 10) // 5)
    np.testing.assert_allclose(s[0, 0], 3.0 * 10 / 2, rtol=1e-6)
    np.testing.assert_allclose(s[0, 1], 3.0 * 10 / 4, rtol=1e-6)
    assert np.abs(s[0, 2:]).max() < 1e-5
    np.testing.assert_allclose(spectrogram(x, 10), np.log1p(s), rtol=1e-6)


def test_spectrogram_columns_are_frames_every_hop():
    rng = np.random.default_rng(0)
    x = rng.standard_normal((3, 100, 2))
    n_fft, hop = 20, 7
    s = spectrogram(x, n_fft, hop=hop, log=False)
    assert s.shape == (3, 2 * 11, 1 + (100 - 20) // 7)
    taper = 0.5 - 0.5 * np.cos(2 * np.pi * np.arange(n_fft) / n_fft)     # periodic Hann
    for col in (0, 5, s.shape[2] - 1):
        frame = x[1, col * hop:col * hop + n_fft, 1]
        want = np.abs(np.fft.rfft(frame * taper))
        np.testing.assert_allclose(s[1, 11:, col], want, rtol=1e-5, atol=1e-5)


@pytest.mark.parametrize(("shape", "n_fft", "hop", "message"), [
    ((100, 2), 20, None, r"^`windows` must be \(k, w, c\), got shape \(100, 2\)$"),
    ((1, 10, 2), 20, None, r"^`n_fft` \(=20\) must be between 2 and the window \(=10\)$"),
    ((1, 10, 2), 1, 1, r"^`n_fft` \(=1\) must be between 2 and the window \(=10\)$"),
    ((1, 10, 2), 4, 0, r"^`hop` \(=0\) must be >= 1$"),
])
def test_spectrogram_errors(shape, n_fft, hop, message):
    with pytest.raises(ValueError, match=message):
        spectrogram(np.zeros(shape), n_fft, hop=hop)
