"""A run's input (issue 10, item 3): `tactile train` records the stream's sample period,
channels and units in run.json; evaluate, perturb and compare refuse other data."""

from __future__ import annotations

import json
import math
import shutil

import numpy as np
import pytest
from typer.testing import CliRunner

from tactile_cli.cli import app
from tactile_cli.errors import InputError
from tactile_cli.learn.compare import compare
from tactile_cli.learn.data import read_trials
from tactile_cli.learn.evaluate import evaluate
from tactile_cli.learn.inputs import InputSpec, check_input, input_spec
from tactile_cli.learn.perturb import perturb_evaluate
from tactile_cli.learn.runs import load_run
from tactile_cli.learn.train import train
from tactile_cli.store import StoreWriter

from ..factories.action_files import make_action_file
from .conftest import tiny_config

runner = CliRunner()
STREAM = "/trials/synth_0000/signals/event_counts"
CHANNELS = ("positive", "net")  # the file's order; the run reads [net, positive]


def counts_file(path, **changes):
    """8 trials of 10 ms bins (100 Hz), channels positive and net: the same seed gives
    the same counts whatever sensor attributes ``changes`` set."""
    return make_action_file(path, n_trials=8, seed=3, bin_s=0.01,
                            **{"channel_names": CHANNELS, **changes})


@pytest.fixture(scope="module")
def run100(tmp_path_factory):
    """A one-epoch LSTM on a 100 Hz file, reading channels [net, positive]."""
    root = tmp_path_factory.mktemp("inputs")
    data = counts_file(root / "train100.h5")
    run = root / "run"
    train(tiny_config(data={"channels": ["net", "positive"]}, optim={"epochs": 1}),
          [data], run, command="tests")
    return run, data


def one_error_line(result) -> str:
    assert result.exit_code == 2, result.output
    lines = result.stderr.splitlines()
    assert len(lines) == 1, result.stderr
    return lines[0]


def test_run_json_records_the_stream_period_channels_and_units(run100):
    run, _ = run100
    info = json.loads((run / "run.json").read_text())
    assert info["input"] == {
        "stream": "event_counts", "sensor": "event_counts", "origin": "signal",
        "sample_period_s": 0.01, "sample_rate_hz": 100.0, "channels": ["net", "positive"],
        "units": ["events/bin", "events/bin"]}
    assert load_run(run).input == InputSpec("event_counts", 0.01, ("net", "positive"),
                                            ("events/bin", "events/bin"), "event_counts")


@pytest.mark.slow
@pytest.mark.parametrize(("rate", "shown"), [(8000, "0.000125 s (8000 Hz)"),
                                             (101, "0.00990099 s (101 Hz)")])
def test_evaluate_refuses_another_sample_rate_in_one_line(run100, tmp_path, rate, shown):
    run, _ = run100
    other = counts_file(tmp_path / f"at{rate}.h5", sample_rate_hz=rate)
    res = runner.invoke(app, ["evaluate", str(run), "--data", str(other), "--no-latency",
                              "--name", "refused"])
    assert one_error_line(res) == (
        f"tactile: error: {other}, {STREAM}: sample period {shown} differs from the run's "
        "0.01 s (100 Hz) by more than 0.5 %; resample the data to 100 Hz or retrain on it")
    assert not (run / "eval" / "refused").exists()


@pytest.mark.slow
def test_evaluate_accepts_a_rate_within_a_tenth_of_a_percent(run100, tmp_path):
    run, data = run100
    near = counts_file(tmp_path / "near.h5", sample_rate_hz=100.05)
    ref = evaluate(run, [data], latency=False, name="ref").as_dict()
    res = evaluate(run, [near], latency=False, name="near").as_dict()
    assert res["input"]["sample_rate_hz"] == pytest.approx(100.05)
    assert res["input"]["checked_against_run"] is True and res["notes"] == []
    assert res["heads"]["action"]["confusion_matrix"] == \
        ref["heads"]["action"]["confusion_matrix"]
    written = json.loads((run / "eval" / "near" / "metrics.json").read_text())
    assert written["input"]["sample_period_s"] == pytest.approx(1 / 100.05)


@pytest.mark.slow
def test_a_rate_a_clock_apart_is_accepted_with_a_note_naming_the_file(run100, tmp_path):
    """Two sessions of one sensor differ by their clocks (Xela files of one set at 59.78
    and 59.88 Hz, 0.18 %): scored, with a note naming the file and both rates; 1 % apart
    (101 Hz) is another rate and refused (above)."""
    run, data = run100
    near = counts_file(tmp_path / "clock.h5", sample_rate_hz=100.3)
    res = evaluate(run, [near], latency=False, name="clock").as_dict()
    assert res["notes"] == [
        f"{near}: sample period 0.00997009 s (100.3 Hz) differs from the run's 0.01 s "
        "(100 Hz) by 0.30 % (accepted up to 0.5 %, as two clocks of one sensor differ; a "
        "window of the same samples spans that much more or less time)"]
    res = runner.invoke(app, ["evaluate", str(run), "--data", str(near), "--no-latency",
                              "--name", "clock2"])
    assert res.exit_code == 0 and "differs from the run's 0.01 s (100 Hz) by 0.30 %" \
        in res.stderr
    result = train(tiny_config(optim={"epochs": 1}), [data, near], tmp_path / "both")
    assert any(w.startswith(f"{near}: sample period") and "the first trial's" in w
               for w in result.warnings)


