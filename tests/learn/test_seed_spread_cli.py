"""`tactile seed-spread`: one config trained and evaluated at several seeds, each seed a run
folder whose figures are that seed's alone, the summary their spread, a stopped spread
resumed, another spread in the folder refused (:mod:`tactile_cli.learn.seed_spread`)."""

from __future__ import annotations

import json

import pytest
from typer.testing import CliRunner

from tactile_cli.cli import app
from tactile_cli.errors import InputError
from tactile_cli.learn.seed_spread import parse_seeds, partial_dir, seed_spread

from .conftest import tiny_config

runner = CliRunner()


def _config(tmp_path, **split):
    path = tmp_path / "tiny.yaml"
    path.write_text(tiny_config(data={"split": {"val_fraction": 0.0, **split}},
                                optim={"epochs": 2}).as_yaml())
    return path


def _spread(*args, workers=0):
    return runner.invoke(app, ["seed-spread", *map(str, args), "--workers", str(workers)])


@pytest.fixture(scope="module")
def grouped_spread(action_file, tmp_path_factory):
    root = tmp_path_factory.mktemp("seed_spread")
    config = _config(root, mode="group", by="force_level")
    out = root / "spread"
    res = _spread(config, "--data", action_file, "--cv", "2", "--seeds", "0,2", "--out", out,
                  "--json")
    assert res.exit_code == 0, res.output
    return config, out, json.loads(res.stdout)


@pytest.mark.slow
def test_each_seed_is_the_run_that_train_and_evaluate_make(grouped_spread, action_file,
                                                           tmp_path):
    config, out, record = grouped_spread
    assert [r["seed"] for r in record["by_seed"]] == [0, 2]
    assert record["split_depends_on_seed"] is False and record["notes"] == [
        "2 seed(s): too few for an SD to mean much; give 5 or more"]
    # seed 2 by hand: the same figures
    run = tmp_path / "by_hand"
    assert runner.invoke(app, ["train", str(config), "--data", str(action_file), "--cv", "2",
                               "--seed", "2", "--out", str(run)]).exit_code == 0
    res = runner.invoke(app, ["evaluate", str(run), "--no-latency", "--json"])
    assert res.exit_code == 0, res.output
    by_hand = json.loads(res.stdout)
    head = by_hand["heads"][by_hand["primary_head"]]
    row = record["by_seed"][1]
    assert row["window_accuracy"] == head["accuracy"]
    assert row["window_macro_f1"] == head["macro_f1"]
    assert row["n_windows"] == by_hand["n_windows"] and row["n_trials"] == by_hand["n_trials"]
    acc = [r["window_accuracy"] for r in record["by_seed"]]
    summary = record["summary"]["window_accuracy"]
    assert (summary["min"], summary["max"]) == (min(acc), max(acc))
    assert summary["mean"] == pytest.approx(sum(acc) / 2)
    assert summary["spread"] == pytest.approx(max(acc) - min(acc))
    # provenance and the written outputs
    assert record["config_sha256"] and record["data"][0]["sha256"] and record["command"]
    assert record["tool_version"] and record["cv"] == 2
    assert json.loads((out / "seed_spread.json").read_text())["by_seed"] == record["by_seed"]
    assert "| spread |" in (out / "seed_spread.md").read_text()
    assert (out / "seed_spread.png").read_bytes()[:4] == b"\x89PNG"
    assert (out / "seed_0" / "run.json").is_file()
    for row in record["by_seed"]:  # each seed's evaluation names where its run is now
        metrics = json.loads((out / f"seed_{row['seed']}" / "eval" / "seed_spread" /
                              "metrics.json").read_text())
        assert metrics["run"] == row["run"] == str(out / f"seed_{row['seed']}")


