"""Input shift and interleaving in recording order, from the library and through
``tactile evaluate`` (issue 34, item 1)."""

from __future__ import annotations

import json

import numpy as np
import pytest
from typer.testing import CliRunner

from tactile_cli.cli import app
from tactile_cli.learn.config import parse_config
from tactile_cli.learn.cv import train_cv
from tactile_cli.learn.data import TrialSeries, fit_normalisation
from tactile_cli.learn.drift import (
    Interleaving,
    input_shift,
    interleaving,
    pooled_interleaving,
    recording_record,
)
from tactile_cli.learn.evaluate import evaluate
from tactile_cli.learn.heads import HeadSpec
from tactile_cli.learn.train import train

from ..factories.texture_files import make_texture_file

runner = CliRunner()


def _series(name: str, x: np.ndarray, t0: float | None = None, **labels) -> TrialSeries:
    return TrialSeries("f.h5", name, "", x.astype(np.float32), np.arange(len(x)) * 0.01,
                       trial_labels=labels, channel_names=("a", "b"), time_origin_unix_s=t0)


def test_a_shifted_channel_is_flagged_and_an_unshifted_one_is_not():
    swing = np.tile([[-1.0], [1.0]], (50, 1))  # 100 samples, mean 0, std 1
    train_x = np.hstack([100.0 + 4.0 * swing, -5.0 + 2.0 * swing])  # a: 100 +- 4, b: -5 +- 2
    norm = fit_normalisation([_series("t", train_x)], ["a", "b"])
    later = np.hstack([112.0 + 2.0 * swing, -5.0 + 2.0 * swing])  # a: +3 SD, half the spread
    report = input_shift([_series("e1", later[:40]), _series("e2", later[40:])],
                         parse_config(_CONFIG).data, norm, threshold_sd=1.0)
    a, b = report.channels
    assert (a.channel, a.flagged, b.flagged) == ("a", True, False)
    assert a.shift_sd == pytest.approx(3.0) and b.shift_sd == pytest.approx(0.0, abs=1e-12)
    assert a.spread_ratio == pytest.approx(0.5) and b.spread_ratio == pytest.approx(1.0)
    assert report.n_samples == 100 and [c.channel for c in report.flagged] == ["a"]
    assert report.summary() == ("1 of 2 channel(s) shifted beyond 1 training SD from the "
                                "training data: a +3.00")
    record = report.as_dict()
    assert record["flagged"] == ["a"] and record["threshold_sd"] == 1.0
    # the run's baseline removal comes first: a per-trial offset is no shift then
    base = parse_config({**_CONFIG, "data": {**_CONFIG["data"],
                                             "baseline": {"mode": "median"}}}).data
    norm_b = fit_normalisation([_series("t", train_x)], ["a", "b"], baseline=base.baseline)
    assert not input_shift([_series("e", later)], base, norm_b).flagged


def test_interleaving_by_start_time_and_by_class():
    heads = [HeadSpec("material", "classification", "trial", 1.0, ("A", "B"))]
    x = np.zeros((3, 2))
    learned = [_series(f"{m}_{i}", x, t0=t, material=m)
               for m, i, t in (("A", 1, 10.0), ("A", 2, 11.0), ("B", 1, 20.0), ("B", 2, 21.0))]
    record = recording_record(learned, heads, split_mode="stratified", split_by="material")
    assert record is not None and record["by"] == "time_origin_unix_s"
    assert record["class_spans"] == {"A": ["10.0", "11.0"], "B": ["20.0", "21.0"]}
    between = [_series("A_x", x, t0=10.5, material="A"), _series("B_x", x, t0=30.0,
                                                                material="B")]
    found = interleaving(between, record)
    assert (found.n_inside_span, found.n_inside_class_span, found.interleaved) == (1, 1, True)
    assert found.message().startswith("1 of 2 evaluated trial(s) lie inside the recording "
                                      "span (by time_origin_unix_s) of the training trials "
                                      "of their material")
    # A's later trial lies between the training trials overall, but after A's own
    after = [_series("A_y", x, t0=15.0, material="A")]
    found = interleaving(after, record)
    assert (found.n_inside_span, found.n_inside_class_span, found.interleaved) == (1, 0, False)
    assert found.message() is None
    # without start times, a blocked split's label gives the order (natural: 9 < 10)
    by_sample = [_series(f"A_{i}", x, material="A", sample=str(i)) for i in (9, 10)]
    record = recording_record(by_sample, heads, split_mode="blocked", split_by="sample")
    assert record is not None and record["span"] == ["9", "10"]
    assert not interleaving([_series("A_11", x, material="A", sample="11")],
                            record).interleaved
    assert recording_record(by_sample, heads, split_mode="stratified", split_by=None) is None
    unknown = interleaving(by_sample, None)
    assert unknown.interleaved is None and "records no recording order" in unknown.reason


_CONFIG = {
    "seed": 0,
    "data": {"stream": "finger", "channels": ["a", "b"], "window": 20, "stride": 20,
             "targets": [{"name": "material", "source": "trial"}],
             "split": {"mode": "stratified", "by": "material", "val_fraction": 0.0,
                       "test_fraction": 0.34}},
    "model": {"family": "mlp", "hidden": [8]},
    "optim": {"lr": 0.01, "epochs": 1, "patience": 0, "batch_size": 64},
}


@pytest.fixture(scope="module")
def texture(tmp_path_factory):
    root = tmp_path_factory.mktemp("drift")
    first = make_texture_file(root / "first.h5", seed=0, duration_s=1.0)
    later = make_texture_file(root / "later.h5", seed=1, first_sample=11, duration_s=1.0,
                              offset=(25.0, 0.0))  # channel a moved by ~25 counts
    return root, first, later


