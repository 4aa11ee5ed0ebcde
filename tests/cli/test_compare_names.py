"""`tactile compare` names each run by the part of its folder that tells it apart from the
others (relative to the runs' common folder), never cut."""

from __future__ import annotations

from pathlib import Path

import pytest
from typer.testing import CliRunner

from tactile_cli.cli import app
from tactile_cli.learn import compare as compare_module
from tactile_cli.learn.compare import RunPoint, compare_points, distinct_run_paths

runner = CliRunner()
SWEEP = "experiments/2026-11-24_sweep_xela_slip_long_window_study"


def test_distinct_run_paths(tmp_path):
    sweep = [tmp_path / SWEEP / f"lr{lr}" / "run_lstm_window50_stride1_normalised"
             for lr in ("0.003", "0.01")]
    assert distinct_run_paths(sweep) == ["lr0.003/run_lstm_window50_stride1_normalised",
                                         "lr0.01/run_lstm_window50_stride1_normalised"]
    siblings = [tmp_path / "runs" / "lstm", tmp_path / "runs" / "mlp"]
    assert distinct_run_paths(siblings) == ["lstm", "mlp"]
    assert distinct_run_paths([tmp_path / "runs" / "lstm"]) == ["lstm"]
    assert distinct_run_paths([tmp_path / "a" / "x", tmp_path / "b" / "c" / "y"]) == [
        "a/x", "b/c/y"]


def _point(run: Path, family: str, score: float, latency_ms: float, n_params: int) -> RunPoint:
    return RunPoint(run=str(run), label=f"{family}/{run.name}", family=family, eval_name="scene",
                    metrics_path="", score=score, accuracy=score, macro_f1=score,
                    latency_ms=latency_ms, latency_p95_ms=latency_ms, windows_per_s=1000.0,
                    n_params=n_params, size_mb=n_params * 4e-6, n_windows=100, split="all",
                    primary_head="action")


@pytest.mark.parametrize("columns", [None, "80"])
def test_table_shows_the_distinguishing_part_of_long_run_names(tmp_path, monkeypatch, columns):
    names = [("lstm", 0.95, 0.5, 5000), ("cnn1d", 0.94, 0.2, 3000), ("mlp", 0.90, 0.05, 800)]
    runs = [tmp_path / SWEEP / f"seed0_hidden{32 * (i + 1)}"
            / f"run_{fam}_window50_stride1_normalised" for i, (fam, *_) in enumerate(names)]
    points = [_point(run, fam, *rest) for run, (fam, *rest) in zip(runs, names, strict=True)]
    cmp = compare_points(points, data_name="scene")
    monkeypatch.setattr(compare_module, "compare", lambda *args, **kwargs: cmp)
    env = {} if columns is None else {"COLUMNS": columns}
    result = runner.invoke(app, ["compare", *map(str, runs)], env=env)
    assert result.exit_code == 0, result.output
    table = result.output.split("the model this scene needs")[0]
    assert "…" not in table
    assert SWEEP not in table  # the common prefix is left out
    for run in runs:
        name = f"{run.parent.name}/{run.name}"
        assert name in table  # whole, on one line: not cut, not folded
