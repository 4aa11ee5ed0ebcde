"""Absurd sizes in a training config (issue 20): refused before any data are read, with the
key, its line and, for sizes that cannot fit, the estimate and this machine's memory."""

from __future__ import annotations

import pytest
import yaml
from typer.testing import CliRunner

from tactile_cli.cli import app
from tactile_cli.config_file import format_bytes, machine_memory_bytes

from .conftest import tiny_config

runner = CliRunner()


def _config(tmp_path, edit) -> tuple:
    raw = yaml.safe_load(tiny_config().as_yaml())
    edit(raw)
    path = tmp_path / "train.yaml"
    text = yaml.safe_dump(raw, sort_keys=False)
    path.write_text(text)
    return path, text.splitlines()


def _line_of(lines, key) -> int:
    return next(i for i, line in enumerate(lines, start=1) if line.strip().startswith(key))


def _error(tmp_path, path) -> str:
    out = tmp_path / "run"
    res = runner.invoke(app, ["train", str(path), "--data", str(tmp_path / "absent.h5"),
                              "--out", str(out)])
    assert res.exit_code == 2, res.output
    lines = res.stderr.splitlines()
    assert len(lines) == 1 and "Traceback" not in res.output, res.stderr
    assert not out.exists()
    return lines[0]


@pytest.mark.parametrize(("section", "key", "value", "bound"), [
    ("model", "hidden", 10**12, "100000"),
    ("data", "window", 10**12, "10000000"),
    ("optim", "threads", 10**6, "1024"),
    ("optim", "batch_size", 10**12, "10000000"),
])
def test_a_size_beyond_its_bound_names_the_key_and_line(tmp_path, section, key, value, bound):
    path, lines = _config(tmp_path, lambda raw: raw[section].update({key: value}))
    error = _error(tmp_path, path)
    assert error.startswith(f"tactile: error: {path}, line {_line_of(lines, key + ':')}: "
                            f"`{section}.{key}`: Input should be less than or equal to {bound}")


def test_a_rate_of_infinity_is_refused(tmp_path):
    path, lines = _config(tmp_path, lambda raw: raw["optim"].update(lr=float("inf")))
    assert "`optim.lr`: Input should be a finite number" in _error(tmp_path, path)


def test_a_config_that_cannot_fit_gives_the_estimate_and_the_machine_memory(tmp_path):
    path, lines = _config(tmp_path, lambda raw: raw["model"].update(hidden=100_000, layers=50))
    error = _error(tmp_path, path)
    assert error.startswith(f"tactile: error: {path}, line {_line_of(lines, 'hidden:')}: "
                            "`model.hidden` (=100000) needs about ")
    assert "for the model's" in error
    assert error.endswith(f"this machine has {format_bytes(machine_memory_bytes())}: make it "
                          "smaller")
