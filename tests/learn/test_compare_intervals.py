"""`tactile compare` draws the 95 % intervals a cross-validated evaluation records."""

from __future__ import annotations

import json

import matplotlib.axes

from tactile_cli.learn.compare import compare, plot_comparison

from .test_compare import PNG, fake_run


def _add_intervals(run, window_ci, trial_ci):
    path = run / "eval" / "scene" / "metrics.json"
    m = json.loads(path.read_text())
    head = m["heads"]["action"]
    head["accuracy_ci95"] = window_ci
    head["per_trial"] = {"n_trials": 200, "majority_accuracy": 0.9,
                         "majority_accuracy_ci95": trial_ci}
    path.write_text(json.dumps(m))


def test_compare_reads_intervals_and_draws_them_as_error_bars(tmp_path, monkeypatch):
    a = fake_run(tmp_path, "a", "mlp", accuracy=0.74, latency_ms=0.1, n_params=10)
    b = fake_run(tmp_path, "b", "fnn", accuracy=0.71, latency_ms=0.2, n_params=20)
    _add_intervals(a, [0.70, 0.78], [0.85, 0.95])
    _add_intervals(b, [0.65, 0.76], None)  # an interval the evaluation could not give

    cmp = compare([a, b])
    assert [p.score_ci95 for p in cmp.points] == [[0.70, 0.78], [0.65, 0.76]]
    by_trial = compare([a, b], metric="trial_accuracy")
    assert [p.score_ci95 for p in by_trial.points] == [[0.85, 0.95], None]
    assert compare([a, b], metric="f1:slip").points[0].score_ci95 is None
    assert cmp.as_dict()["runs"][0]["score_ci95"] == [0.70, 0.78]

    drawn = []
    original = matplotlib.axes.Axes.errorbar

    def spy(self, x, y, *args, **kwargs):
        drawn.append((list(x), list(y), kwargs.get("yerr")))
        return original(self, x, y, *args, **kwargs)

    monkeypatch.setattr(matplotlib.axes.Axes, "errorbar", spy)
    assert plot_comparison(cmp).startswith(PNG)
    assert len(drawn) == 2
    (x, y, yerr) = next(d for d in drawn if d[0] == [0.1])  # run a
    assert x == [0.1] and abs(y[0] - 74.0) < 1e-9
    assert abs(yerr[0][0] - 4.0) < 1e-9 and abs(yerr[1][0] - 4.0) < 1e-9
    drawn.clear()
    assert plot_comparison(by_trial).startswith(PNG)
    assert len(drawn) == 1  # run b has no per-trial interval: no bar


def test_compare_without_intervals_draws_no_error_bars(tmp_path, monkeypatch):
    a = fake_run(tmp_path, "a", "mlp", accuracy=0.74, latency_ms=0.1, n_params=10)
    b = fake_run(tmp_path, "b", "fnn", accuracy=0.71, latency_ms=0.2, n_params=20)
    cmp = compare([a, b])
    assert all(p.score_ci95 is None for p in cmp.points)
    calls = []
    monkeypatch.setattr(matplotlib.axes.Axes, "errorbar",
                        lambda self, *a, **k: calls.append(1))
    assert plot_comparison(cmp).startswith(PNG)
    assert calls == []
