"""Perturbations (exact on simple inputs), breaking points and `tactile perturb`."""

from __future__ import annotations

import json
import re
import shutil

import numpy as np
import pytest
from typer.testing import CliRunner

from tactile_cli.cli import app
from tactile_cli.errors import InputError
from tactile_cli.learn.perturb import (
    add_noise,
    breaking_index,
    directions,
    drop_samples,
    load_perturbation,
    lowpass,
    lowpass_cutoffs,
    perturb_evaluate,
    scale_time,
    thin_counts,
)
from tactile_cli.store.provenance import sha256_of

from .tiny_runs import tiny_runs

runner = CliRunner()


@pytest.fixture(scope="session")
def runs(tmp_path_factory, action_file, heldout_file):
    return tiny_runs(tmp_path_factory, action_file, heldout_file)


# -- the pure functions ----------------------------------------------------------------------
def test_noise_has_the_requested_snr_per_channel():
    t = np.arange(200_000) / 1000.0
    x = np.stack([np.sin(2 * np.pi * 5 * t), 300 + 40 * np.cos(2 * np.pi * 3 * t),
                  np.zeros_like(t)], axis=1)
    for snr_db in (20.0, 3.0, -6.0):
        y = add_noise(x, snr_db, seed=1)
        noise = y - x
        measured = 10 * np.log10((x[:, :2] ** 2).mean(axis=0) / (noise[:, :2] ** 2).mean(axis=0))
        # noise power estimated from 2e5 samples: standard error 0.014 dB
        np.testing.assert_allclose(measured, snr_db, atol=0.06)
        assert np.all(y[:, 2] == 0)  # a silent channel stays silent
        assert abs(noise[:, 0].mean()) < 0.01 * noise[:, 0].std()  # zero-mean
    np.testing.assert_array_equal(add_noise(x, 10, seed=3), add_noise(x, 10, seed=3))
    assert not np.array_equal(add_noise(x, 10, seed=3), add_noise(x, 10, seed=4))


def test_lowpass_cutoffs_halve_from_half_nyquist_and_remove_a_tone_above_the_cutoff():
    np.testing.assert_allclose(lowpass_cutoffs(50.0, 4), [12.5, 6.25, 3.125, 1.5625])
    # paper 001 sec. 6.4: 8 kHz recordings, seven halvings end at 31.25 Hz
    assert lowpass_cutoffs(8000.0)[-1] == 31.25
    fs = 1000.0
    t = np.arange(4000) / fs
    low, high = np.sin(2 * np.pi * 10 * t), 0.5 * np.sin(2 * np.pi * 200 * t)
    y = lowpass(np.stack([low + high, high], axis=1), 50.0, fs_hz=fs)
    mid = slice(500, 3500)  # away from the edges
    assert np.abs(y[mid, 0] - low[mid]).max() < 1e-3  # 10 Hz passes, 200 Hz is gone
    assert np.abs(y[mid, 1]).max() < 1e-3
    # the tone at the cut-off comes out at -6 dB (Butterworth applied twice, zero phase)
    at_cut = lowpass(np.sin(2 * np.pi * 50 * t)[:, None], 50.0, fs_hz=fs)
    assert abs(np.abs(at_cut[mid, 0]).max() - 0.5) < 0.01
    short = lowpass(np.ones((5, 1)), 50.0, fs_hz=fs)  # shorter than the default padding
    np.testing.assert_allclose(short, 1.0, atol=1e-9)
    with pytest.raises(ValueError, match="must be in \\(0, Nyquist = 500.0 Hz\\)"):
        lowpass(np.ones((10, 1)), 600.0, fs_hz=fs)


def test_thinning_keeps_p_times_the_counts_and_the_sign():
    counts = np.full((4000, 2), 1000.0)
    counts[:, 1] = -1000.0
    y = thin_counts(counts, 0.3, seed=0)
    assert y.shape == counts.shape
    # mean 300, standard error sqrt(1000 * 0.3 * 0.7) / sqrt(4000) = 0.23
    assert abs(y[:, 0].mean() - 300) < 1.0 and abs(y[:, 1].mean() + 300) < 1.0
    assert np.all(y[:, 0] >= 0) and np.all(y[:, 1] <= 0)
    assert np.all(y == np.round(y))
    np.testing.assert_array_equal(thin_counts(counts, 1.0, seed=0), counts)
    np.testing.assert_array_equal(thin_counts(counts, 0.0, seed=0), 0)
    with pytest.raises(ValueError, match="whole numbers"):
        thin_counts(np.full((3, 1), 0.5), 0.5, seed=0)


