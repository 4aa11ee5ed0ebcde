"""The closed-loop avoidance scene and `tactile monitor` on it (paper 002, sec. V,
Figs. 13-14): a small scene (160 x 120 px at 8 px/mm, one box, three pushes) is simulated
once, ingested, and replayed."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

from tactile_cli.cli import app
from tactile_cli.visuotactile.avoidance import (
    AvoidanceConfig,
    interference_times,
    load_avoidance_config,
    simulate_digit_avoidance,
)
from tactile_cli.visuotactile.config import OpticsConfig
from tactile_cli.visuotactile.monitor import replay
from tactile_cli.visuotactile.signals import moving_flags

runner = CliRunner()
SEED = 4


def small_config(**kw) -> AvoidanceConfig:
    base = {"objects": ["box"], "interferences": 3, "squeeze_mm": 1.0, "static_s": 1.2,
            "gap_s": (3.9, 4.0), "tail_s": 3.5}
    return AvoidanceConfig(optics=OpticsConfig(width_px=160, height_px=120, px_per_mm=8.0),
                           **{**base, **kw})


@pytest.fixture(scope="module")
def scene(tmp_path_factory):
    root = tmp_path_factory.mktemp("avoid")
    out = root / "scene"
    cfg_path = root / "scene.yaml"
    cfg_path.write_text(json.dumps(small_config().model_dump(mode="json")))  # YAML superset
    res = runner.invoke(app, ["simulate", "digit-avoidance", str(out), "--config",
                              str(cfg_path), "--seed", str(SEED), "--json"])
    assert res.exit_code == 0, res.output
    h5 = root / "avoid.h5"
    res = runner.invoke(app, ["ingest", str(out / "trials"), "--trial-labels",
                              str(out / "trial_labels.csv"), "--annotations",
                              str(out / "annotations.csv"), "--px-per-mm", "8",
                              "--out", str(h5)])
    assert res.exit_code == 0, res.output
    return out, h5, json.loads((out / "scene.json").read_text())


@pytest.mark.slow
def test_layout_labels_and_truth(scene):
    out, _, meta = scene
    trial = meta["trials"][0]
    folder = out / "trials" / trial["trial"]
    n = trial["n_frames"]
    assert len(list(folder.glob("frame_*.png"))) == n and (folder / "reference.png").exists()
    assert (folder / "timestamps.csv").read_text().count("\n") == n + 1
    labels = (out / "trial_labels.csv").read_text().splitlines()
    assert labels[0].split(",")[:3] == ["trial", "origin", "dataset"]
    assert ";".join(f"{x:.6f}" for x in trial["interference_s"]) in labels[1]
    with np.load(out / "truth" / f"{trial['trial']}.npz", allow_pickle=False) as z:
        assert z["height_mm"].shape == (n, 120, 160)
        np.testing.assert_allclose(z["interference_s"], trial["interference_s"])
        # the per-frame flags are the annotation intervals, by the documented rule
        np.testing.assert_array_equal(z["gripper_moving"],
                                      moving_flags(z["t_s"], trial["gripper_moving_s"]))
        # a raised grip presses deeper: depth during slip mode above the normal grip
        raise_t = [e["t_s"] for e in trial["events"] if e["kind"] == "raise_grip"]
        k = int(np.searchsorted(z["t_s"], raise_t[0] + 1.0))
        assert z["depth_mm"][k] > 0.45 + 0.25
    # second push 1.6 s after the first (in slip mode: a timer restart), as configured
    assert trial["interference_s"][1] - trial["interference_s"][0] == pytest.approx(1.6)


def test_live_monitor_caught_every_push_and_ignored_the_release_peaks(scene):
    out, _, meta = scene
    trial = meta["trials"][0]
    ev = trial["events"]
    onsets = trial["interference_s"]
    raises = [e["t_s"] for e in ev if e["kind"] == "raise_grip"]
    releases = [e["t_s"] for e in ev if e["kind"] == "release_grip"]
    restarts = [e["t_s"] for e in ev if e["kind"] == "timer_restart"]
    # pushes 1 and 3 start slip episodes, push 2 restarts the timer; each caught in 0.2 s
    assert len(raises) == 2 and len(releases) == 2
    assert 0 <= raises[0] - onsets[0] <= 0.2 and 0 <= raises[1] - onsets[2] <= 0.2
    assert restarts and 0 <= restarts[0] - onsets[1] <= 0.2
    # release hold_s after the last judged slip
    assert releases[0] == pytest.approx(max(restarts) + 3.0, abs=0.04)
    with np.load(out / "truth" / f"{trial['trial']}.npz", allow_pickle=False) as z:
        s, t = z["live_signal"], z["t_s"]
    thr = trial["threshold"]
    for rel in releases:  # the second peak of each pair is above threshold ...
        window = (t > rel) & (t <= rel + 0.3 + 1e-9)
        assert s[window].max() > thr
        ignored = [e["t_s"] for e in ev if e["kind"] == "ignored_moving"
                   and rel < e["t_s"] <= rel + 0.3 + 1e-9]
        assert ignored  # ... and ignored by the manager, never a slip
    slips = [e["t_s"] for e in ev if e["kind"] in ("slip", "timer_restart")]
    assert all(not (rel < ts <= rel + 0.5) for rel in releases for ts in slips)
    # without the manager the same signal takes the release peak for a slip
    bare = replay(s, t, threshold=thr, motion_s=0.0)
    for rel in releases:
        assert any(rel < ts <= rel + 0.3 + 1e-9 for ts in bare.slip_times_s)


def test_replay_of_the_written_frames_matches_the_live_monitor(scene):
    _, h5, meta = scene
    res = runner.invoke(app, ["monitor", str(h5), "--json"])
    assert res.exit_code == 0, res.output
    got = json.loads(res.output)
    live = meta["trials"][0]
    trial = got["trials"][0]
    assert trial["motion_from"] == "annotations"
    assert trial["threshold"] == pytest.approx(live["threshold"], rel=1e-9)
    assert [(e["frame"], e["kind"]) for e in trial["events"]] == [
        (e["frame"], e["kind"]) for e in live["events"]]
    assert trial["score"] == {"n_interferences": 3, "caught": 3, "missed": 0,
                              "false_slips": 0, "delays_s": trial["score"]["delays_s"]}
    assert all(0 <= d <= 0.2 for d in trial["score"]["delays_s"])
    assert got["totals"]["detection_rate"] == 1.0


@pytest.mark.slow
def test_monitor_reads_the_scene_folder_as_a_stream_of_frames(scene):
    out, h5, _ = scene
    from_file = json.loads(runner.invoke(app, ["monitor", str(h5), "--json"]).output)
    res = runner.invoke(app, ["monitor", str(out), "--json"])
    assert res.exit_code == 0, res.output
    from_folder = json.loads(res.output)
    assert from_folder["file"] == str(out)
    assert from_folder["trials"] == from_file["trials"]
    # one image-sequence folder alone: no labels, no annotations, same signal
    res = runner.invoke(app, ["monitor", str(next((out / "trials").iterdir())), "--json"])
    alone = json.loads(res.output)["trials"][0]
    assert alone["interference_s"] is None and alone["motion_from"] == "motion_s"
    assert alone["threshold"] == from_file["trials"][0]["threshold"]


@pytest.mark.slow
def test_monitor_text_output_plot_and_motion_model(scene, tmp_path):
    _, h5, _ = scene
    res = runner.invoke(app, ["monitor", str(h5), "--plot", str(tmp_path / "plots"),
                              "--mesh", "16x12", "--hold-s", "2"])
    assert res.exit_code == 0, res.output
    assert "raise_grip" in res.output and "release_grip" in res.output
    assert "interferences caught" in res.output
    png = next((tmp_path / "plots").glob("*.png"))
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    # another command's figure in the folder stays; --overwrite empties the folder first
    (tmp_path / "plots" / "other.png").write_bytes(b"x")
    res = runner.invoke(app, ["monitor", str(h5), "--plot", str(tmp_path / "plots"),
                              "--mesh", "16x12"])
    assert res.exit_code == 0, res.output
    assert (tmp_path / "plots" / "other.png").exists() and png.exists()
    res = runner.invoke(app, ["monitor", str(h5), "--plot", str(tmp_path / "plots"),
                              "--mesh", "16x12", "--overwrite"])
    assert res.exit_code == 0, res.output
    assert not (tmp_path / "plots" / "other.png").exists() and png.exists()


def test_monitor_refuses_a_plot_path_that_is_a_file_before_replaying(scene, tmp_path,
                                                                     monkeypatch):
    _, h5, _ = scene
    import tactile_cli.visuotactile.monitor_replay as replay

    def never(*a, **k):
        raise AssertionError("replayed before the --plot check")

    monkeypatch.setattr(replay, "monitor_file", never)
    (tmp_path / "f").write_text("x")
    res = runner.invoke(app, ["monitor", str(h5), "--plot", str(tmp_path / "f")])
    assert res.exit_code == 2, res.output
    assert "is a file; give a folder for the output" in res.output


@pytest.mark.parametrize("args, message", [
    (["--source", "colour"], "--source (='colour') is not one of intensity, height"),
    (["--source", "height"], "pass --model"),
    (["--mesh", "32by24"], "must be COLSxROWS"),
    (["--n-static", "1000"], "needs 1000 static slip signals"),
    (["--trial", "nope"], "nope"),
])
def test_monitor_bad_input_is_one_line_exit_2(scene, args, message):
    _, h5, _ = scene
    res = runner.invoke(app, ["monitor", str(h5), *args])
    assert res.exit_code == 2, res.output
    assert message in res.output and "Traceback" not in res.output


def test_monitor_missing_file(tmp_path):
    res = runner.invoke(app, ["monitor", str(tmp_path / "none.h5")])
    assert res.exit_code == 2 and "file not found" in res.output


@pytest.mark.slow
def test_simulate_same_seed_same_bytes_and_refuses_existing(tmp_path):
    cfg = small_config(interferences=1, repeat_after_s=None)
    a = simulate_digit_avoidance(cfg, tmp_path / "a", seed=2)
    b = simulate_digit_avoidance(cfg, tmp_path / "b", seed=2)
    name = a.trials[0].name
    for rel in (f"trials/{name}/frame_0040.png", "annotations.csv", "trial_labels.csv"):
        assert (tmp_path / "a" / rel).read_bytes() == (tmp_path / "b" / rel).read_bytes()
    assert [e.as_dict() for e in a.trials[0].events] == [e.as_dict() for e in b.trials[0].events]
    res = runner.invoke(app, ["simulate", "digit-avoidance", str(tmp_path / "a")])
    assert res.exit_code == 2 and "--overwrite" in res.output


@pytest.mark.slow
def test_config_file_and_validation(tmp_path):
    assert load_avoidance_config(Path("configs/scene_digit_avoidance.yaml")) == AvoidanceConfig()
    bad = tmp_path / "bad.yaml"
    bad.write_text("gap_s: [3.0, 4.0]\n")
    res = runner.invoke(app, ["simulate", "digit-avoidance", str(tmp_path / "o"), "-c", str(bad)])
    assert res.exit_code == 2 and "gap_s" in res.output
    bad.write_text("holds: 3\n")
    res = runner.invoke(app, ["simulate", "digit-avoidance", str(tmp_path / "o"), "-c", str(bad)])
    assert res.exit_code == 2 and "holds" in res.output
    res = runner.invoke(app, ["simulate", "digit-avoidance", str(tmp_path / "o"),
                              "--object", "banana"])
    assert res.exit_code == 2 and "banana" in res.output and not (tmp_path / "o").exists()
    onsets = interference_times(AvoidanceConfig(), np.random.default_rng(0))
    assert onsets.size == 5 and onsets[0] >= 1.6
    assert np.all(np.diff(onsets)[1:] >= 4.6) and np.diff(onsets)[0] == pytest.approx(1.6)


def test_help():
    for cmd in (["monitor", "--help"], ["simulate", "digit-avoidance", "--help"]):
        res = runner.invoke(app, cmd)
        assert res.exit_code == 0 and "Usage" in res.output


@pytest.mark.slow
@pytest.mark.parametrize("stride", [1, 2])
def test_monitor_height_source_with_a_trained_normal_model(tmp_path_factory, tmp_path,
                                                           stride):
    """--source height: frames through a (small) trained normal network and the Poisson
    solve (every pixel, or 2 x 2 blocks: --stride 2); the slip trials' slides are caught,
    the still trials give no false slip."""
    from tests.factories.gel_frames import make_frames_file, normal_run

    run = normal_run(tmp_path_factory.getbasetemp() / "normal_runs")
    h5 = tmp_path / "frames.h5"
    make_frames_file(h5, n_trials=2, n_frames=60, onset_frame=40, speed_px=2.0)
    res = runner.invoke(app, ["monitor", str(h5), "--source", "height", "--model", str(run),
                              "--mesh", "16x12", "--stride", str(stride), "--json"])
    assert res.exit_code == 0, res.output
    got = json.loads(res.output)
    assert got["source"] == "height"
    slip, still = got["trials"]  # t_00 slips from frame 40, t_01 holds still
    # the factory's slide lasts to the end and has no slip_end_s: later restarts of the
    # same slide count as false slips, so only the catch is checked there
    assert slip["score"]["caught"] == 1 and slip["score"]["missed"] == 0
    assert 40 <= next(e["frame"] for e in slip["events"] if e["kind"] == "slip") <= 42
    assert still["score"] == {"n_interferences": 0, "caught": 0, "missed": 0,
                              "false_slips": 0, "delays_s": []}
