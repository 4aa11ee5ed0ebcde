"""The training config: validated up front, errors name the file, line and key."""

from __future__ import annotations

from pathlib import Path

import pytest
import yaml
from typer.testing import CliRunner

from tactile_cli.cli import app
from tactile_cli.errors import InputError
from tactile_cli.learn.config import load_config

REPO = Path(__file__).resolve().parents[2]
runner = CliRunner()

GOOD = """\
seed: 1
data:
  stream: event_counts
  channels: [net]
  window: 25
  targets:
    - {name: action}
model:
  family: lstm
  hidden: 8
optim:
  epochs: 2
"""


def _write(tmp_path, text: str) -> Path:
    path = tmp_path / "cfg.yaml"
    path.write_text(text)
    return path


def test_defaults_are_filled_and_the_resolved_config_round_trips(tmp_path):
    cfg = load_config(_write(tmp_path, GOOD))
    assert cfg.model.family == "lstm" and cfg.model.layers == 1 and cfg.optim.lr == 1e-3
    again = yaml.safe_load(cfg.as_yaml())
    assert again["model"] == {"dropout": 0.0, "head_hidden": [], "family": "lstm",
                              "hidden": 8, "layers": 1}
    over = cfg.with_overrides(seed=5, epochs=9)
    assert (over.seed, over.optim.epochs, cfg.seed) == (5, 9, 1)


@pytest.mark.parametrize(
    ("old", "new", "message"),
    [
        ("  hidden: 8", "  hiden: 8",
         r"unknown key `model.hiden` \(allowed here: dropout, head_hidden, family, hidden, "
         r"layers\)"),
        ("  epochs: 2", "  epochs: 2\n  lr_decay: 0.5", r"unknown key `optim.lr_decay`"),
        ("    - {name: action}", "    - {name: action, wieght: 2}",
         r"unknown key `data.targets\[0\].wieght`"),
        ("  window: 25", "  window: 0", r"`data.window`: Input should be greater than or "
                                        r"equal to 1 \(got 0\)"),
        ("  family: lstm", "  family: gru", r"model.family must be one of lstm, cnn1d"),
        ("  window: 25\n", "", r"missing key `data.window`"),
    ],
)
def test_bad_keys_are_named_with_file_and_line(tmp_path, old, new, message):
    path = _write(tmp_path, GOOD.replace(old, new))
    with pytest.raises(InputError, match=message) as info:
        load_config(path)
    assert str(info.value).startswith(f"{path}, line ")


def test_cli_unknown_key_exits_2_naming_key_and_file(tmp_path, action_file):
    path = _write(tmp_path, GOOD.replace("  window: 25", "  window: 25\n  windw: 3"))
    result = runner.invoke(app, ["train", str(path), "--data", str(action_file),
                                 "--out", str(tmp_path / "run")])
    assert result.exit_code == 2
    assert result.stderr.strip() == (
        f"tactile: error: {path}, line 6: unknown key `data.windw` (allowed here: stream, "
        "channels, window, stride, align, pad, label_rule, label_delay, targets, bin_s, "
        "transform, normalise, window_norm, class_weights, decide_by, split, boundary_margin, "
        "baseline, augment, frames)")
    assert not (tmp_path / "run").exists()


def test_shipped_configs_are_valid_and_the_lstm_is_the_papers():
    paths = sorted((REPO / "configs").glob("train_*.yaml"))
    families = {load_config(p).model.family for p in paths}
    assert {"lstm", "fnn", "cnn1d", "mlp"} <= families
    lstm = load_config(REPO / "configs" / "train_lstm_actions.yaml")
    # paper 000, sec. 5: one LSTM layer, one fully connected layer (the head), softmax
    assert lstm.model.family == "lstm" and lstm.model.layers == 1
    assert lstm.model.head_hidden == []
    assert lstm.data.channels == ["net"] and lstm.data.stream == "event_counts"
    assert [t.name for t in lstm.data.targets] == ["action"]


def test_a_channel_configuration_can_be_named(tmp_path):
    """`channels: LxRx` stands for paper 001's set; an unknown name is a one-line error."""
    cfg = load_config(_write(tmp_path, GOOD.replace("channels: [net]", "channels: LxRx")))
    assert cfg.data.channels == ["L_x", "R_x"]
    assert load_config(REPO / "configs" / "train_lstm_vibro.yaml").data.channels == [
        "L_x", "L_y", "L_z", "R_x", "R_y", "R_z"]
    with pytest.raises(InputError, match="'L4' is not a channel configuration"):
        load_config(_write(tmp_path, GOOD.replace("channels: [net]", "channels: L4")))
