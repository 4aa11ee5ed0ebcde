"""`tactile accumulate` through the CLI: table, JSON, HDF5 and CSV outputs, figures, errors."""

from __future__ import annotations

import csv
import dataclasses
import json

import h5py
import numpy as np
import pytest
from typer.testing import CliRunner

from tactile_cli.cli import app
from tactile_cli.events import bin_events
from tactile_cli.store import StoreWriter, validate_file
from tactile_cli.vocabulary import ACTIONS

from ..factories.event_counts import events_from_counts, make_trial, random_params

runner = CliRunner()


@pytest.fixture(scope="module")
def recording(tmp_path_factory):
    """Three event trials: two approach-press-slip-release runs at a tenth of the paper's
    gains (one annotated, one not) and one of background noise only."""
    rng = np.random.default_rng(11)
    path = tmp_path_factory.mktemp("acc") / "rec.h5"
    truth = {}
    with StoreWriter(path, command="test") as w:
        w.add_sensor("dvs", kind="event_camera", sample_rate_hz=0, width_px=64, height_px=48)
        for name in ("run_a", "run_b", "noise"):
            if name == "noise":
                pos, neg = rng.poisson(8, 150), rng.poisson(8, 150)
                annotations = []
            else:
                params = dataclasses.replace(random_params(rng), alpha_press=200.0,
                                             alpha_slip=170.0)
                trial = make_trial(rng, params=params, background=3.0)
                pos, neg = trial.positive, trial.negative
                truth[name] = trial
                annotations = trial.timeline.intervals() if name == "run_a" else []
            ev = events_from_counts(pos, neg, rng)
            tw = w.trial(name, labels={"force_level": 4, "force_grade": "small medium"},
                         split="train", annotations=annotations)
            app_ = tw.events("dvs")
            app_.append(ev["x"], ev["y"], ev["t"], ev["p"])
            app_.close(t_origin_us=0)
            truth.setdefault(f"{name}_events", ev)
        w.commit()
    return path, truth


def test_table_lists_every_trial_with_its_segmentation(recording):
    path, _ = recording
    result = runner.invoke(app, ["accumulate", str(path), "--segment"])
    assert result.exit_code == 0, result.output
    for name in ("run_a", "run_b", "noise"):
        assert name in result.output
    assert "segmentation: failed 1, ok 2" in result.output
    assert "noise: failed: no press" in result.output
    assert "bins as annotated: mean" in result.output


def test_json_matches_the_library(recording):
    path, truth = recording
    result = runner.invoke(app, ["accumulate", str(path), "--json", "--segment", "-t", "run_a",
                                 "-t", "noise", "--bin-ms", "20", "--smooth", "5"])
    assert result.exit_code == 0, result.output
    data = json.loads(result.output)
    assert [t["trial"] for t in data["trials"]] == ["run_a", "noise"]
    ev = truth["run_a_events"]
    ref = bin_events(ev["t"], ev["p"], bin_s=0.02)
    run_a = data["trials"][0]
    assert run_a["n_events"] == ev["t"].size and run_a["n_bins"] == ref.n_bins
    assert run_a["n_positive"] == int(ref.positive.sum())
    assert run_a["labels"] == {"force_grade": "small medium", "force_level": 4}
    assert run_a["segmentation"]["status"] == "ok"
    assert run_a["bin_accuracy"] >= 0.95
    tl = truth["run_a"].timeline
    assert abs(run_a["segmentation"]["press_start_s"] - tl.press_start_s) < 0.04
    assert data["trials"][1]["segmentation"]["status"] == "failed"
    assert data["trials"][1]["segmentation"]["release_start_s"] is None
    assert data["summary"]["segmentation_status"] == {"ok": 1, "failed": 1}


