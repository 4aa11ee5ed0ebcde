"""`tactile train` and `tactile evaluate`: run folder, determinism, learning, metrics."""

from __future__ import annotations

import csv
import json

import numpy as np
import pytest
import torch
import yaml
from typer.testing import CliRunner

from tactile_cli.cli import app
from tactile_cli.errors import InputError
from tactile_cli.learn.evaluate import classification_metrics, evaluate
from tactile_cli.learn.runs import load_run
from tactile_cli.learn.train import train

from .conftest import tiny_config

runner = CliRunner()


@pytest.fixture(scope="module")
def tiny_run(tmp_path_factory, action_file):
    """A 10-epoch LSTM (16 units) on the synthetic action task, each bin decided 5 bins
    later (module-wide: it is reused)."""
    out = tmp_path_factory.mktemp("runs") / "lstm"
    cfg = tiny_config(data={"label_delay": 5}, optim={"epochs": 10})
    result = train(cfg, [action_file], out, command="test")
    return out, result


@pytest.mark.slow
def test_run_folder_holds_weights_config_normalisation_history_and_provenance(
        tiny_run, action_file):
    out, result = tiny_run
    names = {p.name for p in out.iterdir()}
    assert {"model.pt", "config.resolved.yaml", "normalisation.json", "history.csv",
            "curves.png", "run.json", "split.csv"} <= names
    info = json.loads((out / "run.json").read_text())
    assert info["format"] == "tactile-run" and info["format_version"] == 1
    assert set(info["versions"]) >= {"tactile", "torch", "numpy", "python"}
    assert info["data"][0]["path"] == str(action_file)
    assert len(info["data"][0]["sha256"]) == 64 and info["data"][0]["n_trials"] == 24
    assert info["seed"] == 0 and info["command"] == "test"
    assert info["model"]["n_params"] == result.n_params > 0
    assert info["split"]["trials"] == {"train": 12, "val": 6, "test": 6}
    assert yaml.safe_load((out / "config.resolved.yaml").read_text())["model"]["hidden"] == 16
    with open(out / "history.csv") as f:
        rows = list(csv.DictReader(f))
    assert [int(r["epoch"]) for r in rows] == list(range(1, 11))
    norm = json.loads((out / "normalisation.json").read_text())
    assert norm["channels"] == ["net"] and norm["transform"] == "signed_log1p"
    with open(out / "split.csv") as f:
        splits = {(r["trial"], r["split"]) for r in csv.DictReader(f)}
    assert len(splits) == 24  # every trial once, on one side only


def test_weights_load_with_weights_only_and_give_the_trained_model(tiny_run):
    out, _ = tiny_run
    state = torch.load(out / "model.pt", weights_only=True)
    assert all(isinstance(v, torch.Tensor) for v in state.values())
    model = load_run(out).load_model()
    for key, value in model.state_dict().items():
        torch.testing.assert_close(value, state[key], rtol=0, atol=0)


@pytest.mark.slow
def test_same_seed_gives_identical_weights_and_another_seed_does_not(tmp_path, action_file):
    cfg = tiny_config(optim={"epochs": 1})
    train(cfg, [action_file], tmp_path / "a")
    train(cfg, [action_file], tmp_path / "b")
    train(cfg.with_overrides(seed=1), [action_file], tmp_path / "c")
    a, b, c = (torch.load(tmp_path / n / "model.pt", weights_only=True) for n in "abc")
    assert a.keys() == b.keys()
    assert all(torch.equal(a[k], b[k]) for k in a)
    assert not all(torch.equal(a[k], c[k]) for k in a)
    losses = [(tmp_path / n / "history.csv").read_text().splitlines()[1].split(",")[1:4]
              for n in "ab"]
    assert losses[0] == losses[1]  # train loss, val loss, val accuracy


