"""The taxel-array chain: scene, contact estimation, gate, classifier, feature stream."""

from __future__ import annotations

import numpy as np
import pytest
from sklearn.naive_bayes import GaussianNB

from tactile_cli.errors import InputError
from tactile_cli.spectral import band_grid
from tactile_cli.store.trials import TactileFile
from tactile_cli.taxel import (
    FeatureConfig,
    TaxelSceneConfig,
    slip_interface,
    write_taxel_features,
)
from tactile_cli.taxel.config import default_presets
from tactile_cli.taxel.features import above_noise_floor, contact_taxels
from tactile_cli.taxel.pipeline import (
    gnb_predict,
    preset_features,
    read_preset_trials,
    stratified_folds,
)
from tactile_cli.taxel.simulate import simulate_trial


def test_presets_follow_the_paper():
    p = default_presets()
    assert (p["biotac"].n_taxels, p["biotac"].rate_hz, p["biotac"].pressure_rate_hz) == \
        (19, 100.0, 4400.0)
    assert (p["capacitive"].n_taxels, p["capacitive"].rate_hz) == (12, 300.0)
    assert (p["pvdf"].n_taxels, p["pvdf"].rate_hz, p["pvdf"].sequential) == (8, 3125.0, False)
    d = p["capacitive"].delays_s()
    np.testing.assert_allclose(np.diff(d), 1 / 3600)
    assert p["biotac"].delays_s()[-1] < 1 / 100
    assert not p["pvdf"].delays_s().any()


def test_scene_config_refuses_unknown_keys():
    with pytest.raises(ValueError):
        TaxelSceneConfig.model_validate({"trials": 3})
    with pytest.raises(ValueError):
        FeatureConfig.model_validate({"folds": 10, "bogus": 1})


def test_trials_are_fixed_by_the_seed():
    cfg = TaxelSceneConfig(trials_per_class=1)
    a = simulate_trial(cfg, "capacitive", "hand", 0, 7)
    b = simulate_trial(cfg, "capacitive", "hand", 0, 7)
    c = simulate_trial(cfg, "capacitive", "hand", 0, 8)
    np.testing.assert_array_equal(a.taxels[0], b.taxels[0])
    assert not np.allclose(a.taxels[0], c.taxels[0])
    assert a.taxels[0].shape == (round(2.5 * 300), 12)


@pytest.mark.slow
def test_file_layout_labels_and_delays(taxel_file):
    with TactileFile(taxel_file) as tf:
        trial = tf.trial("biotac_world_000")
        assert trial.labels["origin"] == "simulated"
        assert trial.labels["dataset"] == "taxel-slip seed 101"
        assert trial.labels["slip"] == "world"
        assert [a.label for a in trial.annotations] == ["rest", "slip"]
        assert trial.signal("biotac_f0").data.shape[1] == 19
        assert trial.signal("biotac_pressure").sample_rate_hz == pytest.approx(4400)
        attrs = tf.sensor("biotac_f0").attrs
        assert attrs["sampling"] == "sequential"
        assert attrs["channel_delay_step_s"] == pytest.approx(2 / 4400)
        assert tf.sensor("pvdf_f1").attrs["sampling"] == "simultaneous"


def test_contact_estimation_and_gate():
    rng = np.random.default_rng(0)
    rest = rng.normal(0, 0.01, (100, 6))
    slip = rng.normal(0, 0.01, (200, 6))
    slip[:, 1:4] += 0.5                      # static sensor: three taxels pressed
    np.testing.assert_array_equal(contact_taxels(rest, slip, 4.0),
                                  [False, True, True, True, False, False])
    dyn = rng.normal(0, 0.01, (200, 6))
    dyn[:, [0, 5]] += rng.normal(0, 0.2, (200, 2))   # dynamic sensor: two vibrate
    np.testing.assert_array_equal(contact_taxels(rest, dyn, 4.0),
                                  [True, False, False, False, False, True])
    assert above_noise_floor(rest, dyn, 2.0)
    assert not above_noise_floor(rest, rng.normal(0, 0.01, (200, 6)), 2.0)