@pytest.mark.slow
def test_cli_evaluate_reports_shift_and_interleaving(texture):
    root, first, later = texture
    stratified = root / "stratified"
    train(parse_config(_CONFIG), [first], stratified, command="tests")
    blocked_cfg = {**_CONFIG, "data": {**_CONFIG["data"], "split": {
        "mode": "blocked", "by": "sample", "val_fraction": 0.0, "test_fraction": 0.34}}}
    blocked = root / "blocked"
    train(parse_config(blocked_cfg), [first], blocked, command="tests")

    held = runner.invoke(app, ["evaluate", str(stratified), "--data", str(first), "--split",
                               "test", "--no-latency"])
    assert held.exit_code == 0, held.output
    metrics = json.loads((stratified / "eval" / "first.test" / "metrics.json").read_text())
    inter = metrics["interleaving"]
    assert inter["order_by"] == "time_origin_unix_s" and inter["class_label"] == "material"
    assert inter["interleaved"] is True and inter["n_evaluated"] == 6
    assert f"tactile: warning: {inter['n_inside_class_span']} of 6 evaluated trial(s) lie " \
        "inside the recording span" in held.stderr
    assert "(interleaved)" in held.stdout

    ok = runner.invoke(app, ["evaluate", str(blocked), "--data", str(first), "--split", "test",
                             "--no-latency"])
    assert ok.exit_code == 0, ok.output
    metrics = json.loads((blocked / "eval" / "first.test" / "metrics.json").read_text())
    assert metrics["interleaving"]["interleaved"] is False
    assert metrics["interleaving"]["n_inside_class_span"] == 0
    assert "lie inside the recording span" not in ok.stderr
    assert "0 of 6 evaluated trial(s) inside the span of the training trials of their " \
        "material (not interleaved)" in ok.stdout
    assert not metrics["shift"]["flagged"]

    shifted = runner.invoke(app, ["evaluate", str(blocked), "--data", str(later),
                                  "--no-latency", "--shift-threshold", "2"])
    assert shifted.exit_code == 0, shifted.output
    shift = json.loads((blocked / "eval" / "later" / "metrics.json").read_text())["shift"]
    assert shift["flagged"] == ["a"] and shift["threshold_sd"] == 2.0
    a, b = shift["channels"]
    assert a["shift_sd"] > 2.0 and abs(b["shift_sd"]) < 0.5
    assert "tactile: warning: 1 of 2 channel(s) shifted beyond 2 training SD from the " \
        "training data: a +" in shifted.stderr
    bad = runner.invoke(app, ["evaluate", str(blocked), "--data", str(later), "--no-latency",
                              "--shift-threshold", "0", "--name", "x"])
    assert bad.exit_code == 2
    assert bad.stderr.startswith("tactile: error: --shift-threshold must be a number > 0")


@pytest.mark.slow
def test_blocked_cross_validation_reports_each_fold_against_its_own_training(texture):
    root, first, _ = texture
    raw = {**_CONFIG, "data": {**_CONFIG["data"], "split": {
        "mode": "blocked", "by": "sample", "val_fraction": 0.0}}}
    run = root / "cv_blocked"
    train_cv(parse_config(raw), [first], run, k=2, jobs=1, command="tests")
    result = evaluate(run, None, latency=False, command="tests")
    inter = result.extra["interleaving"]
    assert inter["interleaved"] is False and inter["n_evaluated"] == 18
    assert [(f["fold"], f["n_evaluated"], f["n_inside_class_span"]) for f in inter["folds"]] \
        == [(0, 9, 0), (1, 9, 0)]
    shift = result.extra["shift"]
    assert [f["fold"] for f in shift["folds"]] == [0, 1] and shift["n_samples"] == 1800
    assert result.cv is not None and result.cv["mode"] == "blocked"


def test_pooled_interleaving_sums_the_folds_and_is_unknown_when_one_is():
    a = Interleaving("time_origin_unix_s", 4, 3, "material", 2, True)
    b = Interleaving("time_origin_unix_s", 5, 1, "material", 0, False)
    pooled = pooled_interleaving([a, b], [0, 1])
    assert (pooled.n_evaluated, pooled.n_inside_span, pooled.n_inside_class_span,
            pooled.interleaved) == (9, 4, 2, True)
    assert [f["fold"] for f in pooled.folds] == [0, 1]
    unknown = pooled_interleaving([a, Interleaving(None, 2, reason="no order")], [0, 1])
    assert unknown.interleaved is None and unknown.reason == "no order"


def test_trials_that_give_no_window_are_named_not_silently_unscored():
    from tactile_cli.learn.data import make_windows, windowless_note

    cfg = parse_config({**_CONFIG, "data": {**_CONFIG["data"], "window": 20, "stride": 20,
                                            "pad": "none"}})
    heads = [HeadSpec("material", "classification", "trial", 1.0, ("A", "B"))]
    trials = [_series("long_A", np.ones((40, 2)), material="A"),
              _series("short_B", np.ones((19, 2)), material="B"),
              _series("exact_B", np.ones((20, 2)), material="B")]
    norm = fit_normalisation(trials, ["a", "b"])
    ws = make_windows(trials, cfg.data, heads, norm)
    assert sorted(set(ws.trials[i] for i in ws.trial_index)) == ["f.h5/exact_B", "f.h5/long_A"]
    assert windowless_note(trials, ws, 20) == [
        "1 of 3 trials give no window and are not scored (f.h5/short_B): shorter than the "
        "window of 20 samples (data.pad: none), or without a labelled sample"]
    assert windowless_note(trials[:1] + trials[2:], make_windows(
        trials[:1] + trials[2:], cfg.data, heads, norm), 20) == []
