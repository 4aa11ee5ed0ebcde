"""Image-sequence input and the ``cnn2d_frames`` family (issue 35, item 1): frames as the
difference from a reference, area-averaged; a 2-D CNN per frame with an LSTM or temporal
convolution over the frames, through train, evaluate, cross-validation and export."""

from __future__ import annotations

import numpy as np
import pytest
import torch

from tactile_cli.errors import InputError
from tactile_cli.learn import export
from tactile_cli.learn.config import FramesConfig, load_config, parse_config
from tactile_cli.learn.cv import evaluate_cv, train_cv
from tactile_cli.learn.data import read_trials, resolve_channels
from tactile_cli.learn.evaluate import evaluate
from tactile_cli.learn.frames import (
    LUMA,
    area_downsample,
    frame_channel_names,
    frame_difference,
)
from tactile_cli.learn.heads import HeadSpec
from tactile_cli.learn.models import build_model
from tactile_cli.learn.train import train

from ..factories.frame_sequences import HEIGHT, WIDTH, write_lift_file

HEADS = [HeadSpec("slipped", "classification", "trial", 1.0, ("0", "1"))]


def _raw(*, window=6, stride=6, pad="none", temporal="lstm", frames=None, epochs=8):
    return {
        "seed": 0,
        "data": {"stream": "frames", "channels": ["*"], "window": window, "stride": stride,
                 "pad": pad, "frames": frames or {"width": 8, "height": 6},
                 "targets": [{"name": "slipped", "source": "trial"}],
                 "split": {"mode": "stratified", "by": "slipped", "val_fraction": 0.25}},
        "model": {"family": "cnn2d_frames", "channels": [4], "embed": 8, "hidden": 8,
                  "temporal": temporal},
        "optim": {"epochs": epochs, "batch_size": 8, "lr": 0.01, "patience": 0},
    }


@pytest.fixture(scope="module")
def lifts(tmp_path_factory):
    folder = tmp_path_factory.mktemp("lifts")
    write_lift_file(folder / "train.h5", n_lifts=16, seed=0)
    write_lift_file(folder / "test.h5", n_lifts=8, seed=1)
    return folder / "train.h5", folder / "test.h5"


def test_area_downsampling_is_the_mean_of_the_pixels_covered():
    image = np.arange(4 * 6, dtype=np.float32).reshape(4, 6, 1)
    out = area_downsample(image, 2, 3)
    np.testing.assert_allclose(out[:, :, 0], image[:, :, 0].reshape(2, 2, 3, 2)
                               .mean(axis=(1, 3)))
    odd = area_downsample(np.arange(5, dtype=np.float32).reshape(1, 5, 1), 1, 2)
    np.testing.assert_allclose(odd[0, :, 0], [0.5, 3.0])  # columns [0, 2) and [2, 5)


def test_a_frame_becomes_its_difference_from_the_reference_plane_major():
    ref = np.full((4, 4, 3), 100, np.uint8)
    image = ref.copy()
    image[:2, :, 0] = 160  # red up by 60 in the top half
    colour = frame_difference(image, ref, FramesConfig(width=2, height=2, colour=True))
    np.testing.assert_allclose(colour, [60, 60, 0, 0] + [0] * 8)
    grey = frame_difference(image, ref, FramesConfig(width=2, height=2))
    np.testing.assert_allclose(grey, [60 * LUMA[0]] * 2 + [0, 0], rtol=1e-6)
    names = frame_channel_names(FramesConfig(width=2, height=12, colour=True))
    assert names[:3] == ["r_r00_c0", "r_r00_c1", "r_r01_c0"] and names[-1] == "b_r11_c1"
    assert len(names) == 3 * 12 * 2


