"""Output folders of train, evaluate, perturb and compare (issue 20): a file where a folder
is expected is one error line before any work; a failure leaves the earlier folder intact
and no hidden temporary folder."""

from __future__ import annotations

import importlib
import shutil

import pytest
from typer.testing import CliRunner

from tactile_cli.cli import app
from tactile_cli.errors import InputError

from .conftest import tiny_config
from .tiny_runs import tiny_runs

runner = CliRunner()


@pytest.fixture(scope="session")
def runs(tmp_path_factory, action_file, heldout_file):
    return tiny_runs(tmp_path_factory, action_file, heldout_file)


@pytest.fixture
def run_copy(tmp_path, runs):
    return shutil.copytree(runs["mlp"], tmp_path / "run")


def _one_error_line(result, *words: str) -> None:
    assert result.exit_code == 2, result.output
    assert "Traceback" not in result.output
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("tactile: error: "), result.stderr
    for word in words:
        assert word in lines[0]


def _tree(folder):
    return {str(p.relative_to(folder)): p.read_bytes() for p in folder.rglob("*")
            if p.is_file()}


def _hidden(folder):
    return sorted(p.name for p in folder.rglob(".*"))


def test_evaluate_with_a_file_at_run_eval_is_one_line(run_copy, heldout_file):
    shutil.rmtree(run_copy / "eval")
    (run_copy / "eval").write_bytes(b"not a folder")
    result = runner.invoke(app, ["evaluate", str(run_copy), "--data", str(heldout_file)])
    _one_error_line(result, str(run_copy / "eval"), "is a file")
    assert (run_copy / "eval").read_bytes() == b"not a folder"
    assert _hidden(run_copy) == []


def test_evaluate_failing_midway_keeps_the_earlier_evaluation(run_copy, heldout_file,
                                                              monkeypatch):
    evaluate = importlib.import_module("tactile_cli.learn.metrics")  # writes the folder

    before = _tree(run_copy)

    def boom(*args, **kwargs):
        raise InputError("cannot draw the confusion matrix", path=run_copy)

    monkeypatch.setattr(evaluate, "plot_confusion", boom)  # after metrics.json is written
    result = runner.invoke(app, ["evaluate", str(run_copy), "--data", str(heldout_file),
                                 "--no-latency", "--overwrite"])
    _one_error_line(result, "cannot draw the confusion matrix")
    assert _tree(run_copy) == before
    assert _hidden(run_copy) == []


@pytest.mark.slow
def test_train_out_file_is_refused_before_training(tmp_path, action_file):
    cfg = tmp_path / "cfg.yaml"
    cfg.write_text(tiny_config().as_yaml())
    taken = tmp_path / "taken"
    taken.write_bytes(b"mine")
    for out in (taken, taken / "run"):
        for extra in ([], ["--overwrite"]):
            result = runner.invoke(app, ["train", str(cfg), "--data", str(action_file),
                                         "--out", str(out), *extra])
            _one_error_line(result, str(taken), "is a file")
    assert taken.read_bytes() == b"mine"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["cfg.yaml", "taken"]


@pytest.mark.parametrize("command", ["compare", "perturb"])
def test_compare_and_perturb_out_file_is_one_line(tmp_path, runs, heldout_file, command):
    taken = tmp_path / "taken"
    taken.write_bytes(b"mine")
    args = ([command, str(runs["mlp"]), str(runs["fnn"]), "--out", str(taken)]
            if command == "compare" else
            [command, str(runs["mlp"]), "--data", str(heldout_file), "--out", str(taken)])
    result = runner.invoke(app, args)
    _one_error_line(result, str(taken), "is a file")
    assert taken.read_bytes() == b"mine"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["taken"]


def test_compare_out_success_leaves_no_temporary(tmp_path, runs):
    out = tmp_path / "c"
    out.mkdir()
    (out / "notes.txt").write_text("mine")
    result = runner.invoke(app, ["compare", str(runs["mlp"]), str(runs["fnn"]),
                                 "--out", str(out)])
    assert result.exit_code == 0, result.output
    assert sorted(p.name for p in out.iterdir()) == ["compare.csv", "compare.json",
                                                      "compare.png", "notes.txt"]
    assert _hidden(tmp_path) == []
