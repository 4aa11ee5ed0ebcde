"""`tactile compare`: Pareto front, the model this scene needs, files and CLI."""

from __future__ import annotations

import csv
import json
import math

import numpy as np
import pytest
from typer.testing import CliRunner

from tactile_cli.cli import app
from tactile_cli.errors import InputError
from tactile_cli.learn.compare import (
    RunPoint,
    compare,
    compare_points,
    pareto_front,
    pick_needed,
    within_margin,
    write_comparison,
)

from .tiny_runs import tiny_runs

runner = CliRunner()
PNG = b"\x89PNG\r\n\x1a\n"


@pytest.fixture(scope="session")
def runs(tmp_path_factory, action_file, heldout_file):
    return tiny_runs(tmp_path_factory, action_file, heldout_file)


def point(label: str, score: float, latency_ms: float | None, n_params: int) -> RunPoint:
    return RunPoint(run=label, label=label, family=label.split("/")[0], eval_name="e",
                    metrics_path="", score=score, accuracy=score, macro_f1=score,
                    latency_ms=latency_ms, latency_p95_ms=latency_ms, windows_per_s=None,
                    n_params=n_params, size_mb=n_params * 4e-6, n_windows=100, split="all",
                    primary_head="action")


def run_info(family):
    """A run.json with every key `tactile train` writes (read_run_info checks them)."""
    return {"format": "tactile-run", "format_version": 1, "created_utc": "2026-01-01T00:00:00",
            "command": "test", "config_file": None, "versions": {}, "seed": 0, "data": [],
            "heads": [], "class_weights": None, "split": {}, "model": {"family": family},
            "training": {}, "wall_time_s": 0.0}


def fake_run(root, name, family, *, accuracy, latency_ms, n_params, data_name="scene",
             sha="a" * 64, split="all", f1_slip=0.5, recordings=None, n_trials=3):
    """A run folder with run.json and one hand-made eval/<data_name>/metrics.json."""
    run = root / name
    (run / "eval" / data_name).mkdir(parents=True)
    (run / "run.json").write_text(json.dumps(run_info(family)))
    metrics = {
        "format": "tactile-eval", "format_version": 1, "family": family, "name": data_name,
        "split": split, "data": [{"path": "scene.h5", "sha256": sha, "n_trials": n_trials,
                                       **({} if recordings is None else
                                          {"recordings_sha256": recordings})}],
        "n_windows": 1000, "primary_head": "action", "accuracy": accuracy,
        "heads": {"action": {"head": "action", "kind": "classification", "n": 1000,
                             "accuracy": accuracy, "macro_f1": accuracy - 0.01,
                             "per_class": [{"name": "press", "f1": 0.9},
                                           {"name": "slip", "f1": f1_slip}]}},
        "latency": None if latency_ms is None else {
            "batch1_ms_median": latency_ms, "batch1_ms_p95": 1.5 * latency_ms,
            "windows_per_s": 1e6, "threads": 1, "cpu": "test"},
        "model": {"n_params": n_params, "size_mb": n_params * 4e-6, "file_size_bytes": 10},
    }
    (run / "eval" / data_name / "metrics.json").write_text(json.dumps(metrics))
    return run


# -- pure selection --------------------------------------------------------------------------
def test_pareto_front_on_hand_made_points():
    # a: best and slowest; b: faster, a bit worse; c: dominated by b; d: fastest, worst;
    # e: same as b exactly (ties are both on the front); f: no latency
    score = np.array([0.999, 0.996, 0.995, 0.98, 0.996, 0.9999])
    lat = np.array([1.0, 0.5, 2.0, 0.1, 0.5, np.nan])
    assert pareto_front(score, lat).tolist() == [True, True, False, True, True, False]
    # one point dominating all others on both axes: the front is that point alone
    assert pareto_front(np.array([0.9, 0.95, 0.8]), np.array([1.0, 0.2, 0.3])).tolist() == \
        [False, True, False]
    # same latency, lower score: dominated; same score, higher latency: dominated
    assert pareto_front(np.array([0.9, 0.8]), np.array([1.0, 1.0])).tolist() == [True, False]
    assert pareto_front(np.array([0.9, 0.9]), np.array([1.0, 2.0])).tolist() == [True, False]


