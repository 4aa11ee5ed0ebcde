"""A model scored on recordings it trained on is named as such whichever file holds them:
run.json records the source files (SHA-256) of its training trials, and `evaluate` counts
the evaluated trials read from any of them (a user ingested 5 Xela trials to train on and
then scored the model on the whole set of 7: no warning, "overlaps_training": [])."""

from __future__ import annotations

import json

import pytest
from typer.testing import CliRunner

from tactile_cli.cli import app
from tactile_cli.store.reader import trial_source_hashes

from ..conftest import REPO, shared_path

runner = CliRunner()


def _ingest(folders, out):
    res = runner.invoke(app, ["ingest", *map(str, folders), "--mapping",
                              str(REPO / "configs" / "xela_slip.yaml"), "--out", str(out),
                              "--no-progress"])
    assert res.exit_code == 0, res.output
    return out


@pytest.mark.slow
def test_evaluate_names_trials_read_from_the_training_recordings(tmp_path):
    source = shared_path("xela_slip")
    trials = sorted(p for p in source.iterdir() if p.is_dir())
    assert len(trials) == 7
    first = _ingest(trials[:5], tmp_path / "first.h5")
    later = _ingest(trials[5:], tmp_path / "later.h5")
    whole = _ingest(trials, tmp_path / "whole.h5")
    own = trial_source_hashes(whole)
    assert all(len(v) == 6 for v in own.values())  # each trial's six CSV files are its own
    run = tmp_path / "run"
    res = runner.invoke(app, ["train", str(REPO / "configs" / "train_fnn_xela_slip.yaml"),
                              "--data", str(first), "--epochs", "1", "--out", str(run),
                              "--no-progress"])
    assert res.exit_code == 0, res.output
    recorded = json.loads((run / "run.json").read_text())["trained_sources_sha256"]
    assert set(recorded) <= set().union(*own.values()) and len(recorded) > 0
    res = runner.invoke(app, ["evaluate", str(run), "--data", str(whole), "--no-latency"])
    assert res.exit_code == 0, res.output
    metrics = json.loads((run / "eval" / "whole" / "metrics.json").read_text())
    seen = metrics["trained_recordings"]
    trained_split = json.loads((run / "run.json").read_text())["split"]["trials"]
    n_trained = trained_split["train"] + trained_split["val"]
    assert (seen["n_trials"], seen["n_evaluated"]) == (n_trained, 7)
    assert f"warning: {n_trained} of 7 evaluated trial(s) were read from source files " \
        "this run was trained on" in res.stderr
    assert metrics["overlaps_training"] == []  # another file: the file check alone missed it
    res = runner.invoke(app, ["evaluate", str(run), "--data", str(later), "--no-latency"])
    assert res.exit_code == 0 and "source files this run was trained on" not in res.stderr
    assert json.loads((run / "eval" / "later" / "metrics.json").read_text())[
        "trained_recordings"]["n_trials"] == 0
    res = runner.invoke(app, ["report", str(run), "--out", str(tmp_path / "rep")])
    assert res.exit_code == 0, res.output
    page = (tmp_path / "rep" / "index.html").read_text()
    assert f"no ({n_trained} of 7 evaluated trials were read from source files" in page


def test_a_source_several_trials_share_identifies_no_recording(tmp_path):
    """A file every trial names (the scene a set was drawn from, a shared table) and two
    trials' identical files are nobody's own: only a trial's own sources identify it."""
    import hashlib

    import numpy as np

    from tactile_cli.store.writer import StoreWriter

    files = {}
    for name, text in (("scene.json", "{}"), ("a.csv", "t,x\n0,1\n"),
                       ("b.csv", "t,x\n0,2\n"), ("a_marker.csv", "t\n"),
                       ("b_marker.csv", "t\n")):
        files[name] = tmp_path / name
        files[name].write_text(text)
    out = tmp_path / "set.h5"
    with StoreWriter(out, command="test") as w:
        acc = w.add_sensor("acc", kind="accelerometer", sample_rate_hz=100.0,
                           channel_names=["x"], channel_units="g")
        for trial in ("a", "b"):
            tr = w.trial(trial, sources=[w.add_source(files[n]) for n in (
                "scene.json", f"{trial}.csv", f"{trial}_marker.csv")])
            tr.write_signal("acc", sensor=acc, data=np.array([[1.0], [2.0]]),
                            t_s=np.array([0.0, 0.01]))
        w.commit()

    def sha(name):
        return hashlib.sha256(files[name].read_bytes()).hexdigest()

    assert trial_source_hashes(out) == {"a": frozenset({sha("a.csv")}),
                                        "b": frozenset({sha("b.csv")})}
