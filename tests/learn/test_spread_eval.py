"""`tactile evaluate SPREAD --data FILE`: every seed's model of a seed spread scored on
recordings the spread never saw, each seed's figures the ones `tactile evaluate` gives, the
seeds' spread beside the spread's own figures (:mod:`tactile_cli.learn.spread_eval`)."""

from __future__ import annotations

import json

import pytest
from typer.testing import CliRunner

from tactile_cli.cli import app

from ..factories.action_files import make_action_file
from .conftest import tiny_config

runner = CliRunner()


@pytest.fixture(scope="module")
def spread(action_file, heldout_file, tmp_path_factory):
    """A 2-seed spread without cv (scored on ``heldout_file``) and a later session."""
    root = tmp_path_factory.mktemp("spread_eval")
    config = root / "tiny.yaml"
    config.write_text(tiny_config(data={"split": {"val_fraction": 0.0, "test_fraction": 0.0}},
                                  optim={"epochs": 2}).as_yaml())
    out = root / "spread"
    res = runner.invoke(app, ["seed-spread", str(config), "--data", str(action_file),
                              "--eval-data", str(heldout_file), "--seeds", "0,1", "--out",
                              str(out), "--workers", "0", "--no-plot"])
    assert res.exit_code == 0, res.output
    later = make_action_file(root / "later.h5", n_trials=8, seed=11)
    return config, out, later


@pytest.mark.slow
def test_each_seed_is_scored_as_evaluate_scores_it(spread, tmp_path):
    config, out, later = spread
    res = runner.invoke(app, ["evaluate", str(out), "--data", str(later), "--json"])
    assert res.exit_code == 0, res.output
    record = json.loads(res.stdout)
    assert record["format"] == "tactile-seed-spread-eval" and record["name"] == "later"
    assert record["seeds"] == [0, 1] and record["data"][0]["path"] == str(later)
    assert record["spread_sha256"] and record["command"] and record["tool_version"]
    for row in record["by_seed"]:  # the figures of `tactile evaluate SEED_RUN --data later`
        metrics = json.loads((out / f"seed_{row['seed']}" / "eval" / "later" /
                              "metrics.json").read_text())
        head = metrics["heads"][metrics["primary_head"]]
        assert row["window_accuracy"] == head["accuracy"]
        assert row["n_trials"] == metrics["n_trials"] == 8
    first, second = (json.loads((out / f"seed_{s}" / "eval" / "later" / "metrics.json")
                                .read_text()) for s in (0, 1))
    assert first["latency"] and not second["latency"]  # the first seed's model is timed
    acc = [r["window_accuracy"] for r in record["by_seed"]]
    assert record["summary"]["window_accuracy"]["mean"] == pytest.approx(sum(acc) / 2)
    own = json.loads((out / "seed_spread.json").read_text())["summary"]
    assert record["spread_summary"] == own
    line = record["against_own"][0]
    assert line.startswith(f"window accuracy: {100 * own['window_accuracy']['mean']:.1f} % "
                           "on the spread's own evaluation, ")
    written = out / "eval" / "later"
    assert sorted(p.name for p in written.iterdir()) == ["spread_eval.json", "spread_eval.md",
                                                          "spread_eval.png"]
    assert "own evaluation" in (written / "spread_eval.md").read_text()
    assert "own evaluation" in runner.invoke(app, ["info", str(out)]).stdout
    res = runner.invoke(app, ["report", str(out), "--out", str(tmp_path / "report")])
    assert res.exit_code == 0, res.output
    page = (tmp_path / "report" / "index.html").read_text()
    assert f"spread on {later}</h4>" in page and "own evaluation" in page
    # a damaged evaluation record: report refuses it in one line, info names it
    record_path = written / "spread_eval.json"
    kept = record_path.read_bytes()
    record_path.write_text("{}")
    res = runner.invoke(app, ["report", str(out), "--out", str(tmp_path / "report2")])
    assert res.exit_code == 2 and len(res.stderr.strip().splitlines()) == 1
    assert "spread_eval.json: not a seed-spread evaluation" in res.stderr
    assert not (tmp_path / "report2").exists()
    assert "evaluation later: unreadable" in runner.invoke(app, ["info", str(out)]).stdout
    record_path.write_bytes(kept)
    # compare ranks the spread on that evaluation
    res = runner.invoke(app, ["compare", str(out), "--data-name", "later", "--json"])
    assert res.exit_code == 0, res.output
    point = json.loads(res.stdout)["runs"][0]
    assert point["score"] == pytest.approx(sum(acc) / 2) and point["seeds"]["scores"] == acc
    metrics = json.loads((out / "seed_0" / "eval" / "later" / "metrics.json").read_text())
    assert point["latency_ms"] == metrics["latency"]["batch1_ms_median"] > 0