def test_margin_selection_picks_the_smallest_model_and_names_the_fastest():
    pts = [point("lstm/a", 0.999, 1.0, 100_000), point("cnn1d/b", 0.996, 0.5, 10_000),
           point("mlp/c", 0.995, 2.0, 5_000), point("fnn/d", 0.98, 0.1, 1_000)]
    cmp = compare_points(pts, margin_pp=0.5)
    assert [p.within_margin for p in pts] == [True, True, True, False]  # 0.4 pp is inside
    assert cmp.best.label == "lstm/a"
    assert cmp.needed.label == "mlp/c"  # fewest parameters within 0.5 pp of 99.9 %
    assert cmp.fastest.label == "cnn1d/b"  # lowest latency within the margin
    assert [p.label for p in cmp.pareto] == ["fnn/d", "cnn1d/b", "lstm/a"]  # by latency
    assert "the model this scene needs: mlp/c (5,000 parameters" in cmp.summary()
    # margin 0: only the best qualifies
    cmp0 = compare_points([point("lstm/a", 0.999, 1.0, 100_000),
                           point("mlp/c", 0.995, 2.0, 5_000)], margin_pp=0.0)
    assert cmp0.needed.label == cmp0.fastest.label == "lstm/a"
    # a wide margin reaches the 1,000-parameter FNN
    assert compare_points(pts, margin_pp=2.0).needed.label == "fnn/d"


def test_needed_ties_break_by_latency_and_exact_margin_edge_is_inside():
    n = np.array([500, 500, 400])
    lat = np.array([2.0, 1.0, np.nan])
    assert pick_needed(n, lat, np.array([True, True, False]), ["a", "b", "c"]) == 1
    # no latency counts as slowest
    assert pick_needed(np.array([5, 5]), np.array([np.nan, 3.0]), np.array([True, True]),
                       ["a", "b"]) == 1
    assert within_margin(np.array([0.999, 0.994]), 0.5).tolist() == [True, True]
    assert within_margin(np.array([0.999, 0.9939]), 0.5).tolist() == [True, False]
    with pytest.raises(InputError, match="`margin_pp` must be a number >= 0"):
        compare_points([point("a/a", 0.9, 1.0, 1)], margin_pp=-1)


# -- reading metrics.json --------------------------------------------------------------------
def test_compare_reads_hand_made_metrics_and_writes_chart_table_and_provenance(tmp_path):
    a = fake_run(tmp_path, "big", "lstm", accuracy=0.9990, latency_ms=0.8, n_params=50_000)
    b = fake_run(tmp_path, "small", "mlp", accuracy=0.9960, latency_ms=0.05, n_params=900)
    c = fake_run(tmp_path, "slow", "cnn1d", accuracy=0.9900, latency_ms=3.0, n_params=20_000)
    d = fake_run(tmp_path, "untimed", "fnn", accuracy=0.9991, latency_ms=None, n_params=80_000)
    cmp = compare([a, b, c, d])
    assert cmp.data_name == "scene"
    assert [p.label for p in cmp.points] == ["lstm/big", "mlp/small", "cnn1d/slow",
                                             "fnn/untimed"]
    assert cmp.best.label == "fnn/untimed"
    assert cmp.needed.label == "mlp/small"  # within 0.31 pp, 900 parameters
    assert cmp.fastest.label == "mlp/small"
    assert [p.label for p in cmp.pareto] == ["mlp/small", "lstm/big"]
    assert [p.pareto for p in cmp.points] == [True, True, False, False]

    files = write_comparison(cmp, tmp_path / "out", command="tactile compare test")
    assert files.png.read_bytes()[:8] == PNG
    record = json.loads(files.json.read_text())
    assert record["command"] == "tactile compare test" and record["tool_version"]
    assert record["needed"] == "mlp/small" and record["pareto"] == ["mlp/small", "lstm/big"]
    assert len(record["inputs"]) == 4 and all(len(i["sha256"]) == 64 for i in record["inputs"])
    with open(files.csv) as f:
        rows = list(csv.DictReader(f))
    assert [r["label"] for r in rows] == ["lstm/big", "mlp/small", "cnn1d/slow", "fnn/untimed"]
    assert math.isclose(float(rows[1]["delta_pp"]), -0.31, abs_tol=1e-9)
    assert rows[1]["needed"] == "True" and rows[3]["latency_ms_median"] == ""
    assert not [p for p in (tmp_path / "out").iterdir() if p.name.startswith(".")]


