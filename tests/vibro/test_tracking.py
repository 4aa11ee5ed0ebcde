"""Sliding spectra and band tracking of :mod:`tactile_cli.spectral` (paper 003, sec. 2.4)."""

from __future__ import annotations

import numpy as np
import pytest

from tactile_cli.spectral import (
    FrameSettings,
    SpectrumTracker,
    band_peak,
    causal_moving_average,
    frame_spectra,
)


def test_band_peak_recovers_a_tone_amplitude_and_frequency():
    fs = 2500.0
    t = np.arange(int(2 * fs)) / fs
    x = 0.3 * np.sin(2 * np.pi * 576.3 * t) + 1.0 * np.sin(2 * np.pi * 130 * t)
    settings = FrameSettings.from_seconds(fs, window_s=0.2, hop_s=0.01, n_fft=2048)
    spectra = frame_spectra(x, settings)
    assert len(spectra.t_s) == 1 + (len(x) - 500) // 25
    assert spectra.t_s[0] == pytest.approx(499 / fs)          # stamped at its last sample
    amp, f = band_peak(spectra.magnitude, spectra.f_hz, (570, 580))
    np.testing.assert_allclose(f, 576.3, atol=0.15)
    np.testing.assert_allclose(amp, 0.3, rtol=0.05)
    _, f_local = band_peak(spectra.magnitude, spectra.f_hz, (131.5, 250), local=True)
    assert not np.allclose(f_local, 131.5)   # the 130 Hz skirt is not a peak of the band


def test_tracker_gives_the_offline_frames_whatever_the_chunks():
    rng = np.random.default_rng(0)
    x = rng.standard_normal(3000)
    settings = FrameSettings.from_seconds(2500.0, window_s=0.2, hop_s=0.01)
    offline = frame_spectra(x, settings)
    tracker = SpectrumTracker(settings)
    cuts = np.sort(rng.choice(np.arange(1, 3000), 40, replace=False))
    parts = [tracker.push(chunk) for chunk in np.split(x, cuts)]
    np.testing.assert_allclose(np.concatenate([p.t_s for p in parts]), offline.t_s)
    np.testing.assert_allclose(np.vstack([p.magnitude for p in parts]), offline.magnitude,
                               atol=1e-12)


def test_causal_moving_average_is_causal_and_errors_name_arguments():
    np.testing.assert_allclose(causal_moving_average(np.array([1.0, 3, 5, 7]), 2), [1, 2, 4, 6])
    with pytest.raises(ValueError, match="`band_hz`"):
        band_peak(np.ones((2, 5)), np.arange(5.0), (10, 20))
    with pytest.raises(ValueError, match="`window_s`"):
        FrameSettings.from_seconds(100.0, window_s=0.01, hop_s=0.01)
