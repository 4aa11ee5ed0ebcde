"""The model registry: every family builds, runs forward with the right shapes, and the
multi-task loss is paper 001's eq. 3."""

from __future__ import annotations

import pytest
import torch
from torch.nn import functional as F

from tactile_cli.learn.config import parse_config
from tactile_cli.learn.heads import HeadSpec
from tactile_cli.learn.models import REGISTRY, build_model, count_parameters, multitask_loss

HEADS = [
    HeadSpec("motion", "classification", "sample", 1.0, ("none", "slide", "slip")),
    HeadSpec("texture", "classification", "trial", 0.5, ("a", "b", "c", "d", "e")),
    HeadSpec("speed", "regression", "trial", 2.0),
]

FAMILIES = {
    "lstm": {"hidden": 8, "layers": 2},
    "cnn1d": {"channels": [4, 6], "kernel": 3},
    "cnn2d_spectrogram": {"n_fft": 8, "hop": 2, "channels": [4, 4]},
    "fnn": {"hidden": [16, 8]},
    "mlp": {"hidden": [8], "features": ["mean", "std", "slope"]},
}


def _model_cfg(family: str, **extra):
    raw = {"data": {"stream": "s", "channels": ["a", "b", "c"], "window": 24,
                    "targets": [{"name": "motion"}]},
           "model": {"family": family, **FAMILIES[family], **extra}}
    return parse_config(raw).model


def test_registry_has_the_six_families():
    # cnn2d_layout needs whole sensors of a layout: tests/learn/test_layout_cnn.py;
    # cnn2d_frames image sequences: tests/learn/test_frame_cnn.py
    assert set(REGISTRY) == set(FAMILIES) | {"cnn2d_layout", "cnn2d_frames"}


@pytest.mark.parametrize("family", list(FAMILIES))
def test_every_family_builds_and_runs_forward_with_the_right_shapes(family):
    torch.manual_seed(0)
    model = build_model(_model_cfg(family, head_hidden=[5]), window=24, n_channels=3,
                        heads=HEADS)
    x = torch.randn(7, 24, 3)
    out = model(x)
    assert list(out) == ["motion", "texture", "speed"]
    assert out["motion"].shape == (7, 3)
    assert out["texture"].shape == (7, 5)
    assert out["speed"].shape == (7,)
    assert count_parameters(model) > 0
    # batch 1 works (the latency case) and gives the same as in a batch
    model.eval()
    with torch.no_grad():
        single = model(x[:1])["motion"]
        torch.testing.assert_close(single, model(x)["motion"][:1], rtol=1e-4, atol=1e-5)


def test_spectrogram_shape_follows_n_fft_and_hop():
    model = build_model(_model_cfg("cnn2d_spectrogram"), window=24, n_channels=3, heads=HEADS)
    spec = model.trunk.spectrogram(torch.randn(2, 24, 3))
    assert spec.shape == (2, 3, 8 // 2 + 1, 1 + (24 - 8) // 2)


def test_lstm_of_the_paper_is_one_layer_and_one_linear_head():
    cfg = _model_cfg("lstm", layers=1, hidden=16)
    model = build_model(cfg, window=24, n_channels=1, heads=HEADS[:1])
    assert model.trunk.lstm.num_layers == 1
    assert [type(m).__name__ for m in model.heads[0].modules()][-1] == "Linear"
    # LSTM(1 -> 16): 4 * 16 * (1 + 16 + 2); head Linear(16 -> 3)
    assert count_parameters(model) == 4 * 16 * (1 + 16 + 2) + 16 * 3 + 3


def test_multitask_loss_is_the_weighted_sum_of_cross_entropies_and_mse():
    torch.manual_seed(1)
    out = {"motion": torch.randn(6, 3), "texture": torch.randn(6, 5), "speed": torch.randn(6)}
    y = {"motion": torch.tensor([0, 1, 2, 2, 1, 0]), "texture": torch.tensor([4, 3, 2, 1, 0, 0]),
         "speed": torch.randn(6)}
    w = {"motion": torch.tensor([1.0, 2.0, 0.5])}
    loss = multitask_loss(out, y, HEADS, w)
    ce_motion = F.cross_entropy(out["motion"], y["motion"], weight=w["motion"])
    ce_texture = F.cross_entropy(out["texture"], y["texture"])
    mse = ((out["speed"] - y["speed"]) ** 2).mean()
    torch.testing.assert_close(loss.parts["motion"], ce_motion)
    torch.testing.assert_close(loss.parts["texture"], ce_texture)
    torch.testing.assert_close(loss.parts["speed"], mse)
    torch.testing.assert_close(loss.total, 1.0 * ce_motion + 0.5 * ce_texture + 2.0 * mse)
    # with unit weights it is eq. 3 exactly: CE_motion + CE_texture + L2_speed
    unit = [HeadSpec(h.name, h.kind, h.source, 1.0, h.classes) for h in HEADS]
    torch.testing.assert_close(multitask_loss(out, y, unit).total,
                               F.cross_entropy(out["motion"], y["motion"]) + ce_texture + mse)