def test_dropped_samples_are_held_or_interpolated():
    x = np.arange(1000, dtype=np.float64)[:, None]
    y = drop_samples(x, 0.2, seed=5)
    changed = np.flatnonzero(y[:, 0] != x[:, 0])
    assert changed.size == 200  # exactly round(0.2 n) samples lost
    kept = np.setdiff1d(np.arange(1000), changed)
    # each lost sample shows the last received one (or the first, before any arrived)
    expect = np.where(np.arange(1000) >= kept[0],
                      kept[np.searchsorted(kept, np.arange(1000), side="right") - 1], kept[0])
    np.testing.assert_array_equal(y[:, 0], expect)
    more = drop_samples(x, 0.5, seed=5)
    assert set(changed) <= set(np.flatnonzero(more[:, 0] != x[:, 0]))  # nested lost sets
    lost = np.flatnonzero(drop_samples(x, 0.3, seed=2)[:, 0] != x[:, 0])
    kept = np.setdiff1d(np.arange(1000), lost)
    inner = lost[(lost > kept[0]) & (lost < kept[-1])]
    ramp = drop_samples(x, 0.3, seed=2, fill="interp")
    np.testing.assert_allclose(ramp[inner, 0], x[inner, 0])  # a ramp is linear
    np.testing.assert_array_equal(ramp[:, 0] != x[:, 0],
                                  np.isin(np.arange(1000), lost) & ~np.isin(np.arange(1000),
                                                                           inner))
    np.testing.assert_array_equal(drop_samples(x, 0.0, seed=1), x)


def test_time_scaling_preserves_label_proportions_and_counts():
    labels = np.repeat(np.array([0, 1, 2, 3], dtype=np.int8), [100, 200, 150, 50])
    x = np.stack([np.arange(500.0), np.full(500, 10.0)], axis=1)
    for factor in (0.5, 0.8, 1.5, 2.0):
        y, lab = scale_time(x, {"action": labels}, factor, conserve_sum=True)
        n_out = round(500 * factor)
        assert y.shape == (n_out, 2) and lab["action"].shape == (n_out,)
        assert lab["action"].dtype == np.int8
        counts = np.bincount(lab["action"], minlength=4)
        np.testing.assert_allclose(counts, factor * np.array([100, 200, 150, 50]), atol=1)
        assert np.all(np.diff(lab["action"]) >= 0)  # order of the actions kept
        assert abs(y[:, 1].sum() - 5000) <= 10 / factor  # events conserved within a bin
        ramp = y[:, 0] * factor  # undo the division: the ramp keeps its end points
        assert ramp[0] == pytest.approx(0, abs=1 / factor)
        assert ramp[-1] == pytest.approx(499, abs=1 / factor)
    same, lab1 = scale_time(x, {"action": labels}, 1.0)
    np.testing.assert_array_equal(same, x)
    np.testing.assert_array_equal(lab1["action"], labels)


def test_breaking_point_walks_from_mild_to_severe_in_each_direction():
    levels = [0.5, 0.8, 1.25, 2.0]
    d = directions("scale", levels)
    assert [(x.name, x.order) for x in d] == [("faster", (1, 0)), ("slower", (2, 3))]
    acc = [0.70, 0.95, 0.99, 0.60]
    assert breaking_index(acc, d[0].order, 0.9) == 0
    assert breaking_index(acc, d[1].order, 0.9) == 3
    noise = directions("noise", [0.0, 30.0, 10.0])
    assert noise[0].order == (1, 2, 0)  # 30 dB, 10 dB, 0 dB
    # a level that recovers after a failure does not move the breaking point
    assert breaking_index([0.95, 0.5, 0.97], (0, 1, 2), 0.9) == 1
    assert breaking_index([0.95, 0.96], (0, 1), 0.9) is None


