"""Real GelSight lifts (../shared/data/gelsight_slip) as an image-sequence input (issue 35):
two lift folders ingested with ``--reference first`` and the labels of
benchmarks/gelsight_slip_sequence.py, read as frames and through the shipped config's
network (the figures: benchmarks/RESULTS.md, "Real data: GelSight lifts")."""

from __future__ import annotations

import csv
import importlib.util
import sys
from pathlib import Path

import numpy as np
import pytest
import torch
from typer.testing import CliRunner

from tactile_cli.cli import app
from tactile_cli.learn.config import load_config
from tactile_cli.learn.data import read_trials, resolve_channels
from tactile_cli.learn.heads import HeadSpec
from tactile_cli.learn.models import build_model
from tests.conftest import shared_path

ROOT = Path(__file__).resolve().parents[2]


def _benchmark():
    path = ROOT / "benchmarks" / "gelsight_slip_sequence.py"
    spec = importlib.util.spec_from_file_location("gelsight_slip_sequence", path)
    assert spec is not None and spec.loader is not None
    mod = importlib.util.module_from_spec(spec)
    sys.modules["gelsight_slip_sequence"] = mod
    spec.loader.exec_module(mod)
    return mod


@pytest.mark.slow
def test_two_real_lifts_read_as_frame_sequences(tmp_path):
    source = shared_path("gelsight_slip")
    rows = _benchmark().write_labels(source, tmp_path / "all_labels.csv")
    assert len(rows) == 20 and sum(r["slipped"] for r in rows) == 11
    assert {r["object"] for r in rows} == {"object001", "object002"}
    lifts = {"067_60_mm": 1, "066_60_mm": 0}  # object001: a slipped and a held lift
    with open(tmp_path / "labels.csv", "w", newline="") as f:
        writer = csv.writer(f)
        writer.writerow(["trial", "slipped", "object"])
        writer.writerows([t, lifts[t], "object001"] for t in lifts)
    out = tmp_path / "lifts.h5"
    result = CliRunner().invoke(app, [
        "ingest", *[str(source / "object001" / t) for t in lifts], "--reference", "first",
        "--trial-labels", str(tmp_path / "labels.csv"), "--out", str(out), "--no-progress"])
    assert result.exit_code == 0, result.output
    cfg = load_config(ROOT / "configs" / "train_cnn2d_frames_gelsight_slip.yaml")
    data = resolve_channels(cfg.data, [out])
    trials = {t.trial: t for t in read_trials([out], data)}
    assert set(trials) == set(lifts)
    for name, t in trials.items():
        assert t.x.shape == (21, 24 * 32) and t.trial_labels["slipped"] == lifts[name]
        np.testing.assert_array_equal(t.x[0], 0.0)  # the first frame is the reference
        assert np.abs(t.x[-1]).mean() > 0.5  # the grasp changes the gel (levels)
    heads = [HeadSpec("slipped", "classification", "trial", 1.0, ("0", "1"))]
    net = build_model(cfg.model, window=21, n_channels=len(data.channels), heads=heads,
                      frames=data.frames)
    x = torch.from_numpy(np.stack([t.x for t in trials.values()]))
    assert net(x)["slipped"].shape == (2, 2)