@pytest.mark.slow
def test_a_finished_spread_is_kept_and_a_stopped_one_resumes(grouped_spread, action_file,
                                                             tmp_path):
    config, out, record = grouped_spread
    res = _spread(config, "--data", action_file, "--cv", "2", "--seeds", "0,2", "--out", out)
    assert res.exit_code == 2
    assert res.output.strip().endswith("output folder exists and is not empty; pass "
                                       "--overwrite to replace it")
    # stopped after its first seed: the runs wait beside the output, which is not made
    again = tmp_path / "again"

    def stop(row):
        raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        seed_spread(config, [action_file], out=again, seeds=[0, 2], cv=2, workers=0,
                    on_seed=stop)
    assert not again.exists() and (partial_dir(again) / "seed_0" / "run.json").is_file()
    # another config is refused there, the same one resumes
    other = tmp_path / "other.yaml"
    other.write_text(config.read_text().replace("hidden: 16", "hidden: 8"))
    res = _spread(other, "--data", action_file, "--cv", "2", "--seeds", "0,2", "--out", again)
    assert res.exit_code == 2
    assert "holds a stopped seed spread of another config, data or settings; pass " \
           "--overwrite to discard it" in res.output
    resumed = seed_spread(config, [action_file], out=again, seeds=[0, 2], cv=2, workers=0)
    assert [r.resumed for r in resumed.rows] == [True, False]
    assert [r.metrics["window_accuracy"] for r in resumed.rows] == [
        r["window_accuracy"] for r in record["by_seed"]]
    assert not partial_dir(again).exists()
    assert json.loads((again / "seed_spread.json").read_text())["by_seed"][0]["run"] == str(
        again / "seed_0")
    assert not (again / ".seed_spread_plan.json").exists()
    # --overwrite replaces a finished spread, and only once the new one is done
    res = _spread(config, "--data", action_file, "--cv", "2", "--seeds", "1", "--out", again,
                  "--overwrite", "--json", "--no-plot")
    assert res.exit_code == 0, res.output
    assert sorted(p.name for p in again.iterdir()) == ["seed_1", "seed_spread.json",
                                                       "seed_spread.md"]


@pytest.mark.slow
def test_without_cv_each_seed_is_scored_on_the_eval_data(action_file, heldout_file, tmp_path):
    config = _config(tmp_path, mode="random")
    res = _spread(config, "--data", action_file, "--eval-data", heldout_file, "--seeds", "1",
                  "--out", tmp_path / "s", "--json", "--no-plot")
    assert res.exit_code == 0, res.output
    record = json.loads(res.stdout)
    assert record["cv"] is None and record["eval_data"][0]["path"] == str(heldout_file)
    assert record["by_seed"][0]["n_trials"] > 0
    assert not (tmp_path / "s" / "seed_spread.png").exists()
    res = _spread(config, "--data", action_file, "--eval-data", heldout_file, "--cv", "2",
                  "--out", tmp_path / "t")
    assert res.exit_code == 2 and "--eval-data FILE is for a spread without --cv" in res.output
    assert not (tmp_path / "t").exists()


@pytest.mark.slow
def test_seeds_side_by_side_give_the_same_figures(action_file, tmp_path):
    """Two local worker processes against one after another here: the same bits, and a
    random split, drawn from the seed, named in the notes."""
    config = _config(tmp_path, mode="random")
    records = []
    for workers in (0, 2):
        res = _spread(config, "--data", action_file, "--cv", "2", "--seeds", "0-2", "--out",
                      tmp_path / f"w{workers}", "--json", "--no-plot", workers=workers)
        assert res.exit_code == 0, res.output
        records.append(json.loads(res.stdout))
    assert records[0]["split_depends_on_seed"] is True and records[0]["seeds"] == [0, 1, 2]
    assert any("folds are drawn from the seed too" in n for n in records[0]["notes"])
    keys = ("seed", "window_accuracy", "window_macro_f1", "n_windows", "folds")
    assert [[r[k] for k in keys] for r in records[0]["by_seed"]] == [
        [r[k] for k in keys] for r in records[1]["by_seed"]]
    assert records[0]["summary"] == records[1]["summary"]


@pytest.mark.slow
def test_a_seed_that_fails_is_one_line_and_leaves_no_folder(action_file, tmp_path):
    config = tmp_path / "bad.yaml"
    config.write_text(tiny_config(data={"stream": "nope"}).as_yaml())
    res = _spread(config, "--data", action_file, "--cv", "2", "--seeds", "0,1", "--out",
                  tmp_path / "s")
    assert res.exit_code == 2
    line = res.output.strip().splitlines()[-1]
    assert line.startswith("tactile: error: seed 0: ") and "nope" in line
    assert line.endswith("(1 more seed(s) failed)")
    assert not (tmp_path / "s").exists()


@pytest.mark.parametrize("text, seeds", [("0-2,7", [0, 1, 2, 7]), ("5", [5]),
                                         (" 1, 3 ", [1, 3]), ([4, 2], [4, 2])])
def test_seeds_are_parsed(text, seeds):
    assert parse_seeds(text) == seeds


@pytest.mark.parametrize("text, message", [
    ("1,1", "`seeds` gives seed 1 twice"), ("0-2,2", "`seeds` gives seed 2 twice"),
    ("3-1", "`seeds` must be integers >= 0 such as 0,1,2 or 0-4, got '3-1'"),
    ("a", "`seeds` must be integers >= 0 such as 0,1,2 or 0-4, got 'a'"),
    ("0-100", "`seeds` names 101 seeds; at most 100"), ([-1], "`seeds` must be >= 0, got -1")])