def test_a_small_lstm_learns_the_action_task_well_above_chance(tiny_run, heldout_file):
    out, result = tiny_run
    res = evaluate(out, [heldout_file], latency=False)
    m = res.heads[0]
    chance = max(c.support for c in m.per_class) / m.n  # always the most frequent class
    assert chance < 0.4
    assert m.accuracy > 0.7, m.accuracy  # about 0.8 after 10 epochs of 12 trials
    assert result.best_val_accuracy > 0.7
    assert min(c.recall for c in m.per_class) > 0.4  # every action is recognised


def test_evaluate_writes_metrics_confusion_and_latency(tiny_run, heldout_file):
    out, _ = tiny_run
    res = evaluate(out, [heldout_file], threads=1, overwrite=True)
    folder = out / "eval" / "heldout"
    assert res.out_dir == folder
    metrics = json.loads((folder / "metrics.json").read_text())
    assert metrics["format"] == "tactile-eval" and metrics["family"] == "lstm"
    assert metrics["primary_head"] == "action" and 0 < metrics["accuracy"] <= 1
    head = metrics["heads"]["action"]
    assert head["classes"] == ["approach", "press", "slip", "release"]
    cm = np.array(head["confusion_matrix"])
    assert cm.shape == (4, 4) and cm.sum() == metrics["n_windows"] == head["n"]
    assert [c["support"] for c in head["per_class"]] == cm.sum(axis=1).tolist()
    assert head["accuracy"] == pytest.approx(np.trace(cm) / cm.sum())
    assert head["boundary_margin"] == 1 and 0 < head["n_near_boundary"] < head["n"]
    assert head["accuracy_excluding_boundaries"] >= head["accuracy"] - 0.05
    lat = metrics["latency"]
    assert lat["threads"] == 1 and lat["batch1_repeats"] == 300
    assert 0 < lat["batch1_ms_median"] <= lat["batch1_ms_p95"]
    assert lat["large_batch"] == 1024 and lat["windows_per_s"] > 0
    assert metrics["model"]["n_params"] > 0 and metrics["model"]["size_mb"] > 0
    assert metrics["overlaps_training"] == []
    assert json.loads((folder / "confusion_action.json").read_text())["matrix"] == cm.tolist()
    assert (folder / "confusion_action.png").stat().st_size > 1000
    with open(folder / "predictions.csv") as f:
        rows = list(csv.DictReader(f))
    assert len(rows) == cm.sum()
    assert sum(r["action_true"] == r["action_pred"] for r in rows) == np.trace(cm)


def test_evaluate_test_split_reproduces_the_training_split(tiny_run, action_file):
    out, result = tiny_run
    res = evaluate(out, [action_file], split="test", latency=False)
    assert res.n_trials == 6 and res.n_windows == result.n_windows["test"]
    assert res.out_dir.name == "synth.test" and res.overlaps_training == [str(action_file)]


def test_classification_metrics_match_table_one_definitions():
    y_true = np.array([0, 0, 0, 1, 1, 2, 2, 2, 2])
    y_pred = np.array([0, 0, 1, 1, 1, 2, 2, 0, 2])
    m = classification_metrics(y_true, y_pred, ["a", "b", "c"],
                               near_boundary=np.array([0, 0, 1, 0, 0, 0, 0, 1, 0], bool))
    assert m.confusion_matrix == [[2, 1, 0], [0, 2, 0], [1, 0, 3]]
    a, b, c = m.per_class
    assert (a.precision, a.recall) == (pytest.approx(2 / 3), pytest.approx(2 / 3))
    assert (b.precision, b.recall, b.f1) == (pytest.approx(2 / 3), 1.0, pytest.approx(0.8))
    assert (c.precision, c.recall) == (1.0, 0.75)
    assert m.accuracy == pytest.approx(7 / 9)
    assert m.accuracy_excluding_boundaries == 1.0 and m.n_near_boundary == 2


