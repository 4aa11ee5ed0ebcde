"""Nothing lost (issue 33) in train, evaluate, perturb, compare, report, export and
detect-delay: an output that is an input, contains one or lies inside one is refused in one
line with or without --overwrite and every input stays byte-identical; an interrupted
--overwrite leaves the earlier output byte-identical (train --cv keeps its finished folds
apart and resumes); an unwritable destination and absurd thread counts are one line before
any work. The sweep's own cases are in test_sweep.py."""

from __future__ import annotations

import errno
import os
import shutil
from pathlib import Path

import pytest
from typer.testing import CliRunner

from tactile_cli import interrupt
from tactile_cli.cli import app
from tactile_cli.interrupt import Interrupted
from tactile_cli.store import atomic

from .conftest import tiny_config
from .tiny_runs import tiny_runs

runner = CliRunner()


@pytest.fixture(autouse=True)
def _no_interrupt_left():
    yield
    interrupt.clear()


def _tree(folder: Path) -> dict[str, bytes]:
    """Every file under ``folder`` (hidden ones too) -> its bytes."""
    return {str(p.relative_to(folder)): p.read_bytes() for p in sorted(folder.rglob("*"))
            if p.is_file()}


def _one_line(res, *parts: str) -> str:
    assert res.exit_code == 2, res.output
    assert "Traceback" not in res.output
    lines = res.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("tactile: error: "), res.stderr
    for part in parts:
        assert part in lines[0], lines[0]
    return lines[0]


@pytest.fixture
def run(tmp_path, tmp_path_factory, action_file, heldout_file) -> Path:
    """A copy of the tiny MLP run, evaluated on ``heldout_file`` (RUN/eval/heldout)."""
    dst = tmp_path / "run"
    shutil.copytree(tiny_runs(tmp_path_factory, action_file, heldout_file)["mlp"], dst)
    return dst


@pytest.fixture
def config(tmp_path) -> Path:
    path = tmp_path / "train.yaml"
    path.write_text(tiny_config(model={"family": "mlp", "hidden": [8]},
                                optim={"epochs": 1}).as_yaml())
    return path


@pytest.fixture
def data(tmp_path, action_file) -> Path:
    """A copy of the training file in a folder of its own."""
    folder = tmp_path / "data"
    folder.mkdir()
    shutil.copyfile(action_file, folder / "synth.h5")
    return folder / "synth.h5"


def test_export_never_replaces_the_runs_own_files(run):
    before = _tree(run)
    for out in (run / "model.pt", run / "run"):  # the model; a sidecar that is run.json
        res = runner.invoke(app, ["export", str(run), "--out", str(out), "--overwrite"])
        _one_line(res, "is the input", "--out")
    assert _tree(run) == before


@pytest.mark.slow
@pytest.mark.parametrize("extra", [[], ["--cv", "2"]])
def test_train_refuses_an_output_that_is_or_holds_its_data(config, data, extra):
    before = _tree(data.parent)
    for out, how in ((data, "is the input"), (data.parent, "contains the input"),
                     (config, "is the input")):
        res = runner.invoke(app, ["train", str(config), "--data", str(data), "--out", str(out),
                                  "--overwrite", "--no-progress", *extra])
        _one_line(res, how, "--out")
    assert _tree(data.parent) == before
    assert [p.name for p in data.parent.parent.iterdir() if p.name.startswith(".")] == []


def test_evaluate_refuses_a_results_folder_that_holds_its_data(run, heldout_file):
    inside = run / "eval" / "h"
    inside.mkdir()
    shutil.copyfile(heldout_file, inside / "h.h5")
    before = _tree(run)
    for extra in (["--name", "h", "--overwrite"], ["--each", "--workers", "0", "--overwrite"]):
        res = runner.invoke(app, ["evaluate", str(run), "--data", str(inside / "h.h5"),
                                  "--no-latency", *extra])
        _one_line(res, "contains the input")
    assert _tree(run) == before


def test_perturb_compare_and_report_refuse_outputs_holding_their_inputs(run, data):
    before = _tree(data.parent), _tree(run)
    res = runner.invoke(app, ["perturb", str(run), "--data", str(data), "--kinds", "noise",
                              "--out", str(data.parent)])
    _one_line(res, "--out contains the input")
    res = runner.invoke(app, ["compare", str(run), "--out", str(run.parent)])
    _one_line(res, "--out contains the input")
    res = runner.invoke(app, ["report", str(run), "--data", str(data), "--out",
                              str(data.parent)])
    _one_line(res, "--out contains the input")
    assert (_tree(data.parent), _tree(run)) == before


