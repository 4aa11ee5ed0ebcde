"""`tactile report` says where every number comes from (issue 11, item 5): origin tags on
every result, recorded data first, and the cross-validated evaluation with its intervals,
per-trial results and zero-support classes, from hand-made metrics.json files."""

from __future__ import annotations

import json
import re
import shutil

import numpy as np
import pytest

from tactile_cli.learn.report import build_report
from tactile_cli.store import StoreWriter
from tactile_cli.store.provenance import sha256_of

from .tiny_runs import tiny_runs

RECORDED = {"kind": "recorded", "datasets": ["biotac_slide20"], "labs": ["Gao et al., IROS 2020"],
            "files": [{"path": "biotac_slide20.h5", "kind": "recorded"}]}


@pytest.fixture(scope="module")
def runs(tmp_path_factory, action_file, heldout_file):
    return tiny_runs(tmp_path_factory, action_file, heldout_file)


def _cv_metrics(base: dict) -> dict:
    """``base`` (a real metrics.json) turned into a 5-fold cross-validated evaluation of
    recorded data with intervals, per-trial votes, a zero-support class and warnings."""
    m = json.loads(json.dumps(base))
    m.update(name="biotac", split="cv", overlaps_training=[], origin=RECORDED,
             warnings=["action: class(es) release have no support in the evaluated data: "
                       "their recall and F1 mean nothing and they are left out of the macro "
                       "F1", "fold 3 has no trial of class mat7"])
    m["cv"] = {"k": 5, "n_folds": 5, "mode": "stratified", "by": "material",
               "folds": [{"fold": i, "n_trials": 40, "n_windows": 400 + i,
                          "accuracy": 0.8 + 0.01 * i, "macro_f1": 0.7 + 0.01 * i,
                          "per_trial_accuracy": 0.9} for i in range(5)],
               "accuracy_mean": 0.845, "accuracy_std": 0.032, "macro_f1_mean": 0.72,
               "macro_f1_std": 0.0158, "per_trial_accuracy_mean": 0.9,
               "per_trial_accuracy_std": 0.0}
    head = m["heads"]["action"]
    head.update(accuracy=0.8125, accuracy_ci95=[0.801, 0.892], macro_f1_ci95=[0.6, 0.75],
                per_trial={"n_trials": 200, "majority_accuracy": 0.9,
                           "majority_accuracy_ci95": [0.8, 0.975],
                           "mean_probability_accuracy": 0.915,
                           "mean_probability_accuracy_ci95": [0.85, 0.96]})
    release = head["per_class"][3]
    release.update(support=0, recall=0.0, f1=0.0, absent=True)
    return m


def _copy_with_eval(src, dst, name: str, metrics: dict):
    shutil.copytree(src, dst)
    folder = dst / "eval" / name
    folder.mkdir(parents=True)
    (folder / "metrics.json").write_text(json.dumps(metrics))
    return dst


def _labelled_file(path, labels: dict, *, source=None):
    with StoreWriter(path, command="tests") as w:
        acc = w.add_sensor("acc", kind="accelerometer", sample_rate_hz=50,
                           channel_names=["a"], channel_units=["g"])
        sources = [w.add_source(source)] if source is not None else []
        w.trial("t0", labels=labels, sources=sources).write_signal(
            "acc", sensor=acc, data=np.zeros((8, 1), np.float32), t_s=np.arange(8) / 50)
        w.commit()
    return path


@pytest.mark.slow
def test_recorded_results_come_first_with_their_tags_and_cv(runs, tmp_path):
    base = json.loads((runs["lstm"] / "eval" / "heldout" / "metrics.json").read_text())
    cv = _cv_metrics(base)
    a = _copy_with_eval(runs["lstm"], tmp_path / "cv_a", "biotac", cv)
    b = _copy_with_eval(runs["mlp"], tmp_path / "cv_b", "biotac", cv)
    res = build_report([runs["fnn"], a, b], tmp_path / "rep", command="t")
    page = res.index.read_text(encoding="utf-8")

    # the overview: recorded results first, every one tagged
    overview = page.split("<h2 id='origins'>", 1)[1].split("<h2", 1)[0]
    rows = re.findall(r"<tr><td class='l'><a href='#eval-([^']+)'>", overview)
    assert rows[:2] == ["lstm/cv_a-biotac", "mlp/cv_b-biotac"]
    assert "fnn/fnn-heldout" in rows[2:]
    assert "<span class='tag recorded'>recorded</span>biotac_slide20 · Gao et al., IROS 2020" \
        in overview
    assert "2 results evaluated on recorded: biotac_slide20 · Gao et al., IROS 2020, trained " \
           "on unknown" in overview
    assert "81.25 [80.10, 89.20]" in overview  # per window, with the bootstrap interval
    assert "90.00 [80.00, 97.50]" in overview  # per trial, majority vote
    assert "84.50 ± 3.20" in overview  # mean ± sd over folds
    assert "held out: the trials of each fold (5-fold stratified by material" in overview
    assert "yes (no file or source shared with the training data)" in overview
    # sections: overview, comparisons (recorded first), runs (recorded first)
    heads = re.findall(r"<h2 id='(\w+)'>", page)
    assert heads[:2] == ["origins", "compare"] and heads[-1] == "runs"
    assert page.index("id='cmp-biotac'") < page.index("id='cmp-heldout'")
    assert page.index("id='run-lstm/cv_a'") < page.index("id='run-fnn/fnn'")
    cmp = page.split("id='cmp-biotac'", 1)[1].split("<h3", 1)[0]
    assert "<th class=\"l\">evaluated on</th>" in cmp and "CV accuracy (%, mean ± sd)" in cmp
    assert "per trial (%) [95 % CI]" in cmp

    # the cross-validated evaluation of one run
    run = page.split("id='run-lstm/cv_a'", 1)[1].split("<h3", 1)[0]
    ev = run.split("id='eval-lstm/cv_a-biotac'", 1)[1].split("<h4", 1)[0]
    assert "evaluated on <span class='tag recorded'>recorded</span>" in ev
    assert "<b>Cross-validated</b> (5-fold, stratified, grouped or stratified by material)" in ev
    assert "<tr class=\"mean\"><td class=\"l\">mean ± sd</td>" in ev
    assert ev.count("<td class=\"l\">4</td>") == 1  # fold 4's row
    assert "warning: fold 3 has no trial of class mat7" in ev
    assert re.search(r'<tr class="absent"><td class="l">release</td>.*?no support: left out of '
                     r"the macro F1</td>", ev)
    assert "95 % CI [80.10, 89.20] %" in ev
    assert "majority vote <b>90.00 %</b> [80.00, 97.50], mean probability 91.50 % " \
           "[85.00, 96.00]" in ev

    record = json.loads(res.provenance.read_text())
    assert record["origins"][0]["evaluated_on"]["kind"] == "recorded"
    assert [o["evaluation"] for o in record["origins"]][:2] == ["biotac", "biotac"]


