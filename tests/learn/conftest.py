"""Fixtures of the learn tests: small synthetic action files and a tiny trained run."""

from __future__ import annotations

from pathlib import Path

import pytest

from tactile_cli.learn.config import TrainConfig, parse_config

from ..factories.action_files import make_action_file, make_event_file


def tiny_config(**changes) -> TrainConfig:
    """A small, fast LSTM config on the synthetic action task; ``changes`` are merged in
    per section (``data={...}``, ``model={...}``, ``optim={...}``, ``seed=...``); a ``model``
    with a ``family`` replaces the LSTM section."""
    raw = {
        "seed": 0,
        "data": {"stream": "event_counts", "channels": ["net"], "window": 20, "stride": 2,
                 "pad": "zero", "transform": "signed_log1p",
                 "targets": [{"name": "action"}],
                 "split": {"val_fraction": 0.25, "test_fraction": 0.25}},
        "model": {"family": "lstm", "hidden": 16},
        "optim": {"lr": 0.01, "batch_size": 64, "epochs": 3, "patience": 0, "threads": 1,
                  "grad_clip": 1.0},
    }
    for key, value in changes.items():
        if key == "model" and "family" in value:  # another family: its own keys only
            raw[key] = value
        elif isinstance(value, dict) and isinstance(raw.get(key), dict):
            raw[key] = {**raw[key], **value}
        else:
            raw[key] = value
    return parse_config(raw)


@pytest.fixture(scope="session")
def action_file(tmp_path_factory) -> Path:
    """24 synthetic trials (2 per force level), no split attributes."""
    return make_action_file(tmp_path_factory.mktemp("learn") / "synth.h5", n_trials=24, seed=0)


@pytest.fixture(scope="session")
def heldout_file(tmp_path_factory) -> Path:
    """12 other synthetic trials (another seed): data a run never saw."""
    return make_action_file(tmp_path_factory.mktemp("learn") / "heldout.h5", n_trials=12,
                            seed=7)


@pytest.fixture(scope="session")
def event_file(tmp_path_factory):
    """2 raw-event trials with annotations and no counts stream, and their ground truth."""
    return make_event_file(tmp_path_factory.mktemp("learn") / "scene.h5", n_trials=2, seed=1)