def test_trials_read_as_series_of_pixel_channels(lifts):
    cfg = parse_config(_raw(frames={"width": 8, "height": 6, "colour": True}))
    data = resolve_channels(cfg.data, [lifts[0]])
    assert len(data.channels) == 3 * 6 * 8
    trials = read_trials([lifts[0]], data)
    t = trials[0]
    assert t.x.shape == (6, 144) and t.origin == "frames" and t.sensor == "gel"
    assert t.sample_period_s == pytest.approx(1 / 30)
    assert set(t.channel_units) == {"levels"}
    # the blob of a held lift (label 0) brightens the gel: positive differences
    assert t.trial_labels["slipped"] == 0 and t.x[-1].max() > 20


def test_a_frame_step_keeps_every_step_th_frame_at_a_longer_period(lifts):
    every = parse_config(_raw(window=3, stride=3))
    data = resolve_channels(every.data, [lifts[0]])
    full = read_trials([lifts[0]], data)[0]
    stepped_cfg = parse_config(_raw(window=3, stride=3, frames={"width": 8, "height": 6,
                                                                 "step": 2}))
    stepped = read_trials([lifts[0]], resolve_channels(stepped_cfg.data, [lifts[0]]))[0]
    # 6 frames -> frames 0, 2, 4: the same values, twice the period
    np.testing.assert_array_equal(stepped.x, full.x[::2])
    np.testing.assert_array_equal(stepped.t_s, full.t_s[::2])
    assert stepped.sample_period_s == pytest.approx(2 * full.sample_period_s)
    with pytest.raises(InputError, match="step"):
        parse_config(_raw(frames={"width": 8, "height": 6, "step": 0}))
    # the change between kept samples: successive differences of the same values
    moved_cfg = parse_config(_raw(window=3, stride=3, frames={"width": 8, "height": 6,
                                                               "step": 2, "change": "previous"}))
    moved = read_trials([lifts[0]], resolve_channels(moved_cfg.data, [lifts[0]]))[0]
    np.testing.assert_allclose(moved.x[0], stepped.x[0])
    np.testing.assert_allclose(moved.x[1:], np.diff(stepped.x, axis=0), atol=1e-4)


def test_config_round_trip_and_refusals(tmp_path):
    cfg = parse_config(_raw(frames={"width": 16, "height": 12, "colour": True,
                                    "reference": "first"}, temporal="conv"))
    path = tmp_path / "c.yaml"
    path.write_text(cfg.as_yaml())
    assert load_config(path) == cfg
    # a run's resolved config lists every pixel value: 3 x 24 x 32 = 2304 channel names
    big = _raw(frames={"width": 32, "height": 24, "colour": True})
    big["data"]["channels"] = frame_channel_names(FramesConfig(width=32, height=24,
                                                               colour=True))
    assert len(parse_config(big).data.channels) == 2304
    assert parse_config({**_raw(), "data": {**_raw()["data"], "frames": None}}).data.frames \
        == FramesConfig()  # stream frames: the default input
    bad = _raw()
    bad["data"] = {**bad["data"], "stream": "electrodes"}
    with pytest.raises(InputError, match="`frames` goes with `stream: frames`"):
        parse_config(bad)
    bad["data"].pop("frames")
    with pytest.raises(InputError, match="cnn2d_frames reads image sequences: set "
                                         "data.stream: frames"):
        parse_config(bad)
    sample = _raw()
    sample["data"] = {**sample["data"], "decide_by": "experiment",
                      "targets": [{"name": "slipped", "source": "sample"}]}
    with pytest.raises(InputError, match="`decide_by` .* give a target with `source: trial`"):
        parse_config(sample)
    with pytest.raises(InputError, match=r"unknown key `data.frames.size`"):
        parse_config({**_raw(), "data": {**_raw()["data"], "frames": {"size": 3}}})


def test_a_decide_by_label_the_trials_lack_is_refused_before_training(lifts, tmp_path):
    raw = _raw()
    raw["data"]["decide_by"] = "experiment"  # the lifts are labelled slipped and object only
    with pytest.raises(InputError, match="trial has no label 'experiment' .*fix "
                                         "data.decide_by"):
        train(parse_config(raw), [lifts[0]], tmp_path / "run", command="tests")
    assert not (tmp_path / "run").exists()