@pytest.mark.slow
def test_origin_is_read_from_the_data_when_metrics_lack_it(runs, tmp_path):
    base = json.loads((runs["lstm"] / "eval" / "heldout" / "metrics.json").read_text())
    scene = _labelled_file(tmp_path / "scene_test.h5",
                           {"origin": "simulated", "dataset": "marker-events seed 1"})
    m = {k: v for k, v in base.items() if k != "origin"}
    m["data"] = [{"path": str(scene), "sha256": sha256_of(scene), "n_trials": 1}]
    gone = dict(m, data=[{"path": str(tmp_path / "moved.h5"), "sha256": "0" * 64,
                          "n_trials": 1}])
    run = _copy_with_eval(runs["lstm"], tmp_path / "r", "scene_test", m)
    (run / "eval" / "moved").mkdir()
    (run / "eval" / "moved" / "metrics.json").write_text(json.dumps(gone))
    res = build_report([run], tmp_path / "rep", command="t")
    by_name = {o["evaluation"]: o for o in res.origins}
    assert by_name["scene_test"]["evaluated_on"]["kind"] == "simulated"
    assert by_name["moved"]["evaluated_on"]["kind"] == "unknown"
    assert [o["evaluation"] for o in res.origins][0] == "scene_test"  # simulated first
    page = res.index.read_text(encoding="utf-8")
    assert "<span class='tag simulated'>simulated</span>marker-events seed 1" in page
    assert "None is known to be on recorded data." in page
    assert f"data file {tmp_path / 'moved.h5'} is no longer at the path recorded" in page
    assert by_name["heldout"]["trained_on"]["kind"] == "unknown"  # no labels on the fixture


@pytest.mark.slow
def test_training_data_made_from_the_evaluated_file_is_not_independent(runs, tmp_path):
    base = json.loads((runs["lstm"] / "eval" / "heldout" / "metrics.json").read_text())
    scene = _labelled_file(tmp_path / "scene.h5", {"origin": "simulated"})
    synth = _labelled_file(tmp_path / "synth.h5", {"origin": "synthetic"}, source=scene)
    run = tmp_path / "r"
    shutil.copytree(runs["lstm"], run)
    info = json.loads((run / "run.json").read_text())
    info["data"] = [{"path": str(synth), "sha256": sha256_of(synth), "n_trials": 1}]
    (run / "run.json").write_text(json.dumps(info))
    m = dict(base, data=[{"path": str(scene), "sha256": sha256_of(scene), "n_trials": 1}])
    m.pop("origin")
    (run / "eval" / "scene").mkdir()
    (run / "eval" / "scene" / "metrics.json").write_text(json.dumps(m))
    res = build_report([run], tmp_path / "rep", command="t")
    by_name = {o["evaluation"]: o for o in res.origins}
    assert by_name["scene"]["independent"] == ("no (the training data were made from "
                                               "scene.h5, which holds the evaluated recordings)")
    assert by_name["scene"]["trained_on"]["kind"] == "synthetic"


@pytest.mark.slow
def test_damaged_new_fields_do_not_break_the_page(runs, tmp_path):
    base = json.loads((runs["lstm"] / "eval" / "heldout" / "metrics.json").read_text())
    m = dict(base, cv={"k": 5, "folds": "x"}, warnings="not a list", origin={
        "kind": "recorded", "datasets": [1, "ok"], "labs": "x", "files": ["y"]})
    m["data"] = "not a list"
    m["heads"]["action"]["per_trial"] = [1, 2]
    m["heads"]["action"]["accuracy_ci95"] = ["a", None]
    run = _copy_with_eval(runs["lstm"], tmp_path / "r", "odd", m)
    res = build_report([run], tmp_path / "rep", command="t")
    page = res.index.read_text(encoding="utf-8")
    assert "<span class='tag recorded'>recorded</span>ok" in page
    assert "warning: n" not in page  # a string is not a list of warnings
