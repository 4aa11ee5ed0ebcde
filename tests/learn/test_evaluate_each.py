"""`tactile evaluate RUN --data FILE... --each`: one evaluation per data file on Dask (issue
18): the same metrics as evaluating each file alone, a bad file named on one line while the
others are written, a restart that skips what is up to date."""

from __future__ import annotations

import json
import os
import shutil
from pathlib import Path

import pytest
from typer.testing import CliRunner

from tactile_cli.cli import app
from tactile_cli.learn.evaluate import evaluate
from tactile_cli.learn.train import train

from .conftest import tiny_config

runner = CliRunner()


@pytest.fixture(scope="module")
def fnn_run(tmp_path_factory, action_file) -> Path:
    """An FNN with a classification head and a regression head (the trial's force level,
    whose values predictions.csv holds at full precision)."""
    out = tmp_path_factory.mktemp("each") / "fnn"
    cfg = tiny_config(model={"family": "fnn", "hidden": [16]},
                      data={"label_delay": 5, "targets": [
                          {"name": "action"},
                          {"name": "force_level", "kind": "regression", "source": "trial"}]},
                      optim={"epochs": 3})
    train(cfg, [action_file], out, command="test")
    return out


def _metrics(folder: Path) -> dict:
    return json.loads((folder / "metrics.json").read_text())


@pytest.mark.slow
def test_each_file_on_a_worker_equals_one_evaluation_per_file(fnn_run, action_file,
                                                              heldout_file, tmp_path):
    """Also issue 30: the predictions (force levels at full precision) are the same bits
    on two Dask workers, in this process (workers=0) and in one evaluation on 3 torch
    threads (:func:`~tactile_cli.learn.train.predict` runs on one thread whatever the
    caller's count)."""
    import torch

    run = tmp_path / "run"
    shutil.copytree(fnn_run, run)
    other = tmp_path / "other.h5"
    shutil.copyfile(heldout_file, other)
    bad = tmp_path / "bad.h5"
    bad.write_bytes(b"no HDF5 here\n")
    res = runner.invoke(app, ["evaluate", str(run), "--data", str(heldout_file), str(other),
                              str(bad), "--each", "--workers", "2", "--json"])
    assert res.exit_code == 2, res.output
    out = json.loads(res.stdout)
    assert out["counts"] == {"ok": 2, "skipped": 0, "failed": 1}
    assert "latency not measured" in out["note"]
    failed = out["items"][2]
    assert failed["status"] == "failed" and "bad.h5" in failed["error"]
    assert f"{bad}: failed: " in res.stderr and "Traceback" not in res.output

    # each folder holds what evaluating that file alone gives (latency aside)
    previous = torch.get_num_threads()
    torch.set_num_threads(3)
    try:
        alone = evaluate(fnn_run, [heldout_file], latency=False, command="test")
        assert torch.get_num_threads() == 3  # the caller's count is given back
    finally:
        torch.set_num_threads(previous)
    csv = {heldout_file.stem: (alone.out_dir / "predictions.csv").read_bytes()}
    assert b"force_level_pred" in csv[heldout_file.stem].splitlines()[0]
    # the copy's rows name its own file; its values are the same
    csv["other"] = csv[heldout_file.stem].replace(heldout_file.stem.encode(), b"other")
    for item, stem in zip(out["items"][:2], (heldout_file.stem, "other"), strict=True):
        folder = run / "eval" / stem
        assert item["output"] == str(folder)
        got, want = _metrics(folder), _metrics(alone.out_dir)
        assert got["heads"] == want["heads"]
        assert got["n_windows"] == want["n_windows"] and got["latency"] is None
        accuracy = item["value"]["summary"]["heads"]["action"]["accuracy"]
        assert accuracy == want["heads"]["action"]["accuracy"]
        assert (folder / "predictions.csv").read_bytes() == csv[stem]
    assert not [p for p in (run / "eval").iterdir() if p.name.startswith(".")]

    # a restart skips what is up to date and redoes an evaluation whose data changed
    later = os.path.getmtime(run / "eval" / "other" / "metrics.json") + 10
    os.utime(other, (later, later))
    res = runner.invoke(app, ["evaluate", str(run), "--data", str(heldout_file), str(other),
                              "--each", "--workers", "0"])
    assert res.exit_code == 0, res.output
    assert "1 to evaluate, 1 up to date (skipped)" in res.stderr
    assert "1 ok, 1 skipped (up to date), 0 failed" in res.stdout
    assert os.path.getmtime(run / "eval" / "other" / "metrics.json") > later - 10
    assert (run / "eval" / "other" / "predictions.csv").read_bytes() == csv["other"]


def test_each_refuses_what_needs_one_evaluation(fnn_run, heldout_file):
    res = runner.invoke(app, ["evaluate", str(fnn_run), "--data", str(heldout_file),
                              "--each", "--name", "x"])
    assert res.exit_code == 2
    assert "--name goes with one evaluation" in res.stderr
    res = runner.invoke(app, ["evaluate", str(fnn_run), "--data", str(heldout_file),
                              "--workers", "2"])
    assert res.exit_code == 2
    assert "--scheduler and --workers go with --each" in res.stderr
