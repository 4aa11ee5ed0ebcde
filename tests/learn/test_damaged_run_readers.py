"""Issue 20, item 5: compare, report, evaluate and perturb read a run folder through one
validated reader (runs.read_run_info / read_run_config / read_metrics); a damaged run.json or
config.resolved.yaml is one line naming the file, exit 2, no traceback, nothing written, the
run left as it was. And a run trained on named classes refuses data whose label lost its
``classes`` attribute."""

from __future__ import annotations

import json
import re
import shutil

import h5py
import numpy as np
import pytest
from typer.testing import CliRunner

from tactile_cli.cli import app
from tactile_cli.errors import InputError
from tactile_cli.learn.evaluate import evaluate
from tactile_cli.learn.train import train

from .conftest import tiny_config

runner = CliRunner()


@pytest.fixture(scope="module")
def run_folder(tmp_path_factory, action_file, heldout_file):
    out = tmp_path_factory.mktemp("readers") / "run"
    train(tiny_config(optim={"epochs": 1}), [action_file], out, command="test")
    evaluate(out, [heldout_file], name="held", latency=False)
    return out


def _drop_first_key(run):
    info = json.loads((run / "run.json").read_text())
    del info[sorted(info)[0]]  # class_weights, as the fuzz corpus does
    (run / "run.json").write_text(json.dumps(info))


DAMAGES = {
    "run.json non-utf8": (lambda r: (r / "run.json").write_bytes(b"\xff\xfe\x00"), "run.json",
                          "not UTF-8 text"),
    "run.json a list": (lambda r: (r / "run.json").write_text("[1, 2]"), "run.json",
                        "run.json is not a JSON object"),
    "run.json empty object": (lambda r: (r / "run.json").write_text("{}"), "run.json",
                              "run.json format is None"),
    "run.json key dropped": (_drop_first_key, "run.json", "run.json has no `class_weights`"),
    "run.json model retyped": (
        lambda r: (r / "run.json").write_text((r / "run.json").read_text().replace(
            '"model": {', '"model": "x", "_": {')), "run.json", "`model` must be a JSON object"),
}
CONFIG_DAMAGES = {
    "config syntax": (lambda r: (r / "config.resolved.yaml").write_text("a: [b\n"),
                      "config.resolved.yaml", "not valid YAML"),
    "config cut": (lambda r: (r / "config.resolved.yaml").write_bytes(
        (r / "config.resolved.yaml").read_bytes()[:37]), "config.resolved.yaml", ""),
    "config gone": (lambda r: (r / "config.resolved.yaml").unlink(), "run",
                    "run folder has no config.resolved.yaml"),
}


def _damaged(run_folder, tmp_path, damage):
    run = tmp_path / "run"
    shutil.copytree(run_folder, run)
    damage(run)
    before = {p.relative_to(run): p.read_bytes() for p in run.rglob("*") if p.is_file()}
    return run, before


def _check_one_line(result, run, where, what):
    assert result.exit_code == 2, result.output
    lines = result.stderr.splitlines()
    assert len(lines) == 1 and lines[0].startswith("tactile: error: "), result.stderr
    assert "Traceback" not in result.output
    if where == "run":
        assert f"{run}: " in lines[0], lines[0]
    else:
        assert f"{run}/{where}" in lines[0], lines[0]
    assert what in lines[0], lines[0]
    assert "tactile train" in lines[0]  # what to do


def _commands(run, other, heldout, out):
    return {
        "compare": ["compare", str(run), str(other)],
        "report": ["report", str(run), "--out", str(out)],
        "evaluate": ["evaluate", str(run), "--data", str(heldout), "--no-latency", "--name",
                     "x"],
        "perturb": ["perturb", str(run), "--data", str(heldout), "--kinds", "noise",
                    "--levels", "noise=10", "--name", "x"],
    }


@pytest.mark.parametrize("command", ["compare", "report", "evaluate", "perturb"])
@pytest.mark.parametrize("name", DAMAGES)
def test_a_damaged_run_json_is_refused_by_every_reader(name, command, run_folder, heldout_file,
                                                        tmp_path):
    damage, where, what = DAMAGES[name]
    run, before = _damaged(run_folder, tmp_path, damage)
    out = tmp_path / "out"
    result = runner.invoke(app, _commands(run, run_folder, heldout_file, out)[command])
    _check_one_line(result, run, where, what)
    assert not out.exists()
    assert not (run / "eval" / "x").exists() and not (run / "perturb").exists()
    assert {p.relative_to(run): p.read_bytes() for p in run.rglob("*") if p.is_file()} == before


