"""`tactile simulate marker-events`: the events follow the configured ground truth.

Small scenes (one group, two or three force levels) are simulated once per module; the
tests bin their events and compare with the expected rates, fit the ROI centroids during
slip, and check reproducibility, saturation, the output folder's atomicity and the CLI.
"""

from __future__ import annotations

import csv
import json
from pathlib import Path

import h5py
import numpy as np
import pytest
from typer.testing import CliRunner

from tactile_cli.cli import app
from tactile_cli.errors import InputError
from tactile_cli.fos.actions import expected_net_counts
from tactile_cli.ingest.sidecars import number_or_text
from tactile_cli.scene import (
    EVENT_DTYPE,
    MarkerSceneConfig,
    expected_rates,
    load_marker_scene_config,
    plan_trials,
    scene_layout,
    simulate_marker_events,
    slip_px_per_m,
)
from tactile_cli.store.origin import data_origin

REPO = Path(__file__).resolve().parents[2]
CONFIG = REPO / "configs" / "scene_marker_events.yaml"
runner = CliRunner()
SEED = 7


def _config(levels: list[int], groups: int = 1) -> MarkerSceneConfig:
    return MarkerSceneConfig().with_overrides(groups=groups, levels=levels)


def _read_csv(path: Path) -> list[dict[str, str]]:
    with open(path, newline="", encoding="utf-8") as f:
        return list(csv.DictReader(f))


@pytest.fixture(scope="module")
def scene(tmp_path_factory) -> tuple[MarkerSceneConfig, Path]:
    """Levels 1, 6, 12 of group 1 (level 12 saturates by default)."""
    config = _config([1, 6, 12])
    out = tmp_path_factory.mktemp("scene") / "scene"
    simulate_marker_events(config, out, seed=SEED, command="test")
    return config, out


def _binned(events: np.ndarray, bin_us: int, n_bins: int) -> dict[str, np.ndarray]:
    b = events["t"] // bin_us
    pos = np.bincount(b[events["p"] > 0], minlength=n_bins)
    neg = np.bincount(b[events["p"] < 0], minlength=n_bins)
    return {"positive": pos, "negative": neg, "net": pos - neg}


# -- config ---------------------------------------------------------------------------------
def test_config_file_repeats_the_built_in_defaults():
    assert load_marker_scene_config(CONFIG) == MarkerSceneConfig()


def test_default_config_has_the_papers_values():
    c = MarkerSceneConfig()
    assert (c.trials.groups, c.trials.n_levels) == (4, 12)
    assert c.fos.alpha_press_range == (1365.0, 2280.0)
    assert (c.fos.tau_press_s, c.fos.alpha_slip, c.fos.tau_slip_s) == (0.3, 1615.0, 0.325)
    assert (c.sensor.width_px, c.sensor.height_px) == (640, 480)
    assert (c.sensor.pixel_pitch_m, c.sensor.focal_length_m) == (9e-6, 3.6e-3)
    assert 0.004 in c.slip.speeds_m_s
    assert c.bin_s == 0.02


def test_unknown_config_key_names_the_key_file_and_line(tmp_path):
    bad = tmp_path / "bad.yaml"
    bad.write_text("fos:\n  tau_press_s: 0.3\n  alpha_slp: 1600\n")
    with pytest.raises(InputError) as err:
        load_marker_scene_config(bad)
    assert str(err.value).startswith(f"{bad}, line 3: unknown key `fos.alpha_slp` "
                                     "(allowed here: alpha_press_range,")


def test_geometry_error_names_the_key(tmp_path):
    bad = tmp_path / "bad.yaml"
    bad.write_text("strips:\n  rest_y_px: 100\n")
    with pytest.raises(InputError, match=r"strips: the strip ROIs span y -219\.\.125 px"):
        load_marker_scene_config(bad)


def test_press_duration_must_fit_the_press_region(tmp_path):
    bad = tmp_path / "bad.yaml"
    bad.write_text("timing:\n  press_duration_s: [0.3, 1.2]\n")
    with pytest.raises(InputError, match="`timing`: `press_duration_s` high"):
        load_marker_scene_config(bad)