def test_multitask_run_reports_regression_error_in_label_units(tmp_path, action_file):
    cfg = tiny_config(data={"targets": [
        {"name": "action"}, {"name": "force_level", "source": "trial", "kind": "regression",
                             "weight": 0.5}]}, optim={"epochs": 2, "lr_schedule": "cosine"})
    out = tmp_path / "mt"
    train(cfg, [action_file], out)
    res = evaluate(out, [action_file], split="test", latency=False)
    reg = res.as_dict()["heads"]["force_level"]
    assert reg["kind"] == "regression" and reg["n"] == res.n_windows
    assert 0 < reg["mae"] <= reg["rmse"] < 12  # levels 1..12, in level units
    norm = json.loads((out / "normalisation.json").read_text())
    assert 5 < norm["targets"]["force_level"]["mean"] < 8


def test_existing_run_folder_is_an_error_unless_overwrite(tiny_run, action_file):
    out, _ = tiny_run
    with pytest.raises(InputError, match="output folder exists; pass `overwrite=True`"):
        train(tiny_config(), [action_file], out)


@pytest.mark.slow
def test_cli_train_and_evaluate(tmp_path, action_file, heldout_file):
    cfg = tmp_path / "cfg.yaml"
    cfg.write_text(tiny_config(optim={"epochs": 2}).as_yaml())
    run = tmp_path / "run"
    result = runner.invoke(app, ["train", str(cfg), "--data", str(action_file), "--out", str(run),
                                 "--epochs", "1", "--json"])
    assert result.exit_code == 0, result.output
    summary = json.loads(result.stdout)
    assert summary["run_dir"] == str(run) and len(summary["history"]) == 1
    text = runner.invoke(app, ["evaluate", str(run), "--data", str(heldout_file),
                               str(action_file), "--no-latency"])
    assert text.exit_code == 0, text.output
    assert "accuracy" in text.stdout and "precision" in text.stdout
    assert (run / "eval" / "heldout+synth" / "metrics.json").exists()
    assert "was used to train this run" in text.stderr  # all trials of a training file
    js = runner.invoke(app, ["evaluate", str(run), "--data", str(heldout_file), "--json",
                             "--threads", "1"])
    assert js.exit_code == 0, js.output
    assert json.loads(js.stdout)["latency"]["threads"] == 1
    missing = runner.invoke(app, ["evaluate", str(tmp_path), "--data", str(heldout_file)])
    assert missing.exit_code == 2
    assert "not a run folder (no run.json)" in missing.stderr
    # an existing evaluation of the same name is kept unless --overwrite (issue 21, item 2)
    before = (run / "eval" / "heldout" / "metrics.json").read_bytes()
    again = runner.invoke(app, ["evaluate", str(run), "--data", str(heldout_file),
                                "--no-latency"])
    assert again.exit_code == 2 and again.stderr.count("\n") == 1
    assert "evaluation folder exists; pass --overwrite to replace it or give another --name" \
        in again.stderr
    assert (run / "eval" / "heldout" / "metrics.json").read_bytes() == before
    forced = runner.invoke(app, ["evaluate", str(run), "--data", str(heldout_file),
                                 "--no-latency", "--overwrite"])
    assert forced.exit_code == 0, forced.output
    assert (run / "eval" / "heldout" / "metrics.json").read_bytes() != before


def _accel_file(path):
    """A sampled 3-axis signal (not event counts): 'motion' per sample, texture per trial;
    slip windows carry a 40 Hz vibration whose amplitude depends on the texture."""
    from tactile_cli.store import StoreWriter

    rng = np.random.default_rng(0)
    with StoreWriter(path, command="test") as w:
        s = w.add_sensor("acc", kind="accelerometer", sample_rate_hz=400,
                         channel_names=["x", "y", "z"], channel_units="g")
        for i in range(12):
            texture = ("smooth", "rough")[i % 2]
            t = np.arange(800) / 400
            motion = (t >= 1.0).astype(np.int8)
            amp = (0.5 if texture == "smooth" else 1.5) * motion
            data = rng.normal(0, 0.1, (800, 3))
            data[:, 2] += amp * np.sin(2 * np.pi * 40 * t)
            w.trial(f"r{i}", labels={"texture": texture}).write_signal(
                "acc", sensor=s, data=data, t_s=t,
                sample_labels={"motion": (motion, ["still", "slip"])})
        w.commit()
    return path