def test_band_grid_covers_every_narrow_band():
    lo, hi = band_grid(9, 3)
    assert len(lo) == 8 + 7 + 6 and lo.min() == 1 and hi.max() == 8
    assert ((hi - lo) < 3).all()


def test_gnb_matches_scikit_learn():
    rng = np.random.default_rng(1)
    x = rng.standard_normal((40, 5)) + np.repeat([0, 1], 20)[:, None]
    y = np.repeat([0, 1], 20)
    t = rng.standard_normal((15, 5))
    got = gnb_predict(x, y, t)
    for b in range(5):
        want = GaussianNB().fit(x[:, [b]], y).predict(t[:, [b]])
        np.testing.assert_array_equal(got[:, b], want)


def test_folds_are_stratified_and_independent_of_order():
    names = [f"t{i}" for i in range(30)]
    y = np.array([0] * 12 + [1] * 18)
    folds = stratified_folds(names, y, 6, 0)
    for f in range(6):
        assert 1 <= (y[folds == f] == 0).sum() <= 3
    rev = stratified_folds(names[::-1], y[::-1], 6, 0)
    np.testing.assert_array_equal(rev, folds[::-1])


@pytest.mark.slow
def test_features_separate_the_slip_types(taxel_file):
    with TactileFile(taxel_file) as tf:
        pt = read_preset_trials(tf, "pvdf")
    pf = preset_features(pt, FeatureConfig())
    world = pt.slip_type == "world"
    for name in ("gamma", "g2_single", "g2_multi"):
        full = pf.features[name].full
        assert ((full >= 0) & (full <= 1)).all()
        assert full[world].mean() > full[~world].mean() + 0.2, name
    assert pf.decided.all()


@pytest.mark.slow
def test_slip_interface_nested_accuracy(taxel_file):
    cfg = FeatureConfig(folds=5, inner_folds=3)
    result = slip_interface(taxel_file, cfg)
    table = {(s.preset, s.feature): s for s in result.scores}
    assert len(table) == 9
    for s in table.values():
        assert 0.0 <= s.nested_best_band <= 1.0
        assert len(s.nested_bands_hz) == 5
        assert 0.0 <= s.optimistic_best_band <= 1.0
    # the G2 of 16 electrodes from 5 segments is rank-deficient in narrow bands: flagged
    assert table[("biotac", "g2_single")].rank_deficient_bands > 0
    assert table[("pvdf", "g2_single")].rank_deficient_bands == 0
    assert np.mean([s.full_spectrum for s in table.values()]) > 0.8


@pytest.mark.slow
def test_feature_stream_is_readable(taxel_file, tmp_path):
    out = tmp_path / "features.h5"
    res = write_taxel_features(taxel_file, out, FeatureConfig())
    assert res.n_trials == 60 and "g2_multi_full" in res.channels
    with TactileFile(out) as tf:
        trial = tf.trial("capacitive_world_003")
        sig = trial.signal("spectral_features")
        assert sig.data.shape[1] == 12
        lab = sig.sample_labels["slip"]
        assert lab.classes == ("rest", "hand", "world")
        assert set(np.unique(lab.values)) == {0, 2}
        assert ((sig.data >= 0) & (sig.data <= 1)).all()
        assert trial.labels["origin"] == "simulated"
    with pytest.raises(InputError, match="output exists"):
        write_taxel_features(taxel_file, out, FeatureConfig())


def test_shipped_configs_repeat_the_defaults():
    from pathlib import Path

    from tactile_cli.taxel import load_feature_config, load_taxel_scene_config

    root = Path(__file__).resolve().parents[2] / "configs"
    assert load_feature_config(root / "taxel_features.yaml") == FeatureConfig()
    assert load_taxel_scene_config(root / "scene_taxel_slip.yaml") == TaxelSceneConfig()
