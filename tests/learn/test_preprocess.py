"""Preprocessing that survives drift: baselines, window normalisations, level-free features
and seeded augmentation (issue 34, item 2)."""

from __future__ import annotations

import numpy as np
import pytest
import torch
from pydantic import ValidationError

from tactile_cli.learn.config import LEVEL_FREE_FEATURES, AugmentConfig, BaselineConfig
from tactile_cli.learn.data import TrialSeries, summary_features, trial_samples
from tactile_cli.learn.models import SummaryFeatures
from tactile_cli.learn.preprocess import (
    add_offset,
    apply_gain,
    augment_windows,
    baseline_level,
    drop_channels,
    normalise_windows,
    remove_baseline,
    stretch_time,
)

from .conftest import tiny_config


def test_baseline_removal_recovers_a_known_resting_offset():
    rng = np.random.default_rng(0)
    t_s = np.arange(400) / 100.0  # 4 s at 100 Hz
    offset = np.array([812.5, -40.0])
    touch = np.where(t_s >= 0.5, 30.0 * np.sin(2 * np.pi * 7 * t_s), 0.0)  # contact at 0.5 s
    clean = np.stack([touch, 0.5 * touch], axis=1) + 0.01 * rng.standard_normal((400, 2))
    x = (clean + offset).astype(np.float32)
    level = baseline_level(x, t_s, mode="start", duration_ms=300)
    np.testing.assert_allclose(level, offset, atol=0.01)  # the mean of 30 resting samples
    np.testing.assert_allclose(remove_baseline(x, t_s, mode="start", duration_ms=300), clean,
                               atol=0.01)


def test_baseline_levels_exact_on_small_arrays():
    x = np.array([[1.0, 10.0], [3.0, 20.0], [8.0, 90.0], [100.0, 30.0]], np.float32)
    t_s = np.array([0.0, 0.01, 0.02, 0.03])
    np.testing.assert_array_equal(baseline_level(x, t_s, mode="start", duration_ms=20),
                                  [2.0, 15.0])  # samples before 20 ms: the first two
    np.testing.assert_array_equal(baseline_level(x, t_s, mode="start", duration_ms=1),
                                  [1.0, 10.0])  # at least the first sample
    np.testing.assert_array_equal(baseline_level(x, t_s, mode="median"), [5.5, 25.0])
    np.testing.assert_array_equal(remove_baseline(x, t_s, mode="median"),
                                  x - np.array([5.5, 25.0], np.float32))
    np.testing.assert_array_equal(remove_baseline(x, t_s, mode="none"), x)
    trial = TrialSeries("f.h5", "t", "", x, t_s)
    np.testing.assert_array_equal(trial_samples(trial, BaselineConfig(mode="median")),
                                  x - np.array([5.5, 25.0], np.float32))
    assert trial_samples(trial, BaselineConfig()) is x


def test_window_normalisations_exact():
    w = np.array([[[1.0, 5.0], [2.0, 5.0], [3.0, 5.0], [6.0, 5.0]]], np.float32)  # (1, 4, 2)
    np.testing.assert_array_equal(normalise_windows(w, "none"), w)
    np.testing.assert_array_equal(normalise_windows(w, "center")[0, :, 0], [-2, -1, 0, 3])
    np.testing.assert_allclose(normalise_windows(w, "zscore")[0, :, 0],
                               np.array([-2, -1, 0, 3]) / np.sqrt(3.5), rtol=1e-6)
    np.testing.assert_allclose(normalise_windows(w, "center_scale")[0, :, 0],
                               [-2 / 3, -1 / 3, 0, 1], rtol=1e-6)
    for mode in ("center", "zscore", "center_scale"):  # a constant channel becomes zeros
        np.testing.assert_array_equal(normalise_windows(w, mode)[0, :, 1], 0.0)
    with pytest.raises(ValueError, match="must be one of none, center, zscore"):
        normalise_windows(w, "minmax")