@pytest.mark.parametrize("argv, flag", [
    (["evaluate", "{run}", "--data", "{data}", "--threads", "4096"], "--threads (=4096)"),
    (["evaluate", "{run}", "--data", "{data}", "--each", "--workers", "4096"],
     "--workers (=4096)"),
    (["detect-delay", "{run}", "--data", "{data}", "--threads", "4096"], "--threads (=4096)"),
    (["train", "{config}", "--data", "{data}", "--cv", "2", "--jobs", "4096", "--out",
      "{tmp}/cv"], "--jobs (=4096)"),
    (["perturb", "{run}", "--data", "{data}", "--kinds", "scale", "--levels", "scale=1e9"],
     "scale level 1e+09 is not a time factor from 0.001 to 1000"),
    (["perturb", "{run}", "--data", "{data}", "--seed", "-1"], "--seed (=-1) must be"),
    (["train", "{config}", "--data", "{data}", "--seed", "-1", "--out", "{tmp}/cv"],
     "--seed (=-1): input should be greater than or equal to 0"),
    (["train", "{config}", "--data", "{data}", "--epochs", "100000000000", "--out",
      "{tmp}/cv"], "--epochs (=100000000000): input should be less than or equal to"),
    (["evaluate", "{run}", "--data", "{data}", "--name", "../x"],
     "--name (='../x') must be a plain folder name"),
    (["perturb", "{run}", "--data", "{data}", "--name", ".."],
     "--name (='..') must be a plain folder name"),
])
def test_absurd_counts_are_one_line_before_any_work(run, data, config, tmp_path, argv, flag):
    before = _tree(run)
    subs = {"{run}": str(run), "{data}": str(data), "{config}": str(config),
            "{tmp}": str(tmp_path)}
    argv = [subs.get(a, a.replace("{tmp}", str(tmp_path))) for a in argv]
    _one_line(runner.invoke(app, argv), flag)
    assert _tree(run) == before
    assert not (tmp_path / "cv").exists()


def _interrupt_at_the_first_rename(monkeypatch) -> None:
    """Ctrl-C arriving just before a command puts its first result in place: what the
    CLI's signal handler does (mark the request), seen at the writers' last check."""
    def stop() -> None:
        raise Interrupted()

    monkeypatch.setattr(atomic, "raise_if_requested", stop)


@pytest.mark.slow
@pytest.mark.parametrize("argv", [
    ["train", "{config}", "--data", "{data}", "--out", "{tmp}/out", "--no-progress",
     "--overwrite"],
    ["evaluate", "{run}", "--data", "{data}", "--name", "e", "--no-latency", "--overwrite"],
    ["perturb", "{run}", "--data", "{data}", "--kinds", "noise", "--levels", "noise=10",
     "--name", "p", "--out", "{tmp}/out"],
    ["compare", "{run}", "--out", "{tmp}/out"],
    ["report", "{run}", "--out", "{tmp}/out"],
    ["export", "{run}", "--out", "{tmp}/out/m.onnx", "--overwrite"],
], ids=lambda argv: argv[0])
def test_an_interrupted_overwrite_leaves_the_earlier_output_byte_identical(
        run, data, config, tmp_path, monkeypatch, argv):
    subs = {"{run}": str(run), "{data}": str(data), "{config}": str(config)}
    argv = [subs.get(a, a.replace("{tmp}", str(tmp_path))) for a in argv]
    if argv[0] == "export":
        (tmp_path / "out").mkdir()
    first = runner.invoke(app, argv)  # (--overwrite: no earlier output yet)
    assert first.exit_code == 0, first.output
    before = _tree(tmp_path)
    _interrupt_at_the_first_rename(monkeypatch)
    res = runner.invoke(app, argv)
    assert res.exit_code == 130, res.output
    assert res.stderr.strip().splitlines()[-1] == (
        "tactile: error: interrupted; no output was written and earlier outputs are intact")
    assert _tree(tmp_path) == before


@pytest.mark.slow
def test_train_cv_interrupted_with_overwrite_keeps_the_earlier_run_and_resumes(
        config, data, tmp_path, monkeypatch):
    from tactile_cli.learn import cv

    out = tmp_path / "cv"
    argv = ["train", str(config), "--data", str(data), "--cv", "2", "--jobs", "1", "--out",
            str(out), "--no-progress"]
    assert runner.invoke(app, argv).exit_code == 0
    before = _tree(out)
    real = cv._train_fold

    def then_ctrl_c(*args, **kwargs):
        summary = real(*args, **kwargs)
        interrupt.request()  # what the CLI's SIGINT handler does, after the first fold
        return summary

    monkeypatch.setattr(cv, "_train_fold", then_ctrl_c)
    res = runner.invoke(app, [*argv, "--overwrite"])
    assert res.exit_code == 130, res.output
    assert _tree(out) == before
    partial = cv.partial_dir(out)
    assert sorted(p.name for p in (partial / "folds").iterdir()) == ["fold_00"]
    monkeypatch.setattr(cv, "_train_fold", real)
    res = runner.invoke(app, [*argv, "--overwrite"])
    assert res.exit_code == 0, res.output
    assert "1 already finished (resuming)" in res.stderr
    assert not partial.exists() and (out / "folds" / "fold_01" / "model.pt").is_file()
    assert _tree(out) != before
    assert [p.name for p in tmp_path.iterdir() if p.name.startswith(".")] == []


@pytest.mark.parametrize("extra", [[], ["--cv", "2"]])
def test_train_into_a_folder_that_refuses_files_is_one_line(config, data, tmp_path,
                                                            monkeypatch, extra):
    real_open = os.open

    def refuse(path, flags, *args):
        if ".tactile-probe" in str(path):
            raise PermissionError(errno.EACCES, "Permission denied", str(path))
        return real_open(path, flags, *args)

    monkeypatch.setattr(atomic.os, "open", refuse)
    res = runner.invoke(app, ["train", str(config), "--data", str(data), "--out",
                              str(tmp_path / "locked" / "run"), "--no-progress", *extra])
    _one_line(res, "cannot write in this folder (Permission denied)")
    assert not (tmp_path / "locked").exists()