def test_compare_by_f1_of_one_class(tmp_path):
    a = fake_run(tmp_path, "a", "lstm", accuracy=0.99, latency_ms=1.0, n_params=10, f1_slip=0.6)
    b = fake_run(tmp_path, "b", "fnn", accuracy=0.95, latency_ms=1.0, n_params=20, f1_slip=0.8)
    cmp = compare([a, b], metric="f1:slip")
    assert cmp.best.label == "fnn/b" and cmp.needed.label == "fnn/b"
    assert cmp.metric_label == "F1 of class 'slip'"
    with pytest.raises(InputError, match="has no class 'grip'"):
        compare([a, b], metric="f1:grip")


def test_compare_by_per_trial_accuracy_of_a_trial_level_target(tmp_path):
    """Per window the first run wins; per trial (what a texture answer is) the second."""
    a = fake_run(tmp_path, "a", "mlp", accuracy=0.74, latency_ms=0.1, n_params=10)
    b = fake_run(tmp_path, "b", "cnn2d_spectrogram", accuracy=0.71, latency_ms=0.2,
                 n_params=20)
    for run, votes in ((a, 0.88), (b, 0.945)):
        path = run / "eval" / "scene" / "metrics.json"
        m = json.loads(path.read_text())
        m["heads"]["action"]["per_trial"] = {"n_trials": 200, "majority_accuracy": votes}
        path.write_text(json.dumps(m))
    assert compare([a, b]).best.label == "mlp/a"
    cmp = compare([a, b], metric="trial_accuracy")
    assert cmp.best.label == "cnn2d_spectrogram/b" and cmp.metric_label == "per-trial accuracy"
    c = fake_run(tmp_path, "c", "lstm", accuracy=0.9, latency_ms=0.1, n_params=5)
    with pytest.raises(InputError, match="has no per-trial result"):
        compare([a, c], metric="trial_accuracy")


def test_compare_by_per_group_accuracy_of_trials_decided_together(tmp_path):
    """Per trial the first run wins; per experiment (both cameras decided together, a
    config's `decide_by`) the second, with the group interval carried to the chart."""
    a = fake_run(tmp_path, "a", "mlp", accuracy=0.80, latency_ms=0.1, n_params=10)
    b = fake_run(tmp_path, "b", "cnn2d_frames", accuracy=0.78, latency_ms=0.2, n_params=20)
    for run, trial, group in ((a, 0.90, 0.85), (b, 0.88, 0.95)):
        path = run / "eval" / "scene" / "metrics.json"
        m = json.loads(path.read_text())
        m["heads"]["action"]["per_trial"] = {"n_trials": 58, "majority_accuracy": trial}
        m["heads"]["action"]["per_group"] = {"by": "experiment", "n_trials": 29,
                                             "majority_accuracy": group,
                                             "majority_accuracy_ci95": [group - 0.1, 1.0]}
        path.write_text(json.dumps(m))
    assert compare([a, b], metric="trial_accuracy").best.label == "mlp/a"
    cmp = compare([a, b], metric="group_accuracy")
    assert cmp.best.label == "cnn2d_frames/b" and cmp.metric_label == "per-group accuracy"
    assert cmp.best.score == 0.95 and cmp.best.score_ci95 == [0.85, 1.0]
    c = fake_run(tmp_path, "c", "lstm", accuracy=0.9, latency_ms=0.1, n_params=5)
    with pytest.raises(InputError, match="has no per-group result"):
        compare([a, c], metric="group_accuracy")


