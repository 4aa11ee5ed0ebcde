"""`spectral._tracking`: sliding spectra and band tracking (paper 003, sec. 2.4: an
accelerometer at 2.5 kHz, a spectrogram refreshed at 100 Hz, the peak amplitude in
570-580 Hz or the peak frequency of a resonance, smoothed by a moving average)."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from tactile_cli.spectral import (
    FrameSettings,
    FrameSpectra,
    SpectrumTracker,
    band_peak,
    causal_moving_average,
    frame_spectra,
)

RATE = 2500.0


def _settings(n_fft: int | None = None) -> FrameSettings:
    # 0.1 s frames refreshed every 0.01 s (100 Hz) at 2.5 kHz
    return FrameSettings.from_seconds(RATE, window_s=0.1, hop_s=0.01, n_fft=n_fft)


def test_frame_settings_from_seconds():
    s = _settings()
    assert s == FrameSettings(RATE, 250, 25, 256)       # n_fft: next power of two
    assert _settings(1024).n_fft == 1024
    assert FrameSettings.from_seconds(1000.0, window_s=0.256, hop_s=0.0014).hop == 1
    assert FrameSettings.from_seconds(1000.0, window_s=0.256, hop_s=0.1).n_fft == 256
    np.testing.assert_array_equal(s.f_hz, np.arange(129) * RATE / 256)
    assert dataclasses.is_dataclass(s)
    with pytest.raises(dataclasses.FrozenInstanceError):
        s.hop = 3                                        # type: ignore[misc]


@pytest.mark.parametrize(("kwargs", "message"), [
    ({"rate_hz": 0.0, "window_s": 0.1, "hop_s": 0.01}, r"^`rate_hz` \(=0.0\) must be positive$"),
    ({"rate_hz": RATE, "window_s": 0.001, "hop_s": 0.01},
     r"^`window_s` \(=0.001\) must span at least 4 samples$"),
    ({"rate_hz": RATE, "window_s": 0.1, "hop_s": 0.0001},
     r"^`hop_s` \(=0.0001\) must span at least 1 sample$"),
    ({"rate_hz": RATE, "window_s": 0.1, "hop_s": 0.01, "n_fft": 128},
     r"^`n_fft` \(=128\) must be at least the window \(=250 samples\)$"),
])
def test_frame_settings_errors(kwargs, message):
    rate = kwargs.pop("rate_hz")
    with pytest.raises(ValueError, match=message):
        FrameSettings.from_seconds(rate, **kwargs)


def test_taper_makes_a_sine_peak_at_its_amplitude():
    s = FrameSettings(RATE, 256, 64, 256)
    assert s.taper.shape == (256,)
    np.testing.assert_allclose(s.taper.sum(), 2.0, rtol=1e-12)
    # a sine on bin 60 of amplitude 3: the bin shows 3 (the leakage of its mirror image,
    # 120 bins away, is below 1e-6 of it)
    x = 3.0 * np.sin(2 * np.pi * 60 * np.arange(1000) / 256 + 0.3)
    spec = frame_spectra(x, s)
    np.testing.assert_allclose(spec.magnitude[:, 60], 3.0, rtol=1e-6)


def test_frame_spectra_times_shapes_and_mean_removal():
    s = _settings()
    x = 5.0 + np.random.default_rng(0).standard_normal(1000)
    spec = frame_spectra(x, s)
    assert isinstance(spec, FrameSpectra)
    n_frames = 1 + (1000 - 250) // 25
    assert spec.magnitude.shape == (n_frames, 129)
    # each frame stamped at its last sample: (start + window - 1) / rate
    np.testing.assert_allclose(spec.t_s, (np.arange(n_frames) * 25 + 249) / RATE)
    np.testing.assert_array_equal(spec.f_hz, s.f_hz)
    # each frame equals the FFT of that frame, its mean removed, tapered, padded to n_fft
    k = 7
    frame = x[k * 25:k * 25 + 250]
    want = np.abs(np.fft.rfft((frame - frame.mean()) * s.taper, n=256))
    np.testing.assert_allclose(spec.magnitude[k], want, rtol=1e-12, atol=1e-12)
    # a constant has nothing left once the frame mean is removed
    flat = frame_spectra(np.full(400, 3.25), s)
    assert np.abs(flat.magnitude).max() < 1e-12


def test_frame_spectra_shorter_than_a_window_gives_no_frame():
    s = _settings()
    spec = frame_spectra(np.ones(249), s)
    assert spec.t_s.shape == (0,) and spec.magnitude.shape == (0, 129)
    assert frame_spectra(np.ones(250), s).magnitude.shape == (1, 129)


def test_frame_spectra_rejects_several_channels():
    with pytest.raises(ValueError, match=r"^`x` must be one channel \(n_samples,\), got "
                                         r"shape \(300, 2\)$"):
        frame_spectra(np.zeros((300, 2)), _settings())


def test_band_peak_of_a_tone_in_the_papers_band():
    # 575.3 Hz in the 570-580 Hz band (paper 003), bins every 2.44 Hz: the parabola
    # through the log-amplitudes puts the peak within 0.02 Hz; the amplitude is the
    # largest bin of the band, below the tone's amplitude (the tone lies between bins)
    s = _settings(1024)
    spec = frame_spectra(0.8 * np.sin(2 * np.pi * 575.3 * np.arange(2500) / RATE), s)
    amp, freq = band_peak(spec.magnitude, spec.f_hz, (570.0, 580.0))
    assert amp.shape == freq.shape == (len(spec.t_s),)
    np.testing.assert_allclose(freq, 575.3, atol=0.02)
    inside = (spec.f_hz >= 570.0) & (spec.f_hz <= 580.0)
    np.testing.assert_array_equal(amp, spec.magnitude[:, inside].max(axis=1))
    assert (amp > 0.7).all() and (amp <= 0.8).all()


def test_band_peak_tracks_a_chirp():
    # linear chirp 100 -> 400 Hz over 2 s: each frame's peak is the instantaneous
    # frequency at the frame's middle, (window - 1) / 2 samples before its time stamp
    s = _settings(1024)
    t = np.arange(5000) / RATE
    f0, rate_hz_per_s = 100.0, 150.0
    x = np.cos(2 * np.pi * (f0 * t + 0.5 * rate_hz_per_s * t ** 2))
    spec = frame_spectra(x, s)
    _, freq = band_peak(spec.magnitude, spec.f_hz, (50.0, 500.0))
    middle = spec.t_s - (s.window - 1) / 2 / RATE
    np.testing.assert_allclose(freq, f0 + rate_hz_per_s * middle, atol=0.05)


def test_band_peak_band_edges_are_inclusive_and_one_frame_is_a_row():
    f = np.arange(11) * 10.0
    mag = np.array([0, 1, 2, 3, 9, 3, 2, 1, 0, 0, 0], dtype=float)
    amp, freq = band_peak(mag, f, (40.0, 40.0 + 1e-9))         # one bin, on the edge
    assert amp.tolist() == [9.0] and freq.shape == (1,)
    assert freq[0] == pytest.approx(40.0)                    # symmetric neighbours
    amp, freq = band_peak(mag, f, (50.0, 70.0))              # 50 is the band's maximum
    assert amp.tolist() == [3.0]
    # the refinement moves the peak by half a bin at most
    assert 45.0 <= freq[0] <= 55.0


def test_band_peak_local_finds_a_resonance_not_a_skirt():
    # a strong line (amplitude 100) at 300 Hz beside the band 310-500 Hz, a weaker
    # resonance (5) at 450 Hz in it, above the strong line's Hann sidelobes (< 3): the
    # band's maximum is the strong line's main lobe at the lower edge, the highest local
    # maximum is the resonance
    s = _settings(1024)
    t = np.arange(1000) / RATE
    x = 100.0 * np.sin(2 * np.pi * 300.0 * t) + 5.0 * np.sin(2 * np.pi * 450.0 * t)
    spec = frame_spectra(x, s)
    amp, freq = band_peak(spec.magnitude, spec.f_hz, (310.0, 500.0))
    assert (freq < 312.0).all() and (amp > 10.0).all()
    amp, freq = band_peak(spec.magnitude, spec.f_hz, (310.0, 500.0), local=True)
    np.testing.assert_allclose(freq, 450.0, atol=0.5)
    np.testing.assert_allclose(amp, 5.0, rtol=0.02)


def test_band_peak_local_falls_back_to_the_maximum():
    # a falling skirt with no local maximum inside the band
    f = np.arange(8) * 10.0
    mag = np.array([[8.0, 7, 6, 5, 4, 3, 2, 1]])
    plain = band_peak(mag, f, (20.0, 50.0))
    local = band_peak(mag, f, (20.0, 50.0), local=True)
    assert plain[0].tolist() == local[0].tolist() == [6.0]
    np.testing.assert_array_equal(plain[1], local[1])


@pytest.mark.parametrize("band", [(600.0, 601.0), (580.0, 570.0), (2000.0, 3000.0)])
def test_band_peak_rejects_a_band_without_bins(band):
    f = np.arange(129) * RATE / 256
    lo, hi = band
    with pytest.raises(ValueError, match=rf"^`band_hz` \(=\[{lo}, {hi}\]\) must be an "
                                         r"increasing pair that holds at least one "
                                         r"frequency bin \(bins every 9.77 Hz up to "
                                         r"1250 Hz\)$"):
        band_peak(np.ones((2, 129)), f, band)


def test_moving_average_is_the_causal_trailing_mean():
    x = np.array([1.0, 2.0, 3.0, 4.0, 5.0])
    np.testing.assert_allclose(causal_moving_average(x, 2), [1.0, 1.5, 2.5, 3.5, 4.5])
    np.testing.assert_allclose(causal_moving_average(x, 3), [1.0, 1.5, 2.0, 3.0, 4.0])
    np.testing.assert_array_equal(causal_moving_average(x, 1), x)
    np.testing.assert_allclose(causal_moving_average(x, 50), np.cumsum(x) / np.arange(1, 6))
    assert causal_moving_average(np.zeros(0), 4).shape == (0,)


def test_moving_average_uses_nothing_after_each_sample():
    rng = np.random.default_rng(3)
    x = rng.standard_normal(200)
    y = causal_moving_average(x, 50)
    changed = x.copy()
    changed[120:] += 100.0
    np.testing.assert_array_equal(causal_moving_average(changed, 50)[:120], y[:120])
    np.testing.assert_allclose(y[120], x[71:121].mean(), rtol=1e-12)


def test_moving_average_rejects_empty_windows():
    with pytest.raises(ValueError, match=r"^`n` \(=0\) must be >= 1$"):
        causal_moving_average(np.ones(3), 0)


@pytest.mark.parametrize("chunks", [[1] * 300, [7] * 50, [249, 1, 250, 3], [1000],
                                    [0, 60, 0, 500, 17, 0]])
def test_spectrum_tracker_equals_frame_spectra(chunks):
    s = _settings()
    x = np.random.default_rng(5).standard_normal(sum(chunks))
    want = frame_spectra(x, s)
    tracker = SpectrumTracker(s)
    got, start = [], 0
    for size in chunks:
        part = tracker.push(x[start:start + size])
        assert isinstance(part, FrameSpectra) and part.magnitude.shape[1] == 129
        assert len(part.t_s) == len(part.magnitude)
        got.append(part)
        start += size
    np.testing.assert_array_equal(np.concatenate([g.t_s for g in got]), want.t_s)
    np.testing.assert_allclose(np.concatenate([g.magnitude for g in got]), want.magnitude,
                               rtol=1e-12, atol=1e-12)


def test_spectrum_tracker_pushes_without_a_frame():
    tracker = SpectrumTracker(_settings())
    part = tracker.push(np.ones(100))
    assert part.t_s.shape == (0,) and part.magnitude.shape == (0, 129)
    part = tracker.push(np.ones(150))                          # 250: the first frame
    np.testing.assert_allclose(part.t_s, [249 / RATE])
