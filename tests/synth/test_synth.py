"""`tactile synth`: model-based trajectories (paper 000, sec. 5.1) in the schema, from a
fits file or from the config's paper values; deterministic with --seed."""

from __future__ import annotations

import json
from pathlib import Path

import h5py
import numpy as np
import pytest
import yaml
from typer.testing import CliRunner

from tactile_cli.cli import app
from tactile_cli.errors import InputError
from tactile_cli.fos.actions import expected_net_counts
from tactile_cli.store import StoreWriter, validate_file
from tactile_cli.synth import (
    SynthConfig,
    draw_trial,
    from_config,
    from_fits,
    load_synth_config,
    noisy_net_counts,
    synthesize,
)
from tactile_cli.vocabulary import ACTIONS

REPO = Path(__file__).resolve().parents[2]
runner = CliRunner()


def _datasets(path) -> dict:
    """Every dataset and every label/annotation value of a file (not the creation time)."""
    out = {}
    with h5py.File(path) as h5:
        def visit(name, obj):
            if isinstance(obj, h5py.Dataset) and not name.startswith("provenance"):
                out[name] = obj[()]
            if name.endswith("labels") and isinstance(obj, h5py.Group):
                out[name + "@"] = dict(obj.attrs)
        h5.visititems(visit)
    return out


def test_shipped_config_is_the_defaults():
    assert load_synth_config(REPO / "configs" / "synth_fos.yaml") == SynthConfig()


def test_config_errors_name_the_key_and_line(tmp_path):
    bad = tmp_path / "bad.yaml"
    bad.write_text("bin_s: 0.02\ntiming:\n  slip_s: [0.8, 1.2]\n  slip_len: 3\n")
    with pytest.raises(InputError) as exc:
        load_synth_config(bad)
    assert str(exc.value) == (f"{bad}, line 4: unknown key `timing.slip_len`; see "
                              "configs/synth_fos.yaml for the keys")
    bad.write_text("timing:\n  slip_s: [1.2, 0.8]\n")
    with pytest.raises(InputError, match=r"line 2: `timing.slip_s`: `slip_s` \(=\[1.2, 0.8\]\)"):
        load_synth_config(bad)


