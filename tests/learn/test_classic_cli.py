"""`tactile train`, `evaluate`, `export` and `compare` with a classic family (issue 34,
item 3), through the CLI on a tiny synthetic grasp table (60 one-sample trials of 72
electrodes, :mod:`tests.factories.grasp_tables`)."""

from __future__ import annotations

import json

import pytest
import yaml
from typer.testing import CliRunner

from tactile_cli.cli import app

from ..factories.grasp_tables import write_grasp_file

runner = CliRunner()


def _config(model: dict) -> dict:
    return {"seed": 0,
            "data": {"stream": "electrodes", "channels": ["ff_biotac_*", "mf_biotac_*",
                                                          "th_biotac_*"],
                     "window": 1, "targets": [{"name": "slipped", "source": "trial"}],
                     "split": {"mode": "stratified", "by": "slipped", "val_fraction": 0.2,
                               "test_fraction": 0.2}},
            "model": model, "optim": {"epochs": 5, "batch_size": 16, "lr": 0.01}}


@pytest.fixture(scope="module")
def grasp(tmp_path_factory):
    root = tmp_path_factory.mktemp("grasp_cli")
    data = root / "grasps.h5"
    write_grasp_file(data)
    for name, model in (("logistic", {"family": "logistic", "input": "raw", "c": 0.5}),
                        ("mlp", {"family": "mlp", "hidden": [8], "features": ["last"]})):
        (root / f"{name}.yaml").write_text(yaml.safe_dump(_config(model)))
    return root, data


def _ok(args):
    result = runner.invoke(app, args)
    assert result.exit_code == 0, result.output
    return result


@pytest.mark.slow
def test_cli_train_a_classic_family(grasp):
    root, data = grasp
    out = _ok(["train", str(root / "logistic.yaml"), "--data", str(data), "--out",
               str(root / "run_logistic")]).stdout
    assert f"wrote {root / 'run_logistic'}: logistic, 73 parameters, best epoch 1/1" in out
    info = json.loads((root / "run_logistic" / "run.json").read_text())
    assert info["model"]["input"] == "raw" and info["model"]["n_inputs"] == 72
    assert info["split"]["trials"] == {"train": 36, "val": 12, "test": 12}


@pytest.mark.slow  # uses the run test_cli_train_a_classic_family wrote
def test_cli_evaluate_a_classic_family(grasp):
    root, data = grasp
    run = root / "run_logistic"
    out = _ok(["evaluate", str(run), "--data", str(data), "--split", "test", "--json"])
    metrics = json.loads(out.stdout)
    assert metrics["family"] == "logistic" and metrics["n_trials"] == 12
    assert metrics["model"]["n_params"] == 73
    assert metrics["model"]["file_size_bytes"] == (run / "model.onnx").stat().st_size
    assert metrics["latency"]["batch1_ms_median"] > 0
    assert metrics["heads"]["slipped"]["accuracy_ci95"] is not None


@pytest.mark.slow  # uses the run test_cli_train_a_classic_family wrote
def test_cli_export_a_classic_family_and_check_it(grasp):
    root, data = grasp
    run, onnx_file = root / "run_logistic", root / "logistic.onnx"
    side = json.loads(_ok(["export", str(run), "--out", str(onnx_file), "--json"]).stdout)
    assert side["model"]["family"] == "logistic" and side["model"]["format"] == "onnx"
    assert side["outputs"][0]["name"] == "slipped.probabilities"
    assert side["versions"]["skl2onnx"]
    out = _ok(["evaluate", str(run), "--data", str(data), "--exported", str(onnx_file),
               "--name", "exported", "--json"])
    assert json.loads(out.stdout)["exported"]["max_abs_diff"] <= 1e-5
    result = runner.invoke(app, ["export", str(run), "--out", str(root / "m.pt"),
                                 "--format", "torchscript"])
    assert result.exit_code == 2
    assert "the logistic family cannot be exported to torchscript" in result.output


@pytest.mark.slow
def test_cli_compare_puts_a_classic_family_beside_a_network(grasp):
    root, data = grasp
    _ok(["train", str(root / "mlp.yaml"), "--data", str(data), "--out", str(root / "run_mlp")])
    for run in ("run_logistic", "run_mlp"):
        _ok(["evaluate", str(root / run), "--data", str(data), "--name", "all",
             "--overwrite"])
    out = _ok(["compare", str(root / "run_logistic"), str(root / "run_mlp"), "--data-name",
               "all", "--out", str(root / "cmp"), "--json"])
    table = {row["family"]: row for row in json.loads(out.stdout)["table"]}
    assert set(table) == {"logistic", "mlp"}
    assert table["logistic"]["n_params"] == 73 < table["mlp"]["n_params"]
    assert (root / "cmp" / "compare.png").stat().st_size > 0