@pytest.mark.parametrize("name", CONFIG_DAMAGES)
def test_report_refuses_a_damaged_config_on_one_line(name, run_folder, tmp_path):
    damage, where, what = CONFIG_DAMAGES[name]
    run, before = _damaged(run_folder, tmp_path, damage)
    out = tmp_path / "out"
    result = runner.invoke(app, ["report", str(run), "--out", str(out)])
    _check_one_line(result, run, where, what)
    assert not out.exists()
    assert {p.relative_to(run): p.read_bytes() for p in run.rglob("*") if p.is_file()} == before


def test_compare_refuses_a_damaged_metrics_json_on_one_line(run_folder, tmp_path):
    run, _ = _damaged(run_folder, tmp_path, lambda r: (r / "eval" / "held" / "metrics.json")
                      .write_text("[1, 2]"))
    result = runner.invoke(app, ["compare", str(run), str(run_folder)])
    assert result.exit_code == 2, result.output
    lines = result.stderr.splitlines()
    assert lines == [f"tactile: error: {run}/eval/held/metrics.json: metrics.json is not a "
                     "JSON object; re-create it with `tactile evaluate` (--overwrite)"]


@pytest.mark.parametrize("command", ["evaluate", "perturb"])
def test_data_whose_label_lost_its_classes_is_refused(command, run_folder, heldout_file,
                                                      tmp_path):
    data = tmp_path / "heldout.h5"
    shutil.copy(heldout_file, data)
    with h5py.File(data, "r+") as f:
        trials = sorted(f["trials"])
        for t in trials:
            del f[f"trials/{t}/signals/event_counts/sample_labels/action"].attrs["classes"]
    before = data.read_bytes()
    run = tmp_path / "run"
    shutil.copytree(run_folder, run)
    result = runner.invoke(app, _commands(run, run_folder, data, tmp_path / "out")[command])
    assert result.exit_code == 2, result.output
    lines = result.stderr.splitlines()
    assert len(lines) == 1 and "Traceback" not in result.output, result.stderr
    assert lines[0].startswith(f"tactile: error: {data}, /trials/{trials[0]}/signals/"
                               "event_counts/sample_labels/action: label 'action' has no "
                               "`classes` attribute"), lines[0]
    assert not (run / "eval" / "x").exists() and not (run / "perturb").exists()
    assert data.read_bytes() == before


@pytest.mark.parametrize("edit, message", [
    (lambda m: m["heads"][m["primary_head"]].update(accuracy="high"), "`accuracy` and"),
    (lambda m: m["heads"][m["primary_head"]]["per_class"][0].update(f1="x"),
     "`per_class` must list"),
    (lambda m: m["heads"][m["primary_head"]].update(confusion_matrix=[[1]]),
     "`confusion_matrix` must be"),
    (lambda m: m.update(latency={"batch1_ms_median": "fast"}), "`latency` must hold"),
    (lambda m: m.update(model=None), "`model` must hold"),
    (lambda m: m.update(n_windows=1.5), "`n_windows` must be an integer"),
])
def test_read_metrics_checks_the_fields_compare_and_report_read(tmp_path, edit, message):
    from tactile_cli.learn.evaluate import classification_metrics
    from tactile_cli.learn.runs import read_metrics

    cm = classification_metrics(np.array([0, 1, 1]), np.array([0, 1, 0]), ["a", "b"],
                                head="h")
    m = {"format": "tactile-eval", "format_version": 1, "primary_head": "h",
         "heads": {"h": cm.as_dict()}, "latency": None,
         "model": {"n_params": 10, "size_mb": 0.1}, "n_windows": 3}
    path = tmp_path / "metrics.json"
    path.write_text(json.dumps(m))
    assert read_metrics(path)["heads"]["h"]["n"] == 3
    edit(m)
    path.write_text(json.dumps(m))
    with pytest.raises(InputError, match=re.escape(message)):
        read_metrics(path)
