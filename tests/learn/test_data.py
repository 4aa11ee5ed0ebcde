"""Datasets from HDF5: windows, targets, splits by trial, normalisation, event counting."""

from __future__ import annotations

import numpy as np
import pytest
import torch

from tactile_cli.errors import InputError
from tactile_cli.learn.config import SUMMARY_FEATURES
from tactile_cli.learn.data import (
    TrialSeries,
    assign_splits,
    class_weights,
    fit_normalisation,
    make_windows,
    read_trials,
    resolve_heads,
    summary_features,
)
from tactile_cli.learn.heads import HeadSpec
from tactile_cli.learn.models import SummaryFeatures

from .conftest import tiny_config

ACTION = HeadSpec("action", "classification", "sample", 1.0, ("a", "b", "c"))


def _trial(n: int, labels: np.ndarray | None = None, name: str = "t0", file: str = "f.h5",
           split: str = "") -> TrialSeries:
    x = np.stack([np.arange(n), 100 + np.arange(n)], axis=1).astype(np.float32)
    lab = np.zeros(n, np.int64) if labels is None else np.asarray(labels, np.int64)
    return TrialSeries(file, name, split, x, np.arange(n) * 0.02, {"action": lab},
                       {"action": ("a", "b", "c")}, {"level": 3})


def _data(**kw):
    base = {"window": 4, "stride": 1, "channels": ["u", "v"], "normalise": False, "pad": "none",
            "transform": "none"}
    base.update(kw)
    return tiny_config(data=base).data


def _identity(channels=("u", "v")):
    return fit_normalisation([_trial(3)], list(channels), enabled=False)


def test_windows_are_exact_slices_with_stride_and_no_padding():
    trial = _trial(11)
    data = _data(window=4, stride=3)
    ws = make_windows([trial], data, [ACTION], _identity())
    # window ends at samples 3, 6, 9: first full window, then every 3 samples
    assert ws.end_index.tolist() == [3, 6, 9]
    for k, end in enumerate(ws.end_index):
        np.testing.assert_array_equal(ws.windows(np.array([k]))[0], trial.x[end - 3:end + 1])


def test_windows_aligned_to_the_end_always_end_at_the_last_sample():
    trial = _trial(11)
    ws = make_windows([trial], _data(window=4, stride=3, align="end"), [ACTION], _identity())
    assert ws.end_index.tolist() == [4, 7, 10]  # back from sample 10, full windows only
    np.testing.assert_array_equal(ws.windows(np.array([2]))[0], trial.x[7:11])
    # one window as long as the longest trial, zero-padded: each trial's last 6 samples
    short, long_ = _trial(3, name="short"), _trial(6, name="long")
    one = make_windows([short, long_], _data(window=6, stride=6, pad="zero", align="end"),
                       [ACTION], _identity())
    assert one.end_index.tolist() == [2, 5] and one.trial_index.tolist() == [0, 1]
    first = one.windows(np.array([0]))[0]
    np.testing.assert_array_equal(first[:3], 0)
    np.testing.assert_array_equal(first[3:], short.x)
    # without padding a trial shorter than the window gives none, as with align: start
    assert make_windows([short], _data(window=6, stride=6, align="end"), [ACTION],
                        _identity()).end_index.tolist() == []


def test_zero_and_edge_padding_give_every_sample_a_causal_window():
    trial = _trial(5)
    zero = make_windows([trial], _data(pad="zero"), [ACTION], _identity())
    assert zero.end_index.tolist() == [0, 1, 2, 3, 4]
    first = zero.windows(np.array([0]))[0]
    np.testing.assert_array_equal(first[:3], 0)  # three padding samples, then sample 0
    np.testing.assert_array_equal(first[3], trial.x[0])
    edge = make_windows([trial], _data(pad="edge"), [ACTION], _identity())
    np.testing.assert_array_equal(edge.windows(np.array([1]))[0],
                                  trial.x[[0, 0, 0, 1]])
    # two trials back to back: windows never straddle them
    two = make_windows([trial, _trial(5, name="t1")], _data(pad="zero"), [ACTION], _identity())
    np.testing.assert_array_equal(two.windows(np.array([5]))[0, :3], 0)