def test_level_free_features_exact_and_blind_to_an_offset():
    w = np.array([[[1.0], [2.0], [4.0], [8.0]]], np.float32)
    f = summary_features(w, LEVEL_FREE_FEATURES)[0]
    x = np.array([1.0, 2.0, 4.0, 8.0])
    c = x - x.mean()
    var = (c**2).mean()
    assert f[0] == 7.0  # range
    np.testing.assert_allclose(f[1], np.std([1.0, 2.0, 4.0]), rtol=1e-6)  # diff_std
    np.testing.assert_allclose(f[2], (c**3).mean() / var**1.5, rtol=1e-5)  # skew
    np.testing.assert_allclose(f[3], (c**4).mean() / var**2 - 3, rtol=1e-5)  # kurtosis
    rng = np.random.default_rng(1)
    windows = rng.standard_normal((5, 16, 3)).astype(np.float32)
    names = ("std", "slope", *LEVEL_FREE_FEATURES)
    np.testing.assert_allclose(summary_features(windows + 50.0, names),
                               summary_features(windows, names), atol=2e-4)
    flat = np.zeros((1, 6, 1), np.float32)
    np.testing.assert_array_equal(summary_features(flat, LEVEL_FREE_FEATURES), 0.0)
    layer = SummaryFeatures(("mean", *LEVEL_FREE_FEATURES), 16, 3)
    np.testing.assert_allclose(layer.raw(torch.from_numpy(windows)).numpy(),
                               summary_features(windows, ("mean", *LEVEL_FREE_FEATURES)),
                               rtol=1e-4, atol=1e-5)


def test_augmentations_exact_on_small_arrays():
    w = np.array([[[0.0, 1.0], [2.0, 1.0], [4.0, 1.0]]], np.float32)  # (1, 3, 2)
    np.testing.assert_array_equal(stretch_time(w, np.array([1.0])), w)
    # a band-limited sine of 4 cycles in 64 samples: half and twice its frequency
    i = np.arange(64)
    sine = np.sin(2 * np.pi * 4 * i / 64)[None, :, None].astype(np.float32)
    np.testing.assert_allclose(stretch_time(sine, np.array([0.5]))[0, :, 0],
                               np.sin(2 * np.pi * i / 32), atol=1e-5)
    fast = stretch_time(sine, np.array([2.0]))[0, :, 0]  # 32 samples of content, centred
    np.testing.assert_allclose(fast[16:48], np.sin(2 * np.pi * i[16:48] / 8), atol=1e-5)
    np.testing.assert_allclose(fast[:16], 0.0, atol=1e-5)  # the edges held outward
    np.testing.assert_allclose(fast[48:], np.sin(2 * np.pi * 31 / 8), atol=1e-5)
    rng = np.random.default_rng(3)
    off = add_offset(w, 0.5, np.random.default_rng(3))
    np.testing.assert_allclose(off - w, np.broadcast_to(rng.normal(0, 0.5, (1, 1, 2)),
                                                        w.shape), rtol=1e-6)
    gained = apply_gain(w, 0.3, np.random.default_rng(4))
    np.testing.assert_allclose(gained.mean(axis=1), w.mean(axis=1), rtol=1e-6)  # level kept
    g = np.exp(np.random.default_rng(4).normal(0, 0.3, (1, 1, 2)))[0, 0, 0]
    np.testing.assert_allclose(gained[0, :, 0], 2.0 + g * np.array([-2.0, 0.0, 2.0]),
                               rtol=1e-6)
    np.testing.assert_array_equal(drop_channels(w, 0.0, rng), w)
    np.testing.assert_array_equal(drop_channels(w, 0.999999, rng), 0.0)


def test_augmentation_is_seeded_and_reproducible():
    windows = np.random.default_rng(0).standard_normal((8, 32, 4)).astype(np.float32)
    cfg = AugmentConfig(offset_sd=0.5, gain_sd=0.2, time_stretch=0.1, channel_dropout=0.25)
    a = augment_windows(windows, cfg, np.random.default_rng(7))
    b = augment_windows(windows, cfg, np.random.default_rng(7))
    c = augment_windows(windows, cfg, np.random.default_rng(8))
    np.testing.assert_array_equal(a, b)
    assert not np.array_equal(a, c) and a.dtype == np.float32 and a.shape == windows.shape
    np.testing.assert_array_equal(augment_windows(windows, AugmentConfig(),
                                                  np.random.default_rng(7)), windows)
    with pytest.raises(ValidationError, match="time_stretch"):
        AugmentConfig(time_stretch=1.0)


def test_configs_take_the_new_keys_and_refuse_bad_values():
    cfg = tiny_config(data={"baseline": {"mode": "start", "duration_ms": 250},
                            "window_norm": "zscore", "augment": {"offset_sd": 0.3}},
                      model={"family": "mlp", "hidden": [8],
                             "features": ["std", "range", "diff_std", "skew", "kurtosis"]})
    assert cfg.data.baseline.duration_ms == 250 and cfg.data.augment.active
    assert not tiny_config().data.augment.active
    with pytest.raises(ValidationError):
        BaselineConfig(mode="first")