def test_compare_accepts_a_file_derived_from_the_same_recordings(tmp_path):
    # the spatial run is evaluated on `tactile centroids scene.h5`'s output (another file,
    # whose source is scene.h5 with sha "a"*64): same recordings, same trials, one chart
    a = fake_run(tmp_path, "a", "lstm", accuracy=0.99, latency_ms=1.0, n_params=10)
    s = fake_run(tmp_path, "s", "lstm", accuracy=0.98, latency_ms=0.5, n_params=10,
                 sha="c" * 64, recordings=["a" * 64])
    cmp = compare([a, s])
    assert [p.accuracy for p in cmp.points] == [0.99, 0.98]


def test_compare_refuses_different_data_and_ambiguous_evaluations(tmp_path):
    a = fake_run(tmp_path, "a", "lstm", accuracy=0.99, latency_ms=1.0, n_params=10)
    b = fake_run(tmp_path, "b", "fnn", accuracy=0.95, latency_ms=1.0, n_params=20, sha="b" * 64)
    with pytest.raises(InputError, match="used other recordings than"):
        compare([a, b])
    # a file derived from another recording (its sources) is not the same data either
    b2 = fake_run(tmp_path, "b2", "fnn", accuracy=0.95, latency_ms=1.0, n_params=20,
                  sha="c" * 64, recordings=["e" * 64])
    with pytest.raises(InputError, match="used other recordings than"):
        compare([a, b2])
    # the same recordings, fewer trials of them (tactile centroids --trial): refused
    b3 = fake_run(tmp_path, "b3", "fnn", accuracy=0.95, latency_ms=1.0, n_params=20,
                  sha="c" * 64, recordings=["a" * 64], n_trials=2)
    with pytest.raises(InputError, match="used other recordings than"):
        compare([a, b3])
    c = fake_run(tmp_path, "c", "fnn", accuracy=0.95, latency_ms=1.0, n_params=20,
                 split="test")
    with pytest.raises(InputError, match="evaluation split is 'test' here but 'all'"):
        compare([a, c])
    d = fake_run(tmp_path, "d", "mlp", accuracy=0.9, latency_ms=1.0, n_params=5,
                 data_name="other")
    with pytest.raises(InputError, match=r"the runs share no evaluation \(.*a: scene; .*d: "
                                         r"other\)"):
        compare([a, d])
    with pytest.raises(InputError, match="no evaluation named 'scene' .evaluations: other."):
        compare([a, d], data_name="scene")
    with pytest.raises(InputError, match="run given twice"):
        compare([a, a])


# -- real runs and the CLI -------------------------------------------------------------------
@pytest.mark.slow
def test_compare_real_runs_reads_evaluate_output(runs):
    cmp = compare(list(runs.values()))
    assert cmp.data_name == "heldout"
    assert {p.family for p in cmp.points} == {"lstm", "fnn", "mlp"}
    for p in cmp.points:
        m = json.loads((runs[p.family] / "eval" / "heldout" / "metrics.json").read_text())
        assert p.score == m["accuracy"] and p.n_params == m["model"]["n_params"]
        assert p.latency_ms == m["latency"]["batch1_ms_median"] > 0
    assert cmp.pareto and cmp.best.pareto  # the most accurate run is on the front


@pytest.mark.slow
def test_cli_compare_table_files_json_and_errors(runs, tmp_path):
    dirs = [str(d) for d in runs.values()]
    res = runner.invoke(app, ["compare", *dirs, "--out", str(tmp_path / "c"), "--margin", "1"])
    assert res.exit_code == 0, res.output
    assert "the model this scene needs:" in res.output
    assert (tmp_path / "c" / "compare.png").read_bytes()[:8] == PNG
    js = runner.invoke(app, ["compare", *dirs, "--json"])
    assert js.exit_code == 0, js.output
    record = json.loads(js.stdout)
    assert record["margin_pp"] == 0.5 and len(record["runs"]) == 3

    missing = runner.invoke(app, ["compare", dirs[0], str(tmp_path / "nope")])
    assert missing.exit_code == 2
    assert missing.stderr == (f"tactile: error: {tmp_path / 'nope'}: run folder not found "
                              "(give the folder `tactile train` wrote)\n")
    bad = runner.invoke(app, ["compare", *dirs, "--data-name", "zzz"])
    assert bad.exit_code == 2
    assert "no evaluation named 'zzz' (evaluations: heldout)" in bad.stderr
    assert len(bad.stderr.strip().splitlines()) == 1
    metric = runner.invoke(app, ["compare", *dirs, "--metric", "recall"])
    assert metric.exit_code == 2
    assert ("--metric must be accuracy, macro_f1, trial_accuracy, group_accuracy or f1:<class>, "
            "got 'recall'"
            in metric.stderr)


