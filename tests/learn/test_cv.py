"""Cross-validation runs, pooled evaluation, per-trial votes and honest metrics (issue 11)."""

from __future__ import annotations

import json

import numpy as np
import pytest
import torch
from typer.testing import CliRunner

from tactile_cli.cli import app
from tactile_cli.errors import InputError
from tactile_cli.learn import cv as cvmod
from tactile_cli.learn.cv import partial_dir, train_cv
from tactile_cli.learn.data import expand_channels, resolve_channels
from tactile_cli.learn.evaluate import classification_metrics, evaluate
from tactile_cli.learn.trial_metrics import (
    bootstrap_window_intervals,
    per_trial_confusion,
    trial_votes,
)

from .conftest import tiny_config

runner = CliRunner()


def _cv_config(**data):
    return tiny_config(
        data={"targets": [{"name": "action"},
                          {"name": "force_grade", "source": "trial", "weight": 0.5}],
              "split": {"mode": "stratified", "by": "force_grade", "val_fraction": 0.0},
              **data},
        optim={"epochs": 1})


@pytest.fixture(scope="module")
def cv_run(tmp_path_factory, action_file):
    out = tmp_path_factory.mktemp("cv") / "run"
    res = train_cv(_cv_config(), [action_file], out, k=3, jobs=1)
    return out, res


@pytest.mark.slow
def test_cv_run_folder_holds_one_complete_run_per_fold(cv_run):
    out, res = cv_run
    info = json.loads((out / "run.json").read_text())
    assert res.n_folds == 3 and res.trained == [0, 1, 2] and res.resumed == []
    assert info["cv"]["mode"] == "stratified" and info["cv"]["by"] == "force_grade"
    held = [k for f in info["cv"]["folds"] for k in f["test"]]
    assert len(held) == len(set(held)) == 24  # every trial held out exactly once
    for i in range(3):
        fold = out / "folds" / f"fold_{i:02d}"
        assert (fold / "model.pt").is_file() and (fold / "run.json").is_file()
        rows = (fold / "split.csv").read_text().splitlines()[1:]
        test = {f"synth.h5/{r.split(',')[1]}" for r in rows if r.endswith(",test")}
        assert test == set(info["cv"]["folds"][i]["test"])
    assert not partial_dir(out).exists()


def test_cv_evaluation_pools_the_held_out_windows_of_every_fold(cv_run):
    out, _ = cv_run
    res = evaluate(out, None, latency=False)
    d = res.as_dict()
    action = d["heads"]["action"]
    folds = d["cv"]["folds"]
    assert d["split"] == "cv" and d["cv"]["n_folds"] == 3 and d["n_trials"] == 24
    assert sum(f["n_windows"] for f in folds) == d["n_windows"] == action["n"]
    assert sum(map(sum, action["confusion_matrix"])) == d["n_windows"]
    pooled = sum(f["accuracy"] * f["n_windows"] for f in folds) / d["n_windows"]
    assert action["accuracy"] == pytest.approx(pooled, rel=1e-12)
    accs = [f["accuracy"] for f in folds]
    assert d["cv"]["accuracy_mean"] == pytest.approx(np.mean(accs))
    assert d["cv"]["accuracy_std"] == pytest.approx(np.std(accs, ddof=1))
    grade = d["heads"]["force_grade"]
    assert grade["per_trial"]["n_trials"] == 24
    assert sum(map(sum, grade["per_trial"]["confusion_matrix"])) == 24
    lo, hi = action["accuracy_ci95"]
    assert lo <= action["accuracy"] <= hi
    with pytest.raises(InputError, match="evaluation folder exists"):
        evaluate(out, None, latency=False)
    with pytest.raises(InputError, match="cross-validated on"):
        evaluate(out, [out / "folds" / "fold_00" / "run.json"], latency=False, overwrite=True)


@pytest.mark.slow
def test_a_stopped_cv_run_resumes_and_gives_the_same_models(tmp_path, action_file, cv_run):
    full, _ = cv_run
    out = tmp_path / "run"
    calls = []

    def stop_after_first(index, summary):
        calls.append(index)
        raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        train_cv(_cv_config(), [action_file], out, k=3, jobs=1, on_fold=stop_after_first)
    assert not out.exists() and (partial_dir(out) / "folds" / "fold_00" / "model.pt").is_file()
    res = train_cv(_cv_config(), [action_file], out, k=3, jobs=1)
    assert res.resumed == [0] and res.trained == [1, 2]
    for i in range(3):
        a = torch.load(full / "folds" / f"fold_{i:02d}" / "model.pt", weights_only=True)
        b = torch.load(out / "folds" / f"fold_{i:02d}" / "model.pt", weights_only=True)
        assert all(torch.equal(a[k], b[k]) for k in a)
    # a stopped run of another config is not resumed silently
    with pytest.raises(KeyboardInterrupt):
        train_cv(_cv_config(), [action_file], tmp_path / "other", k=3, jobs=1,
                 on_fold=stop_after_first)
    with pytest.raises(InputError, match="a stopped cross-validation of another config"):
        train_cv(_cv_config(window=10), [action_file], tmp_path / "other", k=3, jobs=1)


