"""Issue 20: `data.bin_s` is a whole number of microseconds (at least 1 us)."""

from __future__ import annotations

from pathlib import Path

import pytest
import yaml

from tactile_cli.errors import InputError
from tactile_cli.learn.config import load_config, parse_config

BASE = Path(__file__).resolve().parents[2] / "configs" / "train_lstm_actions.yaml"


@pytest.mark.parametrize("bin_s", [1e-300, 1e-7, 0.0200005, 0.0])
def test_bin_s_must_be_whole_microseconds(tmp_path, bin_s):
    raw = yaml.safe_load(BASE.read_text())
    raw["data"]["bin_s"] = bin_s
    path = tmp_path / "train.yaml"
    path.write_text(yaml.safe_dump(raw))
    with pytest.raises(InputError) as exc:
        load_config(path)
    assert "bin_s" in str(exc.value) and str(path) in str(exc.value)


@pytest.mark.parametrize("bin_s", [1e-6, 0.02, 0.001, 0.1])
def test_whole_microsecond_bins_are_kept(bin_s):
    raw = yaml.safe_load(BASE.read_text())
    raw["data"]["bin_s"] = bin_s
    assert parse_config(raw).data.bin_s == bin_s