def test_sampled_signal_multitask_spectrogram_cnn(tmp_path):
    """Sampled signals work like counts: channels by name, a per-sample and a trial head."""
    path = _accel_file(tmp_path / "acc.h5")
    cfg = tiny_config(
        data={"stream": "acc", "channels": ["z", "x"], "window": 32, "stride": 8, "pad": "none",
              "transform": "none",
              "targets": [{"name": "motion"}, {"name": "texture", "source": "trial"}]},
        model={"family": "cnn2d_spectrogram", "n_fft": 16, "hop": 4, "channels": [4]},
        optim={"epochs": 4, "lr": 0.01})
    out = tmp_path / "run"
    result = train(cfg, [path], out)
    assert [h.name for h in result.heads] == ["motion", "texture"]
    assert result.heads[1].classes == ("rough", "smooth")
    res = evaluate(out, [path], split="test", latency=False).as_dict()
    assert set(res["heads"]) == {"motion", "texture"}
    assert res["heads"]["motion"]["accuracy"] > 0.8  # a vibration is easy to see
    assert np.sum(res["heads"]["texture"]["confusion_matrix"]) == res["n_windows"]
    # texture within each true motion class: the groups cover every window and their
    # weighted mean is the overall accuracy
    by = res["heads"]["texture"]["accuracy_by"]["motion"]
    assert set(by) == {"still", "slip"}
    assert sum(g["n"] for g in by.values()) == res["n_windows"]
    pooled = sum(g["accuracy"] * g["n"] for g in by.values() if g["n"]) / res["n_windows"]
    assert pooled == pytest.approx(res["heads"]["texture"]["accuracy"])
    assert set(res["heads"]["motion"]["accuracy_by"]["texture"]) == {"rough", "smooth"}


def test_a_diverging_training_is_an_error_not_a_silent_run(tmp_path, action_file):
    cfg = tiny_config(model={"family": "fnn", "hidden": [8]},
                      optim={"optimizer": "sgd", "lr": 1e12, "grad_clip": 0, "epochs": 2})
    with pytest.raises(InputError, match="training diverged in epoch 1"):
        train(cfg, [action_file], tmp_path / "run")
    assert not (tmp_path / "run").exists()
    assert not list(tmp_path.glob(".run.*"))  # no temporary folder left behind


def test_predictions_are_the_same_bits_on_any_torch_thread_count():
    """Issue 30: torch splits a layer's reductions by its intra-op thread count (3 of 4,096
    regression outputs of this network differed between 1 and 3 threads), so
    :func:`predict` runs on one thread whatever the caller's count, and gives it back."""
    from tactile_cli.learn.data import WindowSet
    from tactile_cli.learn.heads import HeadSpec
    from tactile_cli.learn.models import build_model
    from tactile_cli.learn.train import predict

    window, n, c = 64, 4096, 4
    heads = [HeadSpec("action", "classification", "sample", classes=("a", "b", "c", "d")),
             HeadSpec("force", "regression", "sample")]
    torch.manual_seed(0)
    model = build_model(tiny_config(model={"family": "fnn", "hidden": [64, 64]}).model,
                        window=window, n_channels=c, heads=heads)
    x = np.random.default_rng(0).standard_normal((n * window, c)).astype(np.float32)
    ws = WindowSet(x=x, starts=np.arange(n) * window, window=window, targets={},
                   trial_index=np.zeros(n, dtype=np.int64), end_index=np.arange(n),
                   target_index=np.arange(n), target_t_s=np.arange(n) * 1e-3,
                   near_boundary={}, trials=["t"])
    previous = torch.get_num_threads()
    outputs = {}
    try:
        for threads in (1, 2, 3):
            torch.set_num_threads(threads)
            outputs[threads] = predict(model, ws)
            assert torch.get_num_threads() == threads
    finally:
        torch.set_num_threads(previous)
    assert outputs[1]["force"].shape == (n,) and outputs[1]["action"].shape == (n, 4)
    for threads in (2, 3):
        for head in ("action", "force"):
            np.testing.assert_array_equal(outputs[threads][head], outputs[1][head])