@pytest.mark.slow
def test_folds_in_parallel_processes_match_the_serial_ones(tmp_path, action_file, cv_run):
    full, _ = cv_run
    res = train_cv(_cv_config(), [action_file], tmp_path / "par", k=3, jobs=2)
    assert res.jobs == 2
    for i in range(3):
        a = torch.load(full / "folds" / f"fold_{i:02d}" / "model.pt", weights_only=True)
        b = torch.load(tmp_path / "par" / "folds" / f"fold_{i:02d}" / "model.pt",
                       weights_only=True)
        assert all(torch.equal(a[k], b[k]) for k in a)


@pytest.mark.slow
def test_cli_cv_and_split_from(tmp_path, action_file):
    cfg = tmp_path / "cfg.yaml"
    cfg.write_text(_cv_config().as_yaml())
    r = runner.invoke(app, ["train", str(cfg), "--data", str(action_file), "--cv", "2",
                            "--jobs", "1", "--out", str(tmp_path / "r")])
    assert r.exit_code == 0, r.output
    assert "2 folds (stratified by force_grade)" in r.stderr
    r = runner.invoke(app, ["evaluate", str(tmp_path / "r"), "--no-latency", "--json"])
    assert r.exit_code == 0, r.output
    assert json.loads(r.stdout)["cv"]["n_folds"] == 2
    r = runner.invoke(app, ["train", str(cfg), "--data", str(action_file), "--cv", "one",
                            "--out", str(tmp_path / "r2")])
    assert r.exit_code == 2 and "--cv must be an integer >= 2 or loto" in r.stderr
    split = tmp_path / "split.csv"
    split.write_text("trial,split\n" + "".join(
        f"synth_{i:04d},{'test' if i < 3 else 'val' if i < 6 else 'train'}\n"
        for i in range(24)))
    r = runner.invoke(app, ["train", str(cfg), "--data", str(action_file), "--split-from",
                            str(split), "--out", str(tmp_path / "s")])
    assert r.exit_code == 0, r.output
    run = json.loads((tmp_path / "s" / "run.json").read_text())
    assert run["split"]["mode"] == "csv" and run["split"]["source"] == str(split)
    assert run["split"]["trials"] == {"train": 18, "val": 3, "test": 3}
    split.write_text("trial,split\nsynth_0000,test\n")
    r = runner.invoke(app, ["train", str(cfg), "--data", str(action_file), "--split-from",
                            str(split), "--out", str(tmp_path / "s2")])
    assert r.exit_code == 2 and "trial synth.h5/synth_0001 has no split" in r.stderr
    assert r.stderr.count("\n") == 1 and not (tmp_path / "s2").exists()


def test_zero_support_and_single_class_are_flagged_not_hidden():
    m = classification_metrics(np.array([0, 0, 0, 0]), np.array([0, 0, 1, 0]),
                               ["no_slip", "slip"], head="slip")
    assert m.per_class[1].absent and m.per_class[1].support == 0
    assert m.macro_f1 == pytest.approx(m.per_class[0].f1)  # the absent class is left out
    assert any("slip have no support" in w for w in m.warnings)
    assert any("only class no_slip is present" in w for w in m.warnings)
    both = classification_metrics(np.array([0, 1]), np.array([0, 1]), ["a", "b"])
    assert both.warnings == []


def test_per_trial_votes_and_bootstrap_intervals():
    # trial 0: true 1, windows vote 1,1,0 -> 1; trial 1: true 0, votes 1,1,0 -> 1 (wrong);
    # by mean probability trial 1's single confident 0 wins
    logits = np.array([[0, 2], [0, 2], [1, 0], [0, 0.1], [0, 0.1], [9, 0]], dtype=np.float64)
    y = np.array([1, 1, 1, 0, 0, 0])
    tid = np.array([0, 0, 0, 1, 1, 1])
    v = trial_votes(y, logits, tid)
    assert v.n_trials == 2 and v.majority_accuracy == 0.5
    assert v.mean_probability_accuracy == 1.0
    assert v.confusion_matrix == [[0, 1], [0, 1]]
    cms = per_trial_confusion(y, logits.argmax(axis=1), tid, 2, 2)
    assert cms.sum() == 6 and cms[1].tolist() == [[1, 2], [0, 0]]
    same = np.repeat(cms[:1], 10, axis=0)  # ten identical trials: no spread
    ci = bootstrap_window_intervals(same)
    assert ci["accuracy_ci95"] == [pytest.approx(2 / 3)] * 2
    assert bootstrap_window_intervals(cms[:1])["accuracy_ci95"] is None