def test_evaluate_refuses_a_renamed_channel_and_other_units(run100, tmp_path):
    run, _ = run100
    renamed = counts_file(tmp_path / "renamed.h5", channel_names=("positive", "netto"))
    res = runner.invoke(app, ["evaluate", str(run), "--data", str(renamed), "--no-latency"])
    assert one_error_line(res) == (
        f"tactile: error: {renamed}, {STREAM}: channel 'net' is not a channel of sensor "
        "'event_counts' (channels: positive, netto); the run was trained on channels "
        "[net, positive]; rename the data's channels to the run's or retrain on it")
    units = counts_file(tmp_path / "units.h5", channel_units="counts")
    res = runner.invoke(app, ["evaluate", str(run), "--data", str(units), "--no-latency"])
    assert one_error_line(res) == (
        f"tactile: error: {units}, {STREAM}: channel units [counts, counts] of "
        "[net, positive] differ from the run's [events/bin, events/bin]; convert the data "
        "to the run's units or retrain on it")


@pytest.mark.slow
def test_channels_in_another_order_in_the_file_are_read_in_the_run_s_order(run100, tmp_path):
    # channels are selected by name, so the model sees [net, positive] either way: the same
    # predictions, nothing to refuse
    run, data = run100
    swapped = counts_file(tmp_path / "swapped.h5", channel_names=("net", "positive"))
    ref = evaluate(run, [data], latency=False, name="ref_order").as_dict()
    res = evaluate(run, [swapped], latency=False, name="swapped").as_dict()
    assert res["input"]["channels"] == ["net", "positive"]
    assert res["heads"] == ref["heads"]


def test_the_run_s_channel_order_is_checked(run100, tmp_path):
    run, data = run100
    trials = read_trials([data], load_run(run).config.data)
    reordered = InputSpec("event_counts", 0.01, ("positive", "net"),
                          ("events/bin", "events/bin"))
    with pytest.raises(InputError, match=r"channels \[net, positive\] differ from the run's "
                                         r"\[positive, net\]; rename the data's channels"):
        check_input(trials, reordered)


def test_train_refuses_files_of_different_rates(tmp_path):
    a = counts_file(tmp_path / "a.h5")
    b = counts_file(tmp_path / "b.h5", sample_rate_hz=8000)
    with pytest.raises(InputError) as err:
        train(tiny_config(optim={"epochs": 1}), [a, b], tmp_path / "run")
    assert str(err.value) == (
        f"{b}, {STREAM}: sample period 0.000125 s (8000 Hz) differs from 0.01 s (100 Hz) of "
        "a.h5/synth_0000 by more than 0.5 %; resample the files to one rate or use them in "
        "separate runs")
    assert not (tmp_path / "run").exists()


def test_perturb_refuses_another_sample_rate(run100, tmp_path):
    run, _ = run100
    other = counts_file(tmp_path / "fast.h5", sample_rate_hz=8000)
    with pytest.raises(InputError, match=r"sample period 0.000125 s \(8000 Hz\) differs from "
                                         r"the run's 0.01 s \(100 Hz\)"):
        perturb_evaluate(run, [other], ["noise"], {"noise": [10]}, write=False)
    res = runner.invoke(app, ["perturb", str(run), "--data", str(other), "--kinds", "noise"])
    assert one_error_line(res).startswith(f"tactile: error: {other}, {STREAM}: sample period "
                                          "0.000125 s (8000 Hz) differs from the run's")
    assert not (run / "perturb").exists()


def test_a_run_json_without_input_still_evaluates_with_a_note(run100, tmp_path):
    run, data = run100
    old = tmp_path / "old_run"
    shutil.copytree(run, old, ignore=shutil.ignore_patterns("eval", "perturb"))
    info = json.loads((old / "run.json").read_text())
    del info["input"]
    (old / "run.json").write_text(json.dumps(info))
    assert load_run(old).input is None
    res = runner.invoke(app, ["evaluate", str(old), "--data", str(data), "--no-latency",
                              "--name", "old"])
    assert res.exit_code == 0, res.output
    note = (f"{old}: run.json records no input sample period or channels (trained before "
            "they were recorded), so the data's sample period 0.01 s (100 Hz) and channels "
            "[net, positive] were not checked against the training data's; retrain with this "
            "version to have them checked")
    assert f"tactile: warning: {note}\n" in res.stderr
    metrics = json.loads((old / "eval" / "old" / "metrics.json").read_text())
    assert metrics["notes"] == [note]
    assert metrics["input"]["checked_against_run"] is False
    assert metrics["input"]["sample_period_s"] == 0.01
    # any rate is evaluated, but never silently
    fast = counts_file(tmp_path / "fast.h5", sample_rate_hz=8000)
    res = perturb_evaluate(old, [fast], ["noise"], {"noise": [10]}, write=False)
    assert any("0.000125 s (8000 Hz)" in n and "were not checked" in n for n in res.notes)
    # compare says so too
    cmp = compare([old], data_name="old")
    assert cmp.notes == ["lstm/old_run: run.json records no input sample period or "
                         "channels, so evaluation 'old' was not checked to be of data like "
                         "the training data; re-run `tactile train` to have it checked"]