def _add_heads(run, **heads):
    """Add heads to a fake run's metrics: name=("classification", accuracy) or
    ("regression", mae)."""
    path = run / "eval" / "scene" / "metrics.json"
    m = json.loads(path.read_text())
    for name, (kind, value) in heads.items():
        m["heads"][name] = ({"head": name, "kind": kind, "n": 1000, "accuracy": value,
                             "macro_f1": value, "per_class": [{"name": "a", "f1": value}]}
                            if kind == "classification" else
                            {"head": name, "kind": kind, "n": 1000, "mae": value, "rmse": value})
    path.write_text(json.dumps(m))


def test_targets_pick_the_smallest_run_meeting_every_one(tmp_path):
    """With targets the choice is the fewest parameters among the runs meeting all of them
    (accuracy at least, MAE at most), not within the margin of the best score."""
    big = fake_run(tmp_path, "big", "cnn2d", accuracy=0.97, latency_ms=0.5, n_params=90_000)
    mid = fake_run(tmp_path, "mid", "lstm", accuracy=0.95, latency_ms=0.4, n_params=40_000)
    tiny = fake_run(tmp_path, "tiny", "mlp", accuracy=0.96, latency_ms=0.1, n_params=900)
    _add_heads(big, object=("classification", 0.98), speed=("regression", 1.1))
    _add_heads(mid, object=("classification", 0.961), speed=("regression", 3.4))
    _add_heads(tiny, object=("classification", 0.90), speed=("regression", 2.0))  # texture
    targets = {"action": 0.948, "object": 0.96, "speed": 3.4}
    cmp = compare([big, mid, tiny], targets=targets)
    assert [p.meets_targets for p in cmp.points] == [True, True, False]
    assert cmp.needed.label == "lstm/mid"  # MAE exactly at the target meets it
    assert cmp.fastest.label == "lstm/mid"
    assert "the smallest meeting action >= 94.8 %, object >= 96 %, speed MAE <= 3.4" \
        in cmp.summary()
    # the margin rule looks at the primary score only
    assert compare([big, mid, tiny], margin_pp=1.0).needed.label == "mlp/tiny"

    none = compare([mid, tiny], targets={"action": 0.99})
    assert none.needed is None and none.fastest is None
    assert none.summary().startswith("no run meets every target (action >= 99 %)")
    files = write_comparison(none, tmp_path / "none")
    assert json.loads(files.json.read_text())["needed"] is None

    with pytest.raises(InputError, match="run cnn2d/big has no head 'grip'"):
        compare([big, mid], targets={"grip": 0.5})
    with pytest.raises(InputError, match="an accuracy target is a fraction"):
        compare([big, mid], targets={"object": 96})


def test_cli_compare_targets(tmp_path):
    a = fake_run(tmp_path, "a", "cnn2d", accuracy=0.97, latency_ms=0.5, n_params=90_000)
    b = fake_run(tmp_path, "b", "mlp", accuracy=0.96, latency_ms=0.1, n_params=900)
    res = runner.invoke(app, ["compare", str(a), str(b), "--target", "action=0.965"])
    assert res.exit_code == 0, res.output
    assert "the model this scene needs: cnn2d/a" in " ".join(res.output.split())
    for bad in ("action", "action=x", "=0.5"):
        res = runner.invoke(app, ["compare", str(a), str(b), "--target", bad])
        assert res.exit_code == 2 and "give HEAD=VALUE" in res.output, res.output