def test_label_rules_last_delay_majority_and_unlabelled_windows():
    labels = np.array([0, 0, 0, 1, 1, 1, 2, 2, -1, -1])
    trial = _trial(10, labels)
    last = make_windows([trial], _data(window=4), [ACTION], _identity())
    assert last.end_index.tolist() == [3, 4, 5, 6, 7]  # ends 8, 9 unlabelled: dropped
    assert last.targets["action"].tolist() == [1, 1, 1, 2, 2]
    delayed = make_windows([trial], _data(window=4, label_delay=2), [ACTION], _identity())
    assert delayed.target_index.tolist() == [1, 2, 3, 4, 5, 6, 7]
    assert delayed.targets["action"].tolist() == [0, 0, 1, 1, 1, 2, 2]
    majority = make_windows([trial], _data(window=4, label_rule="majority"), [ACTION],
                            _identity())
    # windows [0..3] -> 0 (3 of 4), [1..4] -> tie 0/1 -> 0, [2..5] -> 1, ..., [6..9] -> 2
    assert majority.targets["action"].tolist() == [0, 0, 1, 1, 1, 2, 2]
    # target times and the boundary flags (margin 1 around the changes at 2|3, 5|6 and
    # 7|8, where the labelled part ends)
    np.testing.assert_allclose(last.target_t_s, trial.t_s[[3, 4, 5, 6, 7]])
    assert last.near_boundary["action"].tolist() == [True, False, True, True, True]


def test_trial_labels_as_targets_classification_and_regression():
    trials = [_trial(6, name="a"), _trial(6, name="b")]
    trials[1].trial_labels = {"level": 10}
    data = _data(targets=[{"name": "level", "source": "trial"},
                          {"name": "size", "source": "trial", "kind": "regression"}])
    for t, size in zip(trials, (1.5, 2.5), strict=True):
        t.trial_labels["size"] = size
    heads = resolve_heads(data.targets, trials)
    assert heads[0].classes == ("3", "10")  # natural order, not string order
    ws = make_windows(trials, data, heads, _identity())
    assert ws.targets["level"].tolist() == [0] * 3 + [1] * 3
    assert ws.targets["size"].tolist() == [1.5] * 3 + [2.5] * 3
    with pytest.raises(InputError, match="no trial label 'grip'"):
        resolve_heads(_data(targets=[{"name": "grip", "source": "trial"}]).targets, trials)


def test_channels_are_selected_by_name_and_unknown_names_are_errors(action_file):
    data = tiny_config().data
    trials = read_trials([action_file], data)
    assert len(trials) == 24 and trials[0].x.shape[1] == 1
    assert trials[0].classes["action"] == ("approach", "press", "slip", "release")
    bad = tiny_config(data={"channels": ["positive"]}).data
    with pytest.raises(InputError, match=r"channel 'positive' is not a channel of sensor "
                                         r"'event_counts' \(channels: net\)"):
        read_trials([action_file], bad)
    with pytest.raises(InputError, match="no stream 'accel'"):
        read_trials([action_file], tiny_config(data={"stream": "accel"}).data)


def _keys(n: int, file: str = "f.h5") -> list[TrialSeries]:
    return [_trial(5, name=f"t{i:02d}", file=file) for i in range(n)]


def test_random_split_is_by_trial_seeded_and_independent_of_file_order():
    split = tiny_config().data.split  # val 0.25, test 0.25
    trials = _keys(20, "a.h5") + _keys(20, "b.h5")
    a = assign_splits(trials, split, seed=3)
    assert a.mode == "random" and a.counts() == {"train": 20, "val": 10, "test": 10}
    b = assign_splits(trials[::-1], split, seed=3)
    assert dict(zip((t.key for t in trials), a.splits, strict=True)) == \
        dict(zip((t.key for t in trials[::-1]), b.splits, strict=True))
    assert assign_splits(trials, split, seed=4).splits != a.splits
    # windows of one trial never sit on two sides
    ws = make_windows(trials, _data(window=2), [ACTION], _identity())
    side = np.asarray(a.splits)[ws.trial_index]
    for i in range(len(trials)):
        assert len(set(side[ws.trial_index == i])) == 1