def test_the_trunk_needs_every_pixel():
    model = parse_config(_raw()).model
    with pytest.raises(InputError, match="needs every pixel of data.frames \\(48 values"):
        build_model(model, window=6, n_channels=47, heads=HEADS,
                    frames=FramesConfig(width=8, height=6))
    net = build_model(model, window=6, n_channels=48, heads=HEADS,
                      frames=FramesConfig(width=8, height=6))
    assert net(torch.zeros(3, 6, 48))["slipped"].shape == (3, 2)


def test_frames_smaller_than_the_configured_size_are_one_input_error(lifts):
    cfg = parse_config(_raw(frames={"width": WIDTH + 1, "height": HEIGHT}))
    with pytest.raises(InputError, match=f"frames of {WIDTH} x {HEIGHT} px are smaller"):
        read_trials([lifts[0]], resolve_channels(cfg.data, [lifts[0]]))


@pytest.mark.slow
def test_a_per_trial_cnn_lstm_learns_evaluates_and_exports_equal_within_1e_5(lifts, tmp_path):
    cfg = parse_config(_raw(temporal="lstm", window=6, stride=6))
    result = train(cfg, [lifts[0]], tmp_path / "run", command="tests", device="cpu")
    assert result.family == "cnn2d_frames" and result.n_params > 0 and result.device == "cpu"
    out = export.export_run(tmp_path / "run", tmp_path / "m.onnx", format="onnx",
                            command="tests")
    metrics = evaluate(tmp_path / "run", [lifts[1]], name="held_out", exported=out.path,
                       latency=True, command="tests")
    assert metrics.extra["exported"]["max_abs_diff"] <= 1e-5
    assert metrics.heads[0].accuracy >= 0.9, metrics.heads[0].accuracy  # 8 lifts, seed 1
    assert metrics.input["origin"] == "frames" and metrics.n_windows == 8
    assert metrics.latency is not None


@pytest.mark.slow
def test_a_per_frame_temporal_convolution_decides_at_every_frame(lifts, tmp_path):
    cfg = parse_config(_raw(temporal="conv", window=3, stride=1, pad="zero"))
    train(cfg, [lifts[0]], tmp_path / "run", command="tests")
    metrics = evaluate(tmp_path / "run", [lifts[1]], name="held_out", latency=False,
                       command="tests")
    head = metrics.heads[0]
    assert metrics.n_windows == 8 * 6 and head.per_trial["n_trials"] == 8
    assert head.accuracy >= 0.9, head.accuracy


@pytest.mark.slow
def test_cross_validation_grouped_by_object_gives_two_folds(lifts, tmp_path):
    raw = _raw(epochs=4)
    raw["data"]["split"] = {"mode": "group", "by": "object", "val_fraction": 0.0}
    raw["data"]["decide_by"] = "object"  # the lifts of one object decided together
    result = train_cv(parse_config(raw), [lifts[0]], tmp_path / "cv", k=2, jobs=1,
                      command="tests")
    assert result.k == 2
    metrics = evaluate_cv(tmp_path / "cv", None, latency=False, command="tests")
    assert metrics.n_trials == 16 and metrics.heads[0].accuracy_ci95 is not None
    assert metrics.heads[0].per_group["n_trials"] == 2
    assert not any("several folds" in n for n in metrics.notes)  # grouped: none split
    # a stratified split puts one object's lifts in both folds: the note says so
    raw["data"]["split"] = {"mode": "stratified", "by": "slipped", "val_fraction": 0.0}
    train_cv(parse_config(raw), [lifts[0]], tmp_path / "strat", k=2, jobs=1, command="tests")
    mixed = evaluate_cv(tmp_path / "strat", None, latency=False, command="tests")
    assert any("2 group(s) of decide_by 'object' have trials in several folds" in n
               for n in mixed.notes), mixed.notes