def test_trials_of_one_group_are_decided_together():
    from tactile_cli.learn.data import WindowSet
    from tactile_cli.learn.heads import HeadSpec
    from tactile_cli.learn.metrics import head_metrics

    # two cameras (trials) per experiment; experiment A slipped (1), B held (0). Camera 0 of
    # A sees nothing (two weak 0 windows), camera 2 of A sees the slip clearly: per trial
    # camera 0 of A is wrong, per experiment the mean probability over both is right.
    logits = np.array([[0.2, 0], [0.2, 0], [0, 5], [0, 5], [3, 0], [3, 0], [2, 0], [0, 1]])
    y = np.array([1, 1, 1, 1, 0, 0, 0, 0])
    tid = np.array([0, 0, 1, 1, 2, 2, 3, 3])
    n = len(y)
    ws = WindowSet(np.zeros((0, 1), np.float32), np.zeros(n, np.int64), 1, {"slipped": y},
                   tid, np.zeros(n, np.int64), np.zeros(n, np.int64), np.zeros(n), {},
                   ["A_c0", "A_c2", "B_c0", "B_c2"])
    heads = [HeadSpec("slipped", "classification", "trial", 1.0, ("0", "1"))]
    (m,), _ = head_metrics(heads, {"slipped": logits}, ws, {}, 1,
                           ("experiment", ["A", "A", "B", "B"]))
    assert m.per_trial["n_trials"] == 4 and m.per_trial["mean_probability_accuracy"] == 0.75
    g = m.per_group
    assert g["by"] == "experiment" and g["n_trials"] == 2
    assert g["mean_probability_accuracy"] == 1.0
    # the majority vote of A is a 2-2 tie, which goes to the lower class (0): wrong
    assert g["majority_accuracy"] == 0.5 and g["confusion_matrix"] == [[1, 0], [1, 0]]
    (plain,), _ = head_metrics(heads, {"slipped": logits}, ws, {}, 1)
    assert plain.per_group is None


@pytest.mark.slow
def test_boundary_metric_only_for_labels_that_change_inside_a_trial(tmp_path, action_file):
    from tactile_cli.learn.train import train

    cfg = tiny_config(optim={"epochs": 1})
    out = tmp_path / "run"
    train(cfg, [action_file], out)
    d = evaluate(out, [action_file], latency=False).as_dict()
    assert d["heads"]["action"]["accuracy_excluding_boundaries"] is not None  # time series
    snap = tiny_config(data={"targets": [{"name": "force_grade", "source": "trial"}]},
                       optim={"epochs": 1})
    train(snap, [action_file], tmp_path / "snap")
    d = evaluate(tmp_path / "snap", [action_file], latency=False).as_dict()
    assert d["heads"]["force_grade"]["accuracy_excluding_boundaries"] is None


def test_channel_patterns_expand_in_the_sensor_s_order(action_file):
    names = ["txl1_x", "txl1_z", "txl2_x", "txl10_x", "pdc"]
    assert expand_channels(["txl*_x", "pdc"], names, path="f", where="w") == \
        ["txl1_x", "txl2_x", "txl10_x", "pdc"]
    with pytest.raises(InputError, match="channel 'ele\\*' matches no channel"):
        expand_channels(["ele*"], names, path="f", where="w")
    data = resolve_channels(tiny_config(data={"channels": ["n*"]}).data, [action_file])
    assert data.channels == ["net"]


def test_load_run_of_a_cv_parent_says_to_give_a_fold(cv_run):
    from tactile_cli.learn.runs import load_run

    with pytest.raises(InputError, match="give a fold's folder"):
        load_run(cv_run[0])
    assert cvmod.parse_cv("LOTO") == "loto" and cvmod.parse_cv("5") == 5


def test_the_closing_line_names_leave_one_trial_out(tmp_path):
    """`train --cv loto` ended with "7 folds (random)": the fold rule is named as the plan
    line names it."""
    from tactile_cli.learn.cv import CvTrainResult
    from tactile_cli.learn.pipeline import train_summary

    def line(k, mode, by):
        return train_summary(CvTrainResult(
            run_dir=tmp_path, family="fnn", k=k, n_folds=7, mode=mode, by=by, resumed=[],
            trained=list(range(7)), jobs=1, wall_time_s=1.0, warnings=[], folds=[]))

    assert line("loto", "random", None).startswith(f"wrote {tmp_path}: fnn, 7 folds (leave "
                                                   "one trial out), 7 trained")
    assert ", 7 folds (stratified by material), " in line(7, "stratified", "material")