def test_bad_seeds_are_one_line(text, message):
    with pytest.raises(InputError) as err:
        parse_seeds(text)
    assert str(err.value) == message


@pytest.mark.slow
def test_compare_takes_a_spread_as_one_run_at_its_seeds_mean(grouped_spread, action_file,
                                                           tmp_path):
    config, out, record = grouped_spread
    other = tmp_path / "small.yaml"
    other.write_text(config.read_text().replace("hidden: 16", "hidden: 4"))
    res = _spread(other, "--data", action_file, "--cv", "2", "--seeds", "0,2", "--out",
                  tmp_path / "small", "--no-plot")
    assert res.exit_code == 0, res.output
    res = runner.invoke(app, ["compare", str(out), str(tmp_path / "small"), "--json",
                              "--margin", "0"])
    assert res.exit_code == 0, res.output
    cmp = json.loads(res.stdout)
    point = next(r for r in cmp["runs"] if r["run"] == str(out))
    acc = [r["window_accuracy"] for r in record["by_seed"]]
    assert point["score"] == pytest.approx(sum(acc) / 2)
    assert point["seeds"]["n"] == 2 and point["seeds"]["scores"] == acc
    assert point["seeds"]["sd"] == pytest.approx(abs(acc[0] - acc[1]) / 2 ** 0.5)
    assert point["score_ci95"] is None
    # the cost is the first seed's, timed once the spread was done
    metrics = json.loads((out / "seed_0" / "eval" / "seed_spread" / "metrics.json").read_text())
    assert point["latency_ms"] == metrics["latency"]["batch1_ms_median"] > 0
    sd_pp = 100 * max(r["seeds"]["sd"] for r in cmp["runs"])
    best = max(r["score"] for r in cmp["runs"])
    near_edge = [r["label"] for r in cmp["runs"] if r["score"] != best
                 and 100 * (best - r["score"]) < sd_pp]  # margin 0: the edge is the best
    noted = [n for n in cmp["notes"] if "of the margin's edge" in n]
    assert bool(noted) == bool(near_edge)
    if noted:
        assert noted[0].startswith(", ".join(near_edge) + ": within one seed SD")


@pytest.mark.slow
def test_compare_refuses_a_spread_missing_a_seed(grouped_spread, tmp_path):
    _, out, _ = grouped_spread
    broken = tmp_path / "broken"
    broken.mkdir()
    (broken / "seed_spread.json").write_text((out / "seed_spread.json").read_text())
    res = runner.invoke(app, ["compare", str(out), str(broken)])
    assert res.exit_code == 2
    assert res.output.strip() == (f"tactile: error: {broken / 'seed_0'}: run folder not found "
                                  "(give the folder `tactile train` wrote)")


@pytest.mark.slow
def test_report_shows_a_spread_and_its_seed_runs(grouped_spread, tmp_path):
    _, out, record = grouped_spread
    res = runner.invoke(app, ["report", str(out), "--out", str(tmp_path / "rep")])
    assert res.exit_code == 0, res.output
    page = (tmp_path / "rep" / "index.html").read_text()
    assert "Seed spreads: how much of a figure is the seed" in page
    first = record["by_seed"][0]["window_accuracy"]
    assert f"{100 * first:.2f}" in page
    prov = json.loads((tmp_path / "rep" / "report.json").read_text())
    assert prov["seed_spreads"] == [str(out)]
    assert prov["runs"] == [str(out / "seed_0"), str(out / "seed_2")]
    assert any(i["role"] == "seed spread" for i in prov["inputs"])


@pytest.mark.parametrize("mode, cv, depends", [("random", 2, True), ("random", "loto", False),
                                               ("stratified", None, False),
                                               ("group", 2, False)])
def test_whether_the_folds_depend_on_the_seed(action_file, tmp_path, mode, cv, depends):
    from tactile_cli.learn.seed_spread import _plan

    split = {"mode": mode, "by": "force_level"} if mode in ("group", "stratified") else {
        "mode": mode}
    config = _config(tmp_path, **split)
    plan = _plan(config, [action_file], [], cv, None, None, [0], "test")
    assert plan["split_depends_on_seed"] is depends