# -- a real run ------------------------------------------------------------------------------
@pytest.mark.slow
def test_perturb_evaluate_finds_breaking_points_and_matches_evaluate(runs, heldout_file):
    run = runs["lstm"]
    before = sha256_of(heldout_file)
    res = perturb_evaluate(run, [heldout_file], ["noise", "lowpass", "drop", "scale"],
                           {"noise": [40, 10, -20], "drop": [0.1, 0.95],
                            "scale": [0.5, 1.25, 2.0]}, command="tests")
    assert sha256_of(heldout_file) == before  # in memory only
    clean = json.loads((run / "eval" / "heldout" / "metrics.json").read_text())["accuracy"]
    assert res.clean_accuracy == clean  # the same pipeline as `tactile evaluate`
    assert res.threshold == pytest.approx(0.9 * clean)
    assert [k.kind for k in res.kinds] == ["noise", "lowpass", "drop_events", "scale"]
    noise = res.kind("noise")
    acc = {lv.level: lv.accuracy for lv in noise.levels}
    assert acc[40] > res.threshold > acc[-20]  # -20 dB: the noise is 100 x the signal
    assert noise.breaking[0].level in (10.0, -20.0) and noise.breaking[0].last_ok == 40
    low = res.kind("lowpass")
    assert res.sample_rate_hz == pytest.approx(50.0)
    assert [lv.cutoff_hz for lv in low.levels] == pytest.approx(
        list(lowpass_cutoffs(50.0, 7)))
    assert low.breaking[0].level is not None  # 0.2 Hz keeps nothing of a 1 s action
    assert low.levels[-1].accuracy < res.threshold
    drop = res.kind("drop_events")
    assert drop.description.startswith("dropped events")
    assert [b.direction for b in res.kind("scale").breaking] == ["faster", "slower"]
    assert res.kind("scale").levels[0].n_windows < res.clean_n_windows  # half as long
    assert res.kind("scale").levels[-1].n_windows > res.clean_n_windows

    out = run / "perturb" / "heldout"
    assert {p.name for p in out.iterdir()} == {"perturb.json", "perturb.csv", "perturb.png"}
    again = load_perturbation(out)
    assert again.as_dict() == json.loads(json.dumps(res.as_dict()))
    assert again.command == "tests" and again.data[0]["sha256"] == before

    strict = perturb_evaluate(run, [heldout_file], ["noise"], {"noise": [30]}, threshold=1.0,
                              write=False)
    assert strict.clean_below_threshold and strict.threshold == 1.0
    assert strict.kinds[0].breaking[0].level == 30


def test_perturb_input_errors(runs, heldout_file):
    run = runs["fnn"]
    with pytest.raises(InputError, match="unknown perturbation kind 'blur'; choose from"):
        perturb_evaluate(run, [heldout_file], ["blur"], write=False)
    with pytest.raises(InputError, match="lowpass level 1 is not a cut-off as a fraction"):
        perturb_evaluate(run, [heldout_file], ["lowpass"], {"lowpass": [1.0]}, write=False)
    with pytest.raises(InputError, match="drop_events level 1 is not a fraction"):
        perturb_evaluate(run, [heldout_file], ["drop"], {"drop": [1.0]}, write=False)
    held = perturb_evaluate(run, [heldout_file], ["drop_samples"], {"drop": [0.0, 0.5]},
                            write=False)
    assert held.kinds[0].kind == "drop_samples"
    assert held.kinds[0].levels[0].accuracy == held.clean_accuracy  # 0 % lost: unchanged
    with pytest.raises(InputError, match="data file not found"):
        perturb_evaluate(run, [heldout_file.with_name("none.h5")], write=False)