# -- ground truth ---------------------------------------------------------------------------
def test_alpha_levels_spread_evenly_and_speeds_cover_every_group():
    config = MarkerSceneConfig().model_copy(update={
        "fos": MarkerSceneConfig().fos.model_copy(update={"alpha_press_jitter_rel": 0.0})})
    trials = plan_trials(config, seed=0)
    assert len(trials) == 48
    alphas = [t.params.alpha_press for t in trials if t.group == 1]
    np.testing.assert_allclose(alphas, np.linspace(1365, 2280, 12), atol=1e-3)
    assert [t.force_grade for t in trials[:12]] == [
        g for g in ["light", "small", "small medium", "medium", "small big", "big"]
        for _ in range(2)]
    for level in range(1, 13):
        speeds = {t.slip_speed_m_s for t in trials if t.force_level == level}
        assert speeds == {0.002, 0.003, 0.004, 0.005}
    px_per_m = slip_px_per_m(focal_length_m=3.6e-3, strip_distance_m=0.03, pixel_pitch_m=9e-6)
    assert px_per_m == pytest.approx(26666.667, rel=1e-6)
    for t in trials:
        assert t.slip_speed_px_s == pytest.approx(t.slip_speed_m_s * px_per_m, abs=1e-6)
        tl = t.timeline
        assert 0.3 <= tl.press_start_s <= 0.6
        assert 1.15 <= tl.slip_start_s - tl.press_start_s <= 1.25 + 1e-9
        assert 0.395 <= tl.press_duration_s <= 0.405 + 1e-9
        assert 1.8 <= tl.release_start_s - tl.slip_start_s <= 2.2 + 1e-9
        assert round(tl.end_s / 0.02, 9) == int(round(tl.end_s / 0.02))  # whole bins


def test_saturation_applies_to_the_configured_level_only(scene):
    config, out = scene
    rows = {r["trial"]: r for r in _read_csv(out / "trials.csv")}
    for trial in plan_trials(config, seed=SEED):
        rates = expected_rates(trial, config)
        linear = expected_net_counts(rates.t_s, trial.timeline, trial.params)
        cell = rows[trial.name]["saturation_limit"]
        if trial.force_level == 12:
            # r = alpha_1 / limit = 0.6 by default
            assert trial.saturation_limit == pytest.approx(trial.params.alpha_press / 0.6,
                                                           rel=1e-6)
            assert float(cell) == trial.saturation_limit
            assert rates.net.max() < trial.saturation_limit
            assert rates.net.max() < 0.8 * linear.max()  # visibly flattened
            events = np.load(out / f"{trial.name}.npy")
            observed = _binned(events, config.bin_us, rates.t_s.size)["net"]
            noise_sd = np.sqrt(rates.positive + rates.negative + 2 * rates.background).max()
            assert observed.max() < trial.saturation_limit + 5 * noise_sd
        else:
            assert trial.saturation_limit is None and cell == ""
            np.testing.assert_array_equal(rates.net, linear)


# -- events ---------------------------------------------------------------------------------
def test_events_are_sorted_in_bounds_and_typed(scene):
    config, out = scene
    for trial in plan_trials(config, seed=SEED):
        events = np.load(out / f"{trial.name}.npy")
        assert events.dtype == EVENT_DTYPE
        assert (np.diff(events["t"]) >= 0).all()
        assert events["t"][0] >= 0 and events["t"][-1] < round(trial.timeline.end_s * 1e6)
        assert events["x"].max() < 640 and events["y"].max() < 480
        assert set(np.unique(events["p"]).tolist()) == {-1, 1}


def test_binned_counts_follow_the_expected_curve_with_poisson_noise(scene):
    config, out = scene
    z_net, z_pos, z_neg = [], [], []
    for trial in plan_trials(config, seed=SEED):
        rates = expected_rates(trial, config)
        got = _binned(np.load(out / f"{trial.name}.npy"), config.bin_us, rates.t_s.size)
        bg = rates.background
        var_net = rates.positive + rates.negative + 2 * bg
        z_net.append((got["net"] - rates.net) / np.sqrt(var_net))
        z_pos.append((got["positive"] - rates.positive - bg) / np.sqrt(rates.positive + bg))
        z_neg.append((got["negative"] - rates.negative - bg) / np.sqrt(rates.negative + bg))
        # the signal is far above the noise: the curve, not the noise, dominates
        assert np.corrcoef(got["net"], rates.net)[0, 1] > 0.99
    for z in (np.concatenate(z_net), np.concatenate(z_pos), np.concatenate(z_neg)):
        n = z.size  # about 500 bins: sd of the mean 0.045, of the variance 0.063
        assert n > 400
        assert abs(z.mean()) < 4 / np.sqrt(n)
        assert 0.8 < z.var() < 1.2