@pytest.mark.slow
def test_again_is_refused_resumed_or_replaced(spread):
    _, out, later = spread
    argv = ["evaluate", str(out), "--data", str(later), "--name", "again", "--no-latency"]
    assert runner.invoke(app, argv).exit_code == 0
    res = runner.invoke(app, argv)
    assert res.exit_code == 2
    assert res.stderr.strip().endswith("again: evaluation folder exists; pass --overwrite to "
                                       "replace it or give another --name")
    # a stopped call (the seeds scored, the summary not written) reads the seeds back
    import shutil

    shutil.rmtree(out / "eval" / "again")
    res = runner.invoke(app, [*argv, "--json"])
    assert res.exit_code == 0, res.output
    assert [r["resumed"] for r in json.loads(res.stdout)["by_seed"]] == [True, True]
    res = runner.invoke(app, [*argv, "--overwrite", "--json"])
    assert [r["resumed"] for r in json.loads(res.stdout)["by_seed"]] == [False, False]


@pytest.mark.parametrize("extra, message", [
    (["--each"], "--each goes with a run folder, not a seed spread"),
    (["--perturb"], "--perturb goes with a run folder, not a seed spread"),
    (["--name", "seed_spread"], "the evaluation name 'seed_spread' is the spread's own"),
    (["--name", "../x"], "--name (='../x') must be a plain folder name"),
])
@pytest.mark.slow
def test_what_a_spread_does_not_take_is_one_line(spread, extra, message):
    _, out, later = spread
    res = runner.invoke(app, ["evaluate", str(out), "--data", str(later), *extra])
    assert res.exit_code == 2 and message in res.stderr
    assert len(res.stderr.strip().splitlines()) == 1


@pytest.mark.slow
def test_a_cross_validated_spread_and_no_data_are_one_line(spread, action_file, tmp_path):
    config, out, _ = spread
    res = runner.invoke(app, ["evaluate", str(out)])
    assert res.exit_code == 2 and "no data files; give --data FILE..." in res.stderr
    cv = tmp_path / "cv"
    assert runner.invoke(app, ["seed-spread", str(config), "--data", str(action_file),
                               "--cv", "2", "--seeds", "0", "--out", str(cv), "--workers",
                               "0", "--no-plot"]).exit_code == 0
    res = runner.invoke(app, ["evaluate", str(cv), "--data", str(action_file)])
    assert res.exit_code == 2 and len(res.stderr.strip().splitlines()) == 1
    assert "a cross-validated spread is scored on its held-out folds" in res.stderr
    assert "without cross-validation, each seed scored on held-out files" in res.stderr


def test_the_later_session_benchmark_splits_recordings_by_number(tmp_path):
    """benchmarks/texture_later_session.py: each session links every file of its recording
    numbers and nothing else, so the three files hold disjoint recordings."""
    from ..conftest import load_benchmark

    bench = load_benchmark("texture_later_session")
    source = tmp_path / "src"
    for m in ("mat1", "mat12"):
        (source / m).mkdir(parents=True)
        for n in range(1, 11):
            for kind in ("bio", "cw", "cv"):
                (source / m / f"{m}_{n}_{kind}.csv").write_text(f"{m} {n} {kind}\n")
    (source / "mat1" / "notes.csv").write_text("not a recording\n")
    seen = set()
    for name, samples in bench.SESSIONS.items():
        dest = tmp_path / name
        assert bench.session_tree(source, dest, samples) == 2 * len(samples)
        files = {p.relative_to(dest).as_posix() for p in dest.rglob("*.csv")}
        assert files == {f"{m}/{m}_{n}_{k}.csv" for m in ("mat1", "mat12") for n in samples
                         for k in ("bio", "cw", "cv")}
        assert not files & seen
        seen |= files
    assert len(seen) == 60


def test_each_figure_is_set_beside_the_spreads_own_and_its_seed_sd():
    from tactile_cli.learn.spread_eval import own_figures_notes

    own = {"window_accuracy": {"mean": 0.627, "sd": 0.018},
           "trial_majority_accuracy": {"mean": 0.96, "sd": 0.022},
           "window_macro_f1": {"sd": 0.01}}  # no mean: nothing to set beside
    here = {"window_accuracy": {"mean": 0.615, "sd": 0.015},
            "trial_majority_accuracy": {"mean": 0.923, "sd": 0.030},
            "window_macro_f1": {"mean": 0.6, "sd": 0.0}}
    assert own_figures_notes(own, here, n_trials=60) == [
        "window accuracy: 62.7 % on the spread's own evaluation, 61.5 % here (-1.2 pp; within "
        "one seed SD, 1.80 pp)",
        "per trial, majority: 96.0 % on the spread's own evaluation, 92.3 % here (-3.7 pp; "
        "larger than one seed SD, 3.00 pp; one of the 60 trials is 1.7 pp)"]
    assert own_figures_notes([1, 2], here) == own_figures_notes({}, here) == []