def test_split_attribute_is_used_and_a_partial_one_is_an_error():
    trials = _keys(4)
    for t, s in zip(trials, ("train", "train", "val", "test"), strict=True):
        t.split_attr = s
    split = tiny_config().data.split
    assert assign_splits(trials, split, 0).splits == ("train", "train", "val", "test")
    trials[3].split_attr = ""
    with pytest.raises(InputError, match="some trials have a split attribute"):
        assign_splits(trials, split, 0)
    with pytest.raises(InputError, match="cannot be split into"):
        assign_splits(_keys(2), split, 0)


def test_normalisation_comes_from_the_training_trials_only(action_file):
    data = tiny_config(data={"transform": "none"}).data
    trials = read_trials([action_file], data)
    a = assign_splits(trials, data.split, 0)
    train = [trials[i] for i in a.indices("train")]
    norm = fit_normalisation(train, data.channels)
    x = np.concatenate([t.x[:, 0] for t in train]).astype(np.float64)
    assert norm.mean[0] == pytest.approx(x.mean(), rel=1e-12)
    assert norm.std[0] == pytest.approx(x.std(), rel=1e-12)
    everything = np.concatenate([t.x[:, 0] for t in trials])
    assert abs(norm.mean[0] - everything.mean()) > 1e-6  # not the statistics of all trials
    assert norm.n_samples == x.shape[0]
    # counts reach thousands per bin; standardised windows are O(1)
    assert x.max() > 2000
    ws = make_windows(train, data, resolve_heads(data.targets, trials), norm)
    assert abs(float(ws.x.mean())) < 0.2 and float(np.abs(ws.x).max()) < 10


def test_class_weights_balance_the_classes_present():
    y = np.array([0, 0, 0, 1, 3, 3])
    w = class_weights(y, 4)
    np.testing.assert_allclose(w, [6 / 9, 6 / 3, 0.0, 6 / 6])
    assert (w * np.bincount(y, minlength=4)).tolist() == pytest.approx([2, 2, 0, 2])


def test_summary_features_numpy_reference_equals_the_model_layer():
    rng = np.random.default_rng(0)
    windows = rng.normal(size=(7, 9, 3)).astype(np.float32)
    windows[0, :, 0] = 2.0 + 0.5 * np.arange(9)  # a pure ramp: slope 0.5 per sample
    ref = summary_features(windows)
    assert ref.shape == (7, len(SUMMARY_FEATURES) * 3)
    assert ref[0, 5 * 3 + 0] == pytest.approx(0.5)  # slope block, channel 0
    assert ref[0, 4 * 3 + 0] == pytest.approx(6.0)  # last
    layer = SummaryFeatures(SUMMARY_FEATURES, 9, 3)
    np.testing.assert_allclose(layer.raw(torch.from_numpy(windows)).numpy(), ref, atol=1e-5)


def test_event_trials_are_counted_on_the_fly_with_labels_from_annotations(event_file):
    path, truth = event_file
    data = tiny_config(data={"channels": ["net"]}).data
    trials = read_trials([path], data)
    assert [t.origin for t in trials] == ["events", "events"]
    for t, tr in zip(trials, truth, strict=True):
        n = tr.t_s.shape[0]
        np.testing.assert_array_equal(t.x[:n, 0], tr.net)
        np.testing.assert_array_equal(t.sample_labels["action"][:n], tr.labels)
        assert t.classes["action"] == ("approach", "press", "slip", "release")
    with pytest.raises(InputError, match="channel 'sum' is not an event-count channel"):
        read_trials([path], tiny_config(data={"channels": ["sum"]}).data)


def test_center_scale_zeroes_a_constant_channel_whatever_its_value():
    from tactile_cli.learn.data import center_scale

    # the float32 mean of 20 copies of 2.7182817 is off by a rounding step, which divided by
    # itself used to give a window of +-1 instead of zeros
    x = np.full((1, 20, 2), 2.7182817, np.float32)
    x[0, :, 1] = np.linspace(0, 1, 20)
    y = center_scale(x)
    assert (y[0, :, 0] == 0).all() and np.abs(y[0, :, 1]).max() == pytest.approx(1.0)