def test_roi_centroid_moves_at_the_slip_speed(scene):
    """Least squares of event y on event time inside each ROI (the event-weighted
    centroid's trajectory): the slope is the strip velocity during the slip and zero while
    the press counts are high before it."""
    config, out = scene
    layout = scene_layout(config)
    for trial in plan_trials(config, seed=SEED):
        ev = np.load(out / f"{trial.name}.npy")
        tl = trial.timeline
        velocity = trial.slip_direction_y * trial.slip_speed_px_s
        t_s = ev["t"] * 1e-6
        for roi in layout.rois:
            inside = roi.contains(ev["x"], ev["y"]) & (ev["p"] > 0)
            # background events pull the centroid to the ROI centre where strip counts are
            # low, so the rest check uses the press pulse, when they are high
            for start_s, end_s, want in (
                    (tl.slip_start_s, tl.release_start_s, velocity),
                    (tl.press_start_s + 0.1, tl.press_start_s + tl.press_duration_s, 0.0)):
                keep = inside & (t_s >= start_s) & (t_s < end_s)
                t, y = t_s[keep], ev["y"][keep].astype(np.float64)
                dt = t - t.mean()
                slope = float(dt @ (y - y.mean()) / (dt @ dt))
                resid = y - y.mean() - slope * dt
                se = float(np.sqrt(resid @ resid / (t.size - 2) / (dt @ dt)))
                assert abs(slope - want) <= 4 * se + 0.01 * abs(velocity), (
                    trial.name, roi.name, start_s, slope, se)
                if want:
                    assert se < 0.01 * abs(velocity)  # the check has power


def test_annotations_and_trials_csv_agree(scene):
    config, out = scene
    trials = {t.name: t for t in plan_trials(config, seed=SEED)}
    rows = _read_csv(out / "trials.csv")
    assert [r["trial"] for r in rows] == list(trials)
    for row in rows:
        truth = trials[row["trial"]].row()
        for key, value in truth.items():
            assert number_or_text(row[key]) == ("" if value is None else value), key
        assert int(row["n_events"]) == np.load(out / f"{row['trial']}.npy").size
        assert (row["origin"], row["dataset"]) == ("simulated", f"marker-events seed {SEED}")
    ann = _read_csv(out / "annotations.csv")
    assert len(ann) == 4 * len(trials)
    for name, trial in trials.items():
        mine = [(float(a["start_s"]), float(a["end_s"]), a["label"]) for a in ann
                if a["trial"] == name]
        assert mine == trial.timeline.intervals()
    scene_json = json.loads((out / "scene.json").read_text())
    assert scene_json["seed"] == SEED and scene_json["command"] == "test"
    assert scene_json["sensor"]["strip_distance_m"] == 0.03
    assert [r["name"] for r in scene_json["rois"]] == ["strip1", "strip2", "strip3", "strip4"]
    assert scene_json["rois"][0] == {"name": "strip1", "x0_px": 125, "y0_px": 81,
                                     "x1_px": 155, "y1_px": 425}
    assert MarkerSceneConfig.model_validate(scene_json["config"]) == config


# -- reproducibility and output -------------------------------------------------------------
def _files(folder: Path) -> dict[str, bytes]:
    return {p.name: p.read_bytes() for p in sorted(folder.iterdir())}


def test_same_seed_same_bytes_other_seed_other_events(tmp_path):
    config = _config([2, 3])
    a = simulate_marker_events(config, tmp_path / "a", seed=3, command="c").out_dir
    b = simulate_marker_events(config, tmp_path / "b", seed=3, command="c").out_dir
    c = simulate_marker_events(config, tmp_path / "c", seed=4, command="c").out_dir
    assert _files(a) == _files(b)
    for name in ("g1_level02.npy", "g1_level03.npy", "trials.csv", "annotations.csv"):
        assert _files(a)[name] != _files(c)[name]
    # a trial is the same alone as in a bigger scene
    alone = simulate_marker_events(_config([3]), tmp_path / "d", seed=3, command="c").out_dir
    assert _files(alone)["g1_level03.npy"] == _files(a)["g1_level03.npy"]


def test_refuses_a_non_empty_folder_and_overwrites_atomically(tmp_path):
    config = _config([1])
    out = tmp_path / "scene"
    out.mkdir()  # an empty folder is fine
    simulate_marker_events(config, out, seed=0, command="c")
    before = _files(out)
    with pytest.raises(InputError, match="not empty; pass `overwrite=True`"):
        simulate_marker_events(config, out, seed=1, command="c")
    assert _files(out) == before
    (out / "stray.txt").write_text("old")
    simulate_marker_events(config, out, seed=1, command="c", overwrite=True)
    assert "stray.txt" not in _files(out) and _files(out) != before
    assert sorted(p.name for p in tmp_path.iterdir()) == ["scene"]  # no temporaries left


