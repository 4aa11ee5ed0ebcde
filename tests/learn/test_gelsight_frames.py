"""Real GelSight lifts (../shared/data/gelsight_slip) as an image-sequence input (issue 35):
two lift folders ingested with ``--reference first`` and the labels of
benchmarks/gelsight_slip_sequence.py, read as frames and through the shipped config's
network (the figures: benchmarks/RESULTS.md, "Real data: GelSight lifts")."""

from __future__ import annotations

import csv
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
from tests.conftest import load_benchmark, shared_path

ROOT = Path(__file__).resolve().parents[2]


def _benchmark():
    return load_benchmark("gelsight_slip_sequence")


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


def test_benchmark_labels_name_lifts_as_ingest_does_when_objects_share_a_folder(tmp_path):
    """The rest of the lift set repeats lift folders across objects (066_60_mm under two
    objects): the labels then name each lift by object, as `tactile ingest` names the
    trials, and a result line without its folder is left out, not a failed ingest."""
    from PIL import Image

    for obj in ("object001", "object003"):
        for lift in ("066_60_mm", "067_00_mm"):
            folder = tmp_path / obj / lift
            folder.mkdir(parents=True)
            Image.new("RGB", (8, 6)).save(folder / "gelsight_img_0.jpg")
    (tmp_path / "object001_result.dat").write_text(
        "66.6 fail 0 160 450 398 066_60 _s09_\n67 ok 0 930 1100 1027 067_00 _s09_\n")
    (tmp_path / "object003_result.dat").write_text(
        "66.6 success 0 10 450 398 066_60 _s01_\n68 slip 0 20 1100 1027 068_00 _s01_\n")
    rows = _benchmark().write_labels(tmp_path, tmp_path / "labels.csv")
    assert [(r["trial"], r["slipped"]) for r in rows] == [
        ("object001__066_60_mm", 1), ("object001__067_00_mm", 0), ("object003__066_60_mm", 0)]
    out = tmp_path / "lifts.h5"
    result = CliRunner().invoke(app, [
        "ingest", str(tmp_path / "object001"), str(tmp_path / "object003"), "--reference",
        "first", "--trial-labels", str(tmp_path / "labels.csv"), "--out", str(out),
        "--no-progress"])
    assert result.exit_code == 0, result.output
    from tactile_cli.store.trials import TactileFile

    with TactileFile(out) as f:
        got = {t: f.trial(t).labels.get("slipped") for t in f.trial_names}
    assert got == {"object001__066_60_mm": 1, "object001__067_00_mm": 0,
                   "object003__066_60_mm": 0, "object003__067_00_mm": None}
