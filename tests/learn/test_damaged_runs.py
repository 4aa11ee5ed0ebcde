"""A damaged run folder (issue 20, item 5): `tactile evaluate` refuses it on one line naming
the file and what to do, exit 2, no traceback, no eval folder, the run left as it was."""

from __future__ import annotations

import json
import shutil

import pytest
from typer.testing import CliRunner

from tactile_cli.cli import app
from tactile_cli.learn.train import train

from .conftest import tiny_config

runner = CliRunner()


@pytest.fixture(scope="module")
def run_folder(tmp_path_factory, action_file):
    out = tmp_path_factory.mktemp("damaged") / "run"
    train(tiny_config(optim={"epochs": 1}), [action_file], out, command="test")
    return out


def _json_edit(name, change):
    def damage(run):
        obj = json.loads((run / name).read_text())
        change(obj)
        (run / name).write_text(json.dumps(obj))
    return damage


def _cut(name, keep=0.5):
    def damage(run):
        data = (run / name).read_bytes()
        (run / name).write_bytes(data[:int(len(data) * keep)])
    return damage


def _bytes(name, data):
    def damage(run):
        (run / name).write_bytes(data)
    return damage


def _set_std(value):
    def change(obj):
        obj["std"][0] = value
    return change


DAMAGES = {
    "cut normalisation": (_cut("normalisation.json"), "normalisation.json, line",
                          "not valid JSON"),
    "zero std": (_json_edit("normalisation.json", _set_std(0.0)), "normalisation.json",
                 "`std[0]` (=0.0) must be finite and positive"),
    "null std": (_json_edit("normalisation.json", _set_std(None)), "normalisation.json",
                 "`std` must be a list of numbers"),
    "std as text": (_json_edit("normalisation.json", _set_std("wide")), "normalisation.json",
                    "`std` must be a list of numbers"),
    "missing mean": (_json_edit("normalisation.json", lambda o: o.pop("mean")),
                     "normalisation.json", "key `mean` is missing"),
    "normalisation gone": (lambda run: (run / "normalisation.json").unlink(), "run",
                           "run folder has no normalisation.json"),
    "heads gone": (_json_edit("run.json", lambda o: o.pop("heads")), "run.json",
                   "run.json has no `heads`"),
    "head kind": (_json_edit("run.json", lambda o: o["heads"][0].update(kind=3)), "run.json",
                  "`heads[0]` is not a valid head record"),
    "data retyped": (_json_edit("run.json", lambda o: o.update(data="x")), "run.json",
                     "`data` must list the training files"),
    "run.json bytes": (_bytes("run.json", b"\xff\xfe{\x00garbage"), "run.json, line 1",
                       "not UTF-8 text (byte 0xff at column 1)"),
    "run.json a list": (_bytes("run.json", b"[1, 2]"), "run.json",
                        "run.json is not a JSON object"),
    "broken config": (_bytes("config.resolved.yaml", b"data: [\n  model: {\n"),
                      "config.resolved.yaml, line", "not valid YAML"),
    "config key retyped": (lambda run: (run / "config.resolved.yaml").write_text(
        (run / "config.resolved.yaml").read_text().replace("hidden: 16", "hidden: wide")),
        "config.resolved.yaml, line", "hidden"),
    "random model.pt": (_bytes("model.pt", bytes(range(256)) * 8), "model.pt",
                        "model.pt cannot be loaded"),
    "cut model.pt": (_cut("model.pt"), "model.pt", "model.pt cannot be loaded"),
}


@pytest.mark.parametrize("name", DAMAGES)
def test_a_damaged_run_folder_is_one_line_naming_the_file(name, run_folder, heldout_file,
                                                          tmp_path):
    damage, where, what = DAMAGES[name]
    run = tmp_path / "run"
    shutil.copytree(run_folder, run)
    damage(run)
    before = {p.name: p.read_bytes() for p in run.iterdir() if p.is_file()}
    result = runner.invoke(app, ["evaluate", str(run), "--data", str(heldout_file),
                                 "--no-latency"])
    assert result.exit_code == 2, result.output
    lines = result.stderr.splitlines()
    assert len(lines) == 1 and lines[0].startswith("tactile: error: "), result.stderr
    assert "Traceback" not in result.output
    assert f"{run}/{where}" in lines[0] or (where == "run" and f"{run}: " in lines[0])
    assert what in lines[0]
    assert "tactile train" in lines[0]  # what to do
    assert not (run / "eval").exists()
    assert {p.name: p.read_bytes() for p in run.iterdir() if p.is_file()} == before


def test_a_run_folder_that_is_a_symlink_loop_is_not_reported_missing(tmp_path, heldout_file):
    (tmp_path / "a").symlink_to(tmp_path / "b")
    (tmp_path / "b").symlink_to(tmp_path / "a")
    result = runner.invoke(app, ["evaluate", str(tmp_path / "a"), "--data", str(heldout_file)])
    assert result.exit_code == 2
    assert result.stderr.splitlines() == [
        f"tactile: error: {tmp_path / 'a'}: run folder is a symlink loop; point the link at a "
        "real file"]