def test_failure_leaves_nothing(tmp_path, monkeypatch):
    from tactile_cli.scene import marker_events

    def boom(*args, **kwargs):
        raise RuntimeError("disk full")

    monkeypatch.setattr(marker_events, "_annotations_csv", boom)
    with pytest.raises(RuntimeError):
        simulate_marker_events(_config([1]), tmp_path / "scene", seed=0)
    assert list(tmp_path.iterdir()) == []


# -- CLI ------------------------------------------------------------------------------------
def test_cli_simulate_json_and_table(tmp_path):
    out = tmp_path / "s"
    result = runner.invoke(app, ["simulate", "marker-events", "--config", str(CONFIG),
                                 "--out", str(out), "--seed", "1", "--groups", "1",
                                 "--levels", "1-2", "--json"])
    assert result.exit_code == 0, result.output
    data = json.loads(result.stdout)
    assert data["n_trials"] == 2 and data["seed"] == 1
    assert data["n_events"] == sum(np.load(out / f"{t}.npy").size
                                   for t in ("g1_level01", "g1_level02"))
    table = runner.invoke(app, ["simulate", "marker-events", "--out", str(tmp_path / "t"),
                                "--groups", "1", "--levels", "12"])
    assert table.exit_code == 0 and "trials" in table.stdout
    for args in (["simulate", "--help"], ["simulate", "marker-events", "--help"]):
        assert runner.invoke(app, args).exit_code == 0


def test_cli_errors_are_one_line_exit_2(tmp_path):
    bad = tmp_path / "bad.yaml"
    bad.write_text("trials:\n  groupz: 2\n")
    result = runner.invoke(app, ["simulate", "marker-events", "--config", str(bad),
                                 "--out", str(tmp_path / "s")])
    assert result.exit_code == 2
    assert result.stderr.strip() == (
        f"tactile: error: {bad}, line 2: unknown key `trials.groupz` (allowed here: groups, "
        "n_levels, levels, force_grades)")
    result = runner.invoke(app, ["simulate", "marker-events", "--levels", "13",
                                 "--out", str(tmp_path / "s")])
    assert result.exit_code == 2
    assert "`levels` (=[13]) must be a non-empty list of levels between 1 and n_levels=12" \
        in result.stderr
    assert len(result.stderr.strip().splitlines()) == 1
    assert not (tmp_path / "s").exists()


def test_ingest_with_sidecars_round_trips_the_ground_truth(scene, tmp_path):
    config, out = scene
    h5 = tmp_path / "scene.h5"
    npys = sorted(str(p) for p in out.glob("*.npy"))
    result = runner.invoke(app, ["ingest", *npys, "--width", "640", "--height", "480",
                                 "--annotations", str(out / "annotations.csv"),
                                 "--trial-labels", str(out / "trials.csv"), "--out", str(h5)])
    assert result.exit_code == 0, result.output
    assert data_origin([h5])["kind"] == "simulated"  # the convention of store/origin.py
    rows = _read_csv(out / "trials.csv")
    ann = _read_csv(out / "annotations.csv")
    with h5py.File(h5) as f:
        for row in rows:
            g = f["trials"][row["trial"]]
            events = np.load(out / f"{row['trial']}.npy")
            np.testing.assert_array_equal(g["events/t"][()], events["t"])
            np.testing.assert_array_equal(g["events/y"][()], events["y"])
            assert int(g["events"].attrs["t_origin_us"]) == 0
            labels = {k: (v.item() if isinstance(v, np.generic) else v)
                      for k, v in g["labels"].attrs.items()}
            want = {k: number_or_text(v) for k, v in row.items() if k != "trial" and v != ""}
            assert labels == want
            assert isinstance(labels["force_level"], int) and labels["force_grade"] in (
                "light", "small medium", "big")
            assert labels["origin"] == "simulated"
            mine = [(float(a["start_s"]), float(a["end_s"]), a["label"]) for a in ann
                    if a["trial"] == row["trial"]]
            got = list(zip(g["annotations/start_s"][()].tolist(),
                           g["annotations/end_s"][()].tolist(),
                           g["annotations/label"].asstr()[()].tolist(), strict=True))
            assert got == mine