@pytest.mark.slow
def test_cli_perturb(runs, heldout_file, tmp_path, monkeypatch):
    dirs = [str(runs["lstm"]), str(runs["mlp"])]
    # provenance records sys.argv; under CliRunner that is the test runner's, so give the
    # command line a shell would (`python -m pytest` passed by luck, `pytest` did not)
    monkeypatch.setattr("sys.argv", ["/usr/bin/tactile", "perturb", *dirs])
    res = runner.invoke(app, ["perturb", *dirs, "--data", str(heldout_file), "--kinds",
                              "noise,scale", "--levels", "noise=30,-20", "--levels",
                              "scale=0.5,2", "--out", str(tmp_path / "p"), "--name", "cli"])
    assert res.exit_code == 0, res.output
    assert "breaking point" in res.output and "-20 dB" in res.output
    assert (tmp_path / "p" / "perturb.png").read_bytes()[:4] == b"\x89PNG"
    combined = json.loads((tmp_path / "p" / "perturb.json").read_text())
    assert len(combined["results"]) == 2 and combined["command"].startswith("tactile")
    assert (runs["mlp"] / "perturb" / "cli" / "perturb.json").is_file()

    js = runner.invoke(app, ["perturb", dirs[0], "--data", str(heldout_file), "--kinds",
                             "noise", "--levels", "noise=0", "--threshold", "50%", "--json",
                             "--name", "cli-json"])
    assert js.exit_code == 0, js.output
    d = json.loads(js.stdout)
    assert d["threshold"] == 0.5 and d["threshold_rule"] == "absolute 0.5"

    missing = runner.invoke(app, ["perturb", str(tmp_path / "nope"), "--data",
                                  str(heldout_file)])
    assert missing.exit_code == 2
    assert missing.stderr == (f"tactile: error: {tmp_path / 'nope'}: run folder not found "
                              "(give the folder `tactile train` wrote)\n")
    bad = runner.invoke(app, ["perturb", dirs[0], "--data", str(heldout_file), "--levels",
                              "noise:30"])
    assert bad.exit_code == 2
    assert "--levels takes KIND=V1,V2,... (e.g. noise=30,20,10), got 'noise:30'" in bad.stderr
    thr = runner.invoke(app, ["perturb", dirs[0], "--data", str(heldout_file), "--threshold",
                              "high"])
    assert thr.exit_code == 2 and "--threshold must be a factor" in thr.stderr
    nodata = runner.invoke(app, ["perturb", dirs[0]])
    assert nodata.exit_code == 2 and "no data files; give --data FILE..." in nodata.stderr


def test_evaluate_perturb_delegates_to_perturb(runs, heldout_file):
    res = runner.invoke(app, ["evaluate", str(runs["mlp"]), "--data", str(heldout_file),
                              "--no-latency", "--perturb", "--perturb-kinds", "noise",
                              "--name", "eval-perturb", "--json"])
    assert res.exit_code == 0, res.output
    payload = json.loads(res.stdout)
    clean = payload["evaluation"]["accuracy"]
    assert payload["perturbation"]["clean_accuracy"] == pytest.approx(clean)
    written = runs["mlp"] / "perturb" / "eval-perturb"
    assert (written / "perturb.json").is_file()
    # the runs are shared: leave them as the report tests expect
    shutil.rmtree(written)
    shutil.rmtree(runs["mlp"] / "eval" / "eval-perturb")
    bad = runner.invoke(app, ["evaluate", str(runs["mlp"]), "--data", str(heldout_file),
                              "--perturb", "--threshold", "2x"])
    assert bad.exit_code == 2


@pytest.mark.parametrize("damage, message", [
    (lambda d: "not json{", "not valid JSON"),
    (lambda d: json.dumps([1, 2]), "not a JSON object"),
    (lambda d: json.dumps({**d, "kinds": "noise"}), "`kinds` must list"),
    (lambda d: json.dumps({**d, "kinds": [{**d["kinds"][0], "levels": [
        {**d["kinds"][0]["levels"][0], "accuracy": "high"}]}]}), "`accuracy` (='high')"),
    (lambda d: json.dumps({**d, "kinds": [{k: v for k, v in d["kinds"][0].items()
                                           if k != "level_name"}]}), "incomplete or mistyped"),
])
def test_a_damaged_perturb_json_is_one_error_naming_it(tmp_path, damage, message):
    record = {"format": "tactile-perturb", "run": "r", "label": "r", "family": "lstm",
              "name": "n", "split": "all", "data": [], "primary_head": "action",
              "n_trials": 1, "clean_accuracy": 0.9, "clean_macro_f1": 0.8,
              "clean_n_windows": 10, "threshold": 0.8, "threshold_rule": "0.9x", "seed": 0,
              "sample_rate_hz": 50.0, "kinds": [{
        "kind": "noise", "description": "noise", "level_name": "SNR (dB)",
        "levels": [{"level": 40.0, "accuracy": 0.9, "macro_f1": 0.8, "n_windows": 10}],
        "breaking": []}]}
    path = tmp_path / "perturb.json"
    path.write_text(json.dumps(record))
    assert load_perturbation(tmp_path).kinds[0].levels[0].accuracy == 0.9  # intact: read
    path.write_text(damage(record))
    with pytest.raises(InputError, match=re.escape(message)) as err:
        load_perturbation(tmp_path)
    assert "perturb.json" in str(err.value) and "\n" not in str(err.value)