@pytest.mark.slow
def test_same_seed_same_file_and_the_layout(tmp_path):
    a, b, c = tmp_path / "a.h5", tmp_path / "b.h5", tmp_path / "c.h5"
    for out, seed in ((a, 0), (b, 0), (c, 1)):
        result = runner.invoke(app, ["synth", "--n", "12", "--seed", str(seed), "--out",
                                     str(out)])
        assert result.exit_code == 0, result.output
    da, db, dc = _datasets(a), _datasets(b), _datasets(c)
    assert da.keys() == db.keys()
    for key in da:
        if key.endswith("@"):
            assert da[key] == db[key], key
        else:
            np.testing.assert_array_equal(da[key], db[key], err_msg=key)
    stream = "trials/synth_00000/signals/event_counts/data"
    assert not np.array_equal(da[stream], dc.get(stream, np.zeros(0)))

    assert validate_file(a).ok
    with h5py.File(a) as h5:
        assert list(h5["trials"])[:2] == ["synth_00000", "synth_00001"] and len(h5["trials"]) == 12
        sensor = h5["sensors/event_counts"]
        assert sensor.attrs["kind"] == "event_camera" and sensor.attrs["bin_s"] == 0.02
        assert (sensor.attrs["width_px"], sensor.attrs["height_px"]) == (640, 480)
        assert sensor.attrs["sample_rate_hz"] == 50.0
        assert sensor["channel_names"].asstr()[()].tolist() == ["net"]
        assert sensor["channel_units"].asstr()[()].tolist() == ["events/bin"]
        trial = h5["trials/synth_00003"]
        s = trial["signals/event_counts"]
        assert s["data"].dtype == np.float32 and s["data"].shape[1] == 1
        t_s = s["t_s"][()]
        np.testing.assert_allclose(np.diff(t_s), 0.02)
        assert t_s[0] == pytest.approx(0.01)
        action = s["sample_labels/action"]
        assert action.dtype == np.int8 and action.attrs["classes"].tolist() == list(ACTIONS)
        lab = dict(trial["labels"].attrs)
        assert 1 <= lab["force_level"] <= 12
        assert lab["force_grade"] == ["light", "small", "small medium", "medium", "small big",
                                      "big"][(lab["force_level"] - 1) // 2]
        # where the trials come from (tactile_cli.store.origin)
        assert lab["origin"] == "synthetic"
        assert lab["dataset"] == "synth seed 0 from the config's FOS values"
        ann = trial["annotations"]
        assert ann["label"].asstr()[()].tolist() == list(ACTIONS)
        starts = ann["start_s"][()]
        np.testing.assert_allclose(starts[1:], [lab["press_start_s"], lab["slip_start_s"],
                                                lab["release_start_s"]])
        # per-bin labels are the annotated regions at the bin centres
        expected = np.searchsorted(starts[1:], t_s, side="right")
        np.testing.assert_array_equal(action[()], expected)
        config = json.loads(h5.attrs["config_json"])
        assert config["seed"] == 0 and config["n"] == 12 and config["fits"] is None
        assert config["distributions"]["press"]["source"] == "config"


def test_counts_follow_the_model_with_poisson_like_noise():
    config = SynthConfig.model_validate({"initial": {"baseline_per_bin": [0, 0],
                                                     "state_per_bin": [0, 0]}})
    press, slip = from_config(config)
    trial = draw_trial(0, np.random.default_rng(0), config=config, press=press, slip=slip,
                       grades={})
    np.testing.assert_allclose(trial.expected, expected_net_counts(trial.t_s, trial.timeline,
                                                                   trial.params))
    assert 0.3 <= trial.timeline.press_start_s <= 0.6
    assert trial.timeline.press_duration_s == pytest.approx(trial.params.as_dict().get(
        "press_duration_s", trial.timeline.press_duration_s))
    with_state = SynthConfig.model_validate({"initial": {"baseline_per_bin": [3, 3],
                                                         "state_per_bin": [50, 50]}})
    other = draw_trial(0, np.random.default_rng(0), config=with_state, press=press, slip=slip,
                       grades={})
    np.testing.assert_allclose(other.expected - trial.expected,
                               3 + 50 * np.exp(-trial.t_s / trial.params.tau_press_s))
    # mean mu, variance k ((1 + 2 beta)|mu| + 2 background)
    mu = np.array([-500.0, 0.0, 30.0, 2000.0])
    rng = np.random.default_rng(1)
    for k in (1.0, 3.0):
        draws = noisy_net_counts(np.tile(mu, (20000, 1)), rng, background_per_bin=20.0,
                                 opposite_fraction=0.5, counting_scale=k)
        np.testing.assert_allclose(draws.mean(axis=0), mu, atol=4 * np.sqrt(k * 4000 / 20000))
        np.testing.assert_allclose(draws.var(axis=0), k * (2 * np.abs(mu) + 40), rtol=0.05)


def test_config_parameters_are_the_papers():
    press, slip = from_config(SynthConfig())
    np.testing.assert_allclose(np.exp(press.log_mean[[0, -1], 0]), [1365.0, 2280.0])
    np.testing.assert_allclose(np.exp(press.log_mean[:, 1]), 0.3)
    np.testing.assert_allclose(np.exp(slip.log_mean[0]), [1615.0, 0.325])
    rng = np.random.default_rng(0)
    draws = np.array([press.sample(12, rng)["alpha_press"] for _ in range(2000)])
    assert np.median(draws) == pytest.approx(2280.0, rel=0.01)
    assert np.std(np.log(draws)) == pytest.approx(0.02, rel=0.1)


def _fits_file(path, levels, alpha, tau, status, verdict=None, duration=None):
    """A file with trials labelled by force level and hand-written fits groups."""
    n = len(levels)
    with StoreWriter(path, command="test") as w:
        for i, level in enumerate(levels):
            w.trial(f"t{i}", labels={"force_level": int(level), "force_grade": f"g{level}"})
        w.commit()
    verdict = verdict if verdict is not None else ["first_order"] * n
    with h5py.File(path, "r+") as h5:
        for name, scale in (("fos_press", 1.0), ("fos_slip", 0.5)):
            g = h5.create_group(f"derived/fits/{name}")
            for key in ("command", "tool_version", "created_utc"):
                g.attrs[key] = "test"
            g.attrs["duration_fitted"] = duration is not None
            cols = {"alpha": np.asarray(alpha) * scale, "tau_s": np.asarray(tau),
                    "duration_s": np.asarray(duration if duration is not None else
                                             np.full(n, 0.4))}
            for c in ("alpha_se", "tau_se", "duration_se", "residual_std", "pearson_r", "aic",
                      "bic", "region_start_s", "region_end_s", "delta_bic"):
                cols[c] = np.zeros(n)
            cols["n_steps"] = cols["n_points"] = np.zeros(n, np.int64)
            for c, v in cols.items():
                g[c] = v
            string = h5py.string_dtype()
            g.create_dataset("trial", data=[f"t{i}" for i in range(n)], dtype=string)
            g.create_dataset("status", data=list(status), dtype=string)
            g.create_dataset("order_verdict", data=list(verdict), dtype=string)
    return path


def test_distributions_from_fits(tmp_path):
    # levels 1 and 3 fitted twice, level 2 not at all; one failed and one second-order fit
    levels = [1, 1, 3, 3, 3, 3]
    alpha = [1000.0, 1100.0, 2000.0, 2200.0, 5.0, 7.0]
    tau = [0.3, 0.33, 0.3, 0.33, 0.1, 0.1]
    status = ["converged"] * 4 + ["max_steps", "converged"]
    verdict = ["first_order"] * 5 + ["second_order"]
    path = _fits_file(tmp_path / "fits.h5", levels, alpha, tau, status, verdict,
                      duration=[0.35, 0.45, 0.4, 0.4, 0.4, 0.4])
    config = SynthConfig.model_validate({"levels": {"n_levels": 3,
                                                    "force_grades": ["a", "b", "c"]}})
    press, slip, grades = from_fits(path, config)
    assert press.names == ("alpha_press", "tau_press_s", "press_duration_s")
    assert press.n_fits.tolist() == [2, 0, 2]
    m1, m3 = np.log([1000, 1100]).mean(), np.log([2000, 2200]).mean()
    np.testing.assert_allclose(press.log_mean[:, 0], [m1, (m1 + m3) / 2, m3])
    np.testing.assert_allclose(slip.log_mean[:, 0], press.log_mean[:, 0] + np.log(0.5))
    # pooled within-level variance of log(alpha): two pairs, 4 fits - 2 levels
    pooled = (2 * (np.log(1100 / 1000) / 2) ** 2 + 2 * (np.log(2200 / 2000) / 2) ** 2) / 2
    assert press.log_cov[0, 0] == pytest.approx(pooled)
    assert grades == {1: "g1", 3: "g3"}
    # second-order fits are kept when asked to
    keep = SynthConfig.model_validate({"levels": {"n_levels": 3, "force_grades": ["a"]},
                                       "fits": {"exclude_second_order": False}})
    assert from_fits(path, keep)[0].n_fits.tolist() == [2, 0, 3]
    # the synthetic file records the fits file as its source
    out = tmp_path / "synth.h5"
    result = synthesize(out, n=5, seed=0, config=config, fits=path)
    assert result.press.source == "/derived/fits/fos_press"
    with h5py.File(out) as h5:
        assert h5["provenance/sources/path"].asstr()[()].tolist() == [str(path)]
        assert h5["trials/synth_00000"].attrs["source_index"].tolist() == [0]
        # the file's grade names where it has them, the config's for the level it lacks
        assert h5["trials/synth_00000/labels"].attrs["force_grade"] in ("g1", "b", "g3")


def test_fits_errors(tmp_path):
    path = tmp_path / "nofits.h5"
    with StoreWriter(path, command="test") as w:
        w.trial("t0", labels={"force_level": 1})
        w.commit()
    with pytest.raises(InputError) as exc:
        from_fits(path, SynthConfig())
    assert str(exc.value) == (f"{path}: no /derived/fits/fos_press; write it with "
                              f"`tactile fit-fos {path}`")
    result = runner.invoke(app, ["synth", "--fits", str(path), "--n", "3", "--out",
                                 str(tmp_path / "o.h5")])
    assert result.exit_code == 2 and "no /derived/fits/fos_press" in result.stderr
    assert not (tmp_path / "o.h5").exists()
    one_each = _fits_file(tmp_path / "single.h5", [1, 2], [1000.0, 1200.0], [0.3, 0.3],
                          ["converged"] * 2)
    with pytest.raises(InputError, match="no force level has two converged fits"):
        from_fits(one_each, SynthConfig())
    outside = _fits_file(tmp_path / "outside.h5", [13, 13], [1000.0, 1200.0], [0.3, 0.3],
                         ["converged"] * 2)
    with pytest.raises(InputError, match="force_level 13, outside 1..12"):
        from_fits(outside, SynthConfig())


def test_cli_options(tmp_path):
    out = tmp_path / "s.h5"
    cfg = tmp_path / "cfg.yaml"
    cfg.write_text(yaml.safe_dump({"levels": {"levels": [1, 12]}, "noise": {
        "counting_scale": 2.0}}))
    result = runner.invoke(app, ["synth", "--n", "6", "--seed", "2", "--config", str(cfg),
                                 "--bin-ms", "10", "--out", str(out)])
    assert result.exit_code == 0, result.output
    assert "6 trials, parameters from the config's fos section" in result.stdout
    with h5py.File(out) as h5:
        assert h5["sensors/event_counts"].attrs["bin_s"] == pytest.approx(0.01)
        levels = {int(h5[f"trials/{t}/labels"].attrs["force_level"]) for t in h5["trials"]}
        assert levels <= {1, 12}
        data = np.concatenate([h5[f"trials/{t}/signals/event_counts/data"][()].ravel()
                               for t in h5["trials"]])
        assert np.all(data % 2 == 0)  # counting_scale 2: counts come in steps of 2
    result = runner.invoke(app, ["synth", "--n", "6", "--out", str(out)])
    assert result.exit_code == 2 and "pass --overwrite" in result.stderr


def test_synthetic_trials_fit_back_to_their_parameters(tmp_path):
    """synth -> fit-fos: the press parameters drawn for each trial come back (the slips of
    0.9-1.2 s are only determined to ~5 %, see tests/fos/test_regions.py)."""
    from tactile_cli.fos.protocol import fit_regions
    from tactile_cli.fos.regions import read_trial_regions

    from ..factories.fos_counts import use_test_compilation_cache

    use_test_compilation_cache()
    # press regions of 1.2-1.6 s and slips of 0.9-1.2 s: the shapes the fos tests compile
    config = SynthConfig.model_validate({
        "timing": {"press_after_s": [0.9, 1.1], "slip_s": [0.9, 1.2]},
        "initial": {"baseline_per_bin": [0, 0], "state_per_bin": [0, 0]}})
    out = tmp_path / "synth.h5"
    synthesize(out, n=12, seed=4, config=config)
    trials = read_trial_regions(out)
    assert {t.counts_from for t in trials} == {"signals/event_counts"}
    press = fit_regions(trials, regions=("press",), order=False)["press"]
    assert press.ok.all(), press.status
    for name, column in (("alpha_press", press.fit.alpha), ("tau_press_s", press.fit.tau_s),
                         ("press_duration_s", press.fit.duration_s)):
        truth = np.array([t.labels[name] for t in trials])
        assert np.mean(np.abs(column / truth - 1) <= 0.05) >= 0.95, name