@pytest.mark.slow
def test_out_file_is_schema_valid_with_counts_labels_and_provenance(recording, tmp_path):
    path, truth = recording
    out = tmp_path / "counts.h5"
    table = tmp_path / "bins.csv"
    figures = tmp_path / "figs"
    result = runner.invoke(app, ["accumulate", str(path), "--segment", "--out", str(out),
                                 "--csv", str(table), "--plot", str(figures)])
    assert result.exit_code == 0, result.output
    assert validate_file(out).ok
    with h5py.File(out) as h5:
        sensor = h5["sensors/event_counts"]
        assert sensor.attrs["kind"] == "event_camera" and sensor.attrs["bin_s"] == 0.02
        assert (sensor.attrs["width_px"], sensor.attrs["height_px"]) == (64, 48)
        assert sensor.attrs["sample_rate_hz"] == pytest.approx(50.0)
        assert list(sensor["channel_names"].asstr()[()]) == ["positive", "negative", "net"]
        assert set(sensor["channel_units"].asstr()[()]) == {"events/bin"}
        assert list(h5["provenance/sources/path"].asstr()[()]) == [str(path)]
        assert h5.attrs["command"]  # the command line (sys.argv: pytest here)
        assert json.loads(h5.attrs["config_json"])["segment"] is True
        ev = truth["run_a_events"]
        ref = bin_events(ev["t"], ev["p"], bin_s=0.02)
        g = h5["trials/run_a/signals/event_counts"]
        np.testing.assert_array_equal(g["data"][()], ref.stack())
        np.testing.assert_allclose(g["t_s"][()], ref.t_s)
        action = g["sample_labels/action"]
        assert list(action.attrs["classes"]) == list(ACTIONS)
        np.testing.assert_array_equal(action[()], truth["run_a"].timeline.labels(ref.t_s))
        assert g.attrs["action_source"] == "annotations"
        assert "action_detected" in g["sample_labels"]
        assert h5["trials/run_a/labels"].attrs["force_level"] == 4
        assert h5["trials/run_a"].attrs["split"] == "train"
        assert list(h5["trials/run_a/annotations/label"].asstr()[()]) == list(ACTIONS)
        # no annotations: the action labels come from the segmentation
        b = h5["trials/run_b/signals/event_counts"]
        assert b.attrs["action_source"] == "segmentation"
        np.testing.assert_array_equal(b["sample_labels/action"][()],
                                      b["sample_labels/action_detected"][()])
        # a failed segmentation labels nothing and says why
        n = h5["trials/noise/signals/event_counts"]
        assert n.attrs["action_source"] == "none" and "sample_labels" not in n
        assert n.attrs["segmentation_status"] == "failed"
    with open(table, newline="") as f:
        rows = list(csv.DictReader(f))
    assert rows[0].keys() == {"trial", "t_s", "positive", "negative", "net", "net_smoothed",
                              "action", "action_detected"}
    run_a = [r for r in rows if r["trial"] == "run_a"]
    assert len(run_a) == ref.n_bins and int(run_a[3]["net"]) == int(ref.net[3])
    assert sorted(p.name for p in figures.iterdir()) == ["noise.png", "run_a.png", "run_b.png"]
    # an existing output needs --overwrite
    again = runner.invoke(app, ["accumulate", str(path), "--out", str(out)])
    assert again.exit_code == 2
    assert again.output.strip() == (f"tactile: error: {out}: --out output exists; pass "
                                    "--overwrite to replace it")


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["-t", "nope"], "{path}: no trial 'nope'; the file has 3 trial(s): run_a, run_b, noise"),
        (["--smooth", "4"], "--smooth (=4) must be odd (a centred moving average); pass e.g. "
         "--smooth 5"),
        (["--bin-ms", "0.0015"], "bin width 0.0015 ms is not a whole number of microseconds; "
                                 "pass e.g. --bin-ms 20"),
    ],
)
def test_bad_input_is_one_line_and_exit_2(recording, args, message):
    path, _ = recording
    result = runner.invoke(app, ["accumulate", str(path), *args])
    assert result.exit_code == 2
    assert result.output.strip() == "tactile: error: " + message.format(path=path)


def test_files_that_are_not_event_recordings_exit_2(tmp_path):
    text = tmp_path / "a.h5"
    text.write_text("hello")
    result = runner.invoke(app, ["accumulate", str(text)])
    assert result.exit_code == 2 and "not a readable HDF5 file" in result.output
    signals = tmp_path / "acc.h5"
    with StoreWriter(signals, command="test") as w:
        s = w.add_sensor("acc", kind="accelerometer", sample_rate_hz=10, channel_names=["a"],
                         channel_units="g")
        w.trial("t0").write_signal("acc", sensor=s, data=np.zeros((5, 1)), t_s=np.arange(5) / 10)
        w.commit()
    result = runner.invoke(app, ["accumulate", str(signals)])
    assert result.exit_code == 2
    assert result.output.strip() == (f"tactile: error: {signals}: no trial has events (event "
                                     "counts need an event-camera recording)")
    result = runner.invoke(app, ["accumulate", str(signals), "-t", "t0"])
    assert result.exit_code == 2
    assert result.output.strip() == (f"tactile: error: {signals}, /trials/t0: trial has no "
                                     "events (event counts need an event-camera recording)")
    missing = runner.invoke(app, ["accumulate", str(tmp_path / "none.h5")])
    assert missing.exit_code == 2
    assert missing.output.strip() == f"tactile: error: {tmp_path / 'none.h5'}: file not found"