def test_compare_refuses_an_evaluation_of_data_at_another_rate(run100, tmp_path):
    run, data = run100
    copy = tmp_path / "run"
    shutil.copytree(run, copy, ignore=shutil.ignore_patterns("eval", "perturb"))
    evaluate(copy, [data], latency=False, name="e")
    assert compare([copy], data_name="e").notes == []
    path = copy / "eval" / "e" / "metrics.json"
    metrics = json.loads(path.read_text())
    metrics["input"]["sample_period_s"] = 1.25e-4  # as if evaluated on 8 kHz data
    path.write_text(json.dumps(metrics))
    res = runner.invoke(app, ["compare", str(copy), "--data-name", "e"])
    assert one_error_line(res) == (
        f"tactile: error: {path}: the evaluation data's sample period 0.000125 s (8000 Hz) "
        "differs from the run's 0.01 s (100 Hz) by more than 0.5 %; re-run `tactile evaluate "
        f"{copy} --data FILE` on data of the run's input, or retrain")
    del metrics["input"]  # a metrics.json of an older tactile: compared, with a note
    path.write_text(json.dumps(metrics))
    res = runner.invoke(app, ["compare", str(copy), "--data-name", "e"])
    assert res.exit_code == 0, res.output
    assert "tactile: warning: lstm/run: metrics.json records no input sample period" \
        in res.stderr


def test_sample_period_from_rate_bin_width_or_time_steps(tmp_path):
    path = tmp_path / "periods.h5"
    t = np.arange(50) * 0.004
    with StoreWriter(path, command="test") as w:
        for name, attrs in (("rated", {"sample_rate_hz": 250.0}),
                            ("binned", {"sample_rate_hz": 0.0, "bin_s": 0.005}),
                            ("bare", {"sample_rate_hz": 0.0})):
            # a rate of 0 (the schema allows it for event cameras only: their count
            # streams carry `bin_s`) leaves the period to `bin_s` or the time steps
            if attrs["sample_rate_hz"] == 0:
                attrs = {**attrs, "kind": "event_camera", "width_px": 8, "height_px": 8}
            s = w.add_sensor(name, **{"kind": "pressure", **attrs}, channel_names=["p"],
                             channel_units="kPa")
            w.trial(name).write_signal("s", sensor=s, data=np.zeros((50, 1)), t_s=t,
                                       sample_labels={"action": (np.zeros(50, np.int8),
                                                                 ["rest", "touch"])})
        w.commit()
    trials = read_trials([path], tiny_config(data={"stream": "s", "channels": ["p"]}).data)
    periods = {tr.trial: tr.sample_period_s for tr in trials}
    assert periods == pytest.approx({"rated": 0.004, "binned": 0.005, "bare": 0.004})
    assert {tr.channel_units for tr in trials} == {("kPa",)}
    with pytest.raises(InputError, match=r"periods.h5, /trials/binned/signals/s: sample "
                                         r"period 0.005 s \(200 Hz\) differs from 0.004 s "
                                         r"\(250 Hz\) of periods.h5/rated"):
        input_spec(trials, "s")


def test_counts_from_events_have_the_config_s_bin_width(event_file):
    path, _ = event_file
    trials = read_trials([path], tiny_config(data={"bin_s": 0.02}).data)
    assert all(t.sample_period_s == 0.02 and t.channel_units == ("events/bin",)
               for t in trials)
    spec = input_spec(trials, "event_counts")
    assert spec.origin == "events" and spec.sample_rate_hz == pytest.approx(50)
    check_input(trials, InputSpec("event_counts", 0.02, ("net",), ("events/bin",)))
    with pytest.raises(InputError, match=r"/trials/scene_000/events \(counted as "
                                         r"event_counts\): sample period 0.02 s \(50 Hz\) "
                                         r"differs from the run's 0.01 s \(100 Hz\)"):
        check_input(trials, InputSpec("event_counts", 0.01, ("net",), ("events/bin",)))
    assert math.isclose(InputSpec.from_dict(spec.as_dict()).sample_period_s, 0.02)
