"""benchmarks/seed_spread.py: one config cross-validated at several seeds, the spread
reported (the GelSight lifts moved 20 points with the seed; RESULTS.md, "Seeds")."""

from __future__ import annotations

import json

import pytest

from tests.conftest import load_benchmark

from .conftest import tiny_config


def _script():
    return load_benchmark("seed_spread")


@pytest.mark.slow
def test_each_seed_is_a_run_and_the_summary_is_their_spread(action_file, tmp_path, capsys):
    config = tmp_path / "tiny.yaml"
    config.write_text(tiny_config(data={"split": {"mode": "random", "val_fraction": 0.0}},
                                  optim={"epochs": 2}).as_yaml())
    script = _script()
    record_path = tmp_path / "spread.json"
    assert script.main([str(config), "--data", str(action_file), "--cv", "2", "--seeds", "0",
                        "3", "--record", str(record_path), "--work", str(tmp_path / "w")]) == 0
    record = json.loads(record_path.read_text())
    assert record["seeds"] == [0, 3] and [r["seed"] for r in record["by_seed"]] == [0, 3]
    assert record["split_depends_on_seed"] is True
    acc = [r["window_accuracy"] for r in record["by_seed"]]
    summary = record["summary"]["window_accuracy"]
    assert summary["min"] == min(acc) and summary["max"] == max(acc)
    assert summary["spread"] == pytest.approx(max(acc) - min(acc))
    assert summary["mean"] == pytest.approx(sum(acc) / 2)
    assert all(len(r["folds"]) == 2 for r in record["by_seed"])
    # a seed's figures are those of that seed alone, run again
    again = tmp_path / "again.json"
    assert script.main([str(config), "--data", str(action_file), "--cv", "2", "--seeds", "3",
                        "--record", str(again)]) == 0
    assert json.loads(again.read_text())["by_seed"][0]["window_accuracy"] == acc[1]
    assert "| spread |" in capsys.readouterr().out


def test_a_seed_given_twice_is_refused(action_file, tmp_path, capsys):
    config = tmp_path / "tiny.yaml"
    config.write_text(tiny_config().as_yaml())
    assert _script().main([str(config), "--data", str(action_file), "--seeds", "1",
                           "1"]) == 2
    assert capsys.readouterr().err.strip() == "error: `seeds` gives seed 1 twice"


def test_a_bad_cv_is_one_line(action_file, tmp_path, capsys):
    config = tmp_path / "tiny.yaml"
    config.write_text(tiny_config().as_yaml())
    assert _script().main([str(config), "--data", str(action_file), "--cv", "1"]) == 2
    assert capsys.readouterr().err.strip() == (
        "error: `k` must be an integer >= 2 or loto, got '1'")