@pytest.mark.slow
def test_compare_puts_a_spread_beside_a_plain_run_of_the_same_data(grouped_spread,
                                                                   action_file, tmp_path):
    config, out, record = grouped_spread
    run = tmp_path / "plain"
    assert runner.invoke(app, ["train", str(config), "--data", str(action_file), "--cv", "2",
                               "--seed", "2", "--out", str(run)]).exit_code == 0
    assert runner.invoke(app, ["evaluate", str(run), "--no-latency"]).exit_code == 0
    res = runner.invoke(app, ["compare", str(out), str(run), "--json"])
    assert res.exit_code == 0, res.output
    cmp = json.loads(res.stdout)
    plain = next(r for r in cmp["runs"] if r["run"] == str(run))
    assert plain["seeds"] is None and plain["eval_name"] != "seed_spread"
    assert plain["score"] == record["by_seed"][1]["window_accuracy"]  # seed 2 alone
    # report: the spread is one point beside the run, never its seeds against each other
    res = runner.invoke(app, ["report", str(out), str(run), "--out", str(tmp_path / "rep")])
    assert res.exit_code == 0, res.output
    prov = json.loads((tmp_path / "rep" / "report.json").read_text())
    assert prov["compared"] == [f"{plain['eval_name']} and the spreads' own"]
    page = (tmp_path / "rep" / "index.html").read_text()
    assert "2 runs evaluated on" in page and f"{100 * cmp['runs'][0]['score']:.2f}" in page
    res = runner.invoke(app, ["report", str(out), "--out", str(tmp_path / "rep1")])
    assert json.loads((tmp_path / "rep1" / "report.json").read_text())["compared"] == []


def test_each_seeds_evaluation_warnings_reach_the_spread(tmp_path):
    """Nothing dropped: a seed's notes, warnings and interleaving message are its row's
    warnings, and the spread names which seeds gave each."""
    from tactile_cli.learn.seed_spread import seed_row, shared_warnings

    inter = {"order_by": "time_origin_unix_s", "n_evaluated": 20, "n_inside_span": 4,
             "class_label": None, "n_inside_class_span": None, "interleaved": True,
             "reason": None}
    metrics = {"primary_head": "slip", "heads": {"slip": {"accuracy": 0.75, "macro_f1": 0.7}},
               "n_windows": 80, "n_trials": 20, "notes": ["a note"],
               "warnings": ["slip: class(es) x have no support"], "interleaving": inter}
    rows = [seed_row(0, tmp_path / "seed_0", metrics, 1.0, False),
            seed_row(1, tmp_path / "seed_1", {**metrics, "notes": [], "interleaving": None}, 1.0,
                 False)]
    assert rows[0].warnings[:2] == ["a note", "slip: class(es) x have no support"]
    assert rows[0].warnings[2].startswith("4 of 20 evaluated trial(s) lie inside the "
                                          "recording span (by time_origin_unix_s)")
    shared = shared_warnings(rows)
    assert shared["slip: class(es) x have no support"] == [0, 1]
    assert shared["a note"] == [0]


@pytest.mark.slow
def test_info_summarises_a_spread(grouped_spread, tmp_path):
    config, out, record = grouped_spread
    res = runner.invoke(app, ["info", str(out)])
    assert res.exit_code == 0, res.output
    lines = res.stdout.splitlines()
    assert lines[0] == (f"{out}: seed spread of {config}, seeds 0, 2, 2-fold cross-validation "
                        "(group split)")
    s = record["summary"]["window_accuracy"]
    assert (f"window accuracy: mean {100 * s['mean']:.1f} %, SD {100 * s['sd']:.2f} pp, "
            f"{100 * s['min']:.1f}-{100 * s['max']:.1f} %") in lines
    broken = tmp_path / "broken"
    broken.mkdir()
    (broken / "seed_spread.json").write_text("{not json")
    res = runner.invoke(app, ["info", str(broken)])
    assert res.exit_code == 2
    assert res.output.strip() == (f"tactile: error: {broken / 'seed_spread.json'}: not a "
                                  "readable seed-spread record (JSONDecodeError); re-create it "
                                  "with `tactile seed-spread`")


@pytest.mark.slow
def test_a_damaged_evaluation_in_a_stopped_spread_is_one_line(grouped_spread, action_file,
                                                              tmp_path):
    config, _, _ = grouped_spread
    out = tmp_path / "s"

    def stop(row):
        raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        seed_spread(config, [action_file], out=out, seeds=[0, 2], cv=2, workers=0,
                    on_seed=stop)
    metrics = partial_dir(out) / "seed_0" / "eval" / "seed_spread" / "metrics.json"
    metrics.write_text(metrics.read_text()[:50])
    res = _spread(config, "--data", action_file, "--cv", "2", "--seeds", "0,2", "--out", out)
    assert res.exit_code == 2
    assert res.output.strip().splitlines()[-1] == (
        f"tactile: error: seed 0: {metrics}: not a readable evaluation record; delete the "
        "seed's folder and run the spread again")
