"""``--device auto|cpu|cuda`` of train, evaluate and sweep (issue 35, item 7). CI has no GPU
(the pinned torch is the CPU build): these tests check the parsing, the refusal of
``cuda`` without a GPU, the device recorded in the run, and that the CPU gives the same
run as before the option existed."""

from __future__ import annotations

import json

import pytest
import torch
import yaml
from typer.testing import CliRunner

from tactile_cli.cli import app
from tactile_cli.errors import InputError
from tactile_cli.learn.device import resolve_device
from tactile_cli.learn.evaluate import evaluate
from tactile_cli.learn.train import train

from .conftest import tiny_config

runner = CliRunner()


def test_auto_is_cuda_only_where_torch_sees_a_gpu(monkeypatch):
    monkeypatch.setattr(torch.cuda, "is_available", lambda: False)
    assert resolve_device("auto") == torch.device("cpu")
    assert resolve_device("cpu") == torch.device("cpu")
    with pytest.raises(InputError, match=r"^`device` \(=cuda\): torch .* sees no CUDA GPU; "
                                         r"use `device='cpu'` or `device='auto'`$"):
        resolve_device("cuda")
    with pytest.raises(InputError, match=r"`device` \(='gpu'\) must be one of auto, cpu, cuda"):
        resolve_device("gpu")
    monkeypatch.setenv("CUBLAS_WORKSPACE_CONFIG", ":4096:8")
    monkeypatch.setattr(torch.cuda, "is_available", lambda: True)
    assert resolve_device("auto") == torch.device("cuda")
    assert resolve_device("cpu") == torch.device("cpu")


@pytest.mark.slow
def test_the_cpu_gives_the_run_it_gave_before_and_records_the_device(action_file, tmp_path):
    cfg = tiny_config()
    default = train(cfg, [action_file], tmp_path / "default", command="tests")
    cpu = train(cfg, [action_file], tmp_path / "cpu", command="tests", device="cpu")
    assert default.device == cpu.device == "cpu"
    a = torch.load(tmp_path / "default" / "model.pt", weights_only=True)
    b = torch.load(tmp_path / "cpu" / "model.pt", weights_only=True)
    assert a.keys() == b.keys() and all(torch.equal(a[k], b[k]) for k in a)
    info = json.loads((tmp_path / "cpu" / "run.json").read_text())
    assert info["training"]["device"] == "cpu" and info["training"]["device_requested"] == "cpu"
    m = evaluate(tmp_path / "cpu", [action_file], name="x", latency=False, command="tests",
                 device="cpu")
    stored = json.loads((tmp_path / "cpu" / "eval" / "x" / "metrics.json").read_text())
    assert m.extra["device"] == "cpu" and stored["device"] == "cpu"


@pytest.mark.skipif(torch.cuda.is_available(), reason="this machine has a GPU")
@pytest.mark.parametrize("command", ["train", "evaluate", "sweep"])
def test_cuda_without_a_gpu_is_one_line_before_any_work(command, action_file, tmp_path):
    config = tmp_path / "c.yaml"
    config.write_text(yaml.safe_dump(tiny_config().model_dump(mode="json")))
    args = {"train": ["train", str(config), "--data", str(action_file), "--out",
                      str(tmp_path / "run")],
            "evaluate": ["evaluate", str(tmp_path / "nothing"), "--data", str(action_file)],
            "sweep": ["sweep", str(tmp_path / "sweep.yaml"), "--out", str(tmp_path / "s")]}
    result = runner.invoke(app, [*args[command], "--device", "cuda"])
    assert result.exit_code == 2, result.output
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and "Traceback" not in result.output
    assert lines[0].startswith("tactile: error: --device (=cuda): torch ")
    assert lines[0].endswith("sees no CUDA GPU; use --device cpu or --device auto")
    assert not (tmp_path / "run").exists() and not (tmp_path / "s").exists()


def test_an_unknown_device_is_one_line(action_file, tmp_path):
    config = tmp_path / "c.yaml"
    config.write_text(yaml.safe_dump(tiny_config().model_dump(mode="json")))
    result = runner.invoke(app, ["train", str(config), "--data", str(action_file), "--out",
                                 str(tmp_path / "run"), "--device", "gpu"])
    assert result.exit_code == 2
    assert result.stderr.strip() == ("tactile: error: --device (='gpu') must be one of auto, "
                                     "cpu, cuda")
