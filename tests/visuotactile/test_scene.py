"""The DIGIT-like renderer, the object shapes and `tactile simulate digit-press`."""

from __future__ import annotations

import csv
import json
from pathlib import Path

import numpy as np
import pytest
from PIL import Image
from typer.testing import CliRunner

from tactile_cli.cli import app
from tactile_cli.errors import InputError
from tactile_cli.visuotactile.config import DigitSceneConfig, load_digit_scene_config
from tactile_cli.visuotactile.render import (
    GelOptics,
    render_reference,
    render_rgb,
    surface_normals,
)
from tactile_cli.visuotactile.shapes import (
    OBJECT_NAMES,
    Texture,
    ball_cap,
    contact_radius_px,
    object_height,
)
from tactile_cli.visuotactile.simulate import read_truth, simulate_digit_press

runner = CliRunner()

#: A scene small enough for tests: 3 presses, 2 objects x 2 trials of 1.8 s at 15 Hz
#: (27 frames each).
SMALL = {
    "calibration": {"presses": 3},
    "trials": {"objects": ["hex_key_small", "box"], "per_object": 2, "duration_s": 1.8,
               "static_s": [1.2, 1.3], "slip_s": [0.3, 0.4], "frame_rate_hz": 15.0},
}


def small_config() -> DigitSceneConfig:
    return DigitSceneConfig.model_validate(SMALL)


@pytest.fixture(scope="module")
def scene(tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("digit") / "scene"
    simulate_digit_press(small_config(), out, seed=3)
    return out


def test_ball_cap_normals_are_the_sphere_normals() -> None:
    optics = GelOptics()
    centre, radius_mm, depth_mm = (150.3, 110.7), 3.0, 0.6
    height = ball_cap(optics, centre, radius_mm, depth_mm)
    normals = surface_normals(height, optics.px_per_mm)
    ys, xs = np.mgrid[0:optics.height_px, 0:optics.width_px]
    r_px = np.hypot(xs - centre[0], ys - centre[1])
    inner = r_px < contact_radius_px(optics, radius_mm, depth_mm) - 2  # central differences
    r_mm = r_px / optics.px_per_mm
    expected = np.stack([(xs - centre[0]) / optics.px_per_mm / radius_mm,
                         (ys - centre[1]) / optics.px_per_mm / radius_mm,
                         np.sqrt(radius_mm ** 2 - np.minimum(r_mm, radius_mm) ** 2) / radius_mm],
                        axis=-1)
    assert np.abs(normals[inner] - expected[inner]).max() < 2e-3
    far = r_px > contact_radius_px(optics, radius_mm, depth_mm) + 2
    assert np.array_equal(normals[far], np.broadcast_to([0, 0, 1], normals[far].shape))
    assert np.allclose(np.linalg.norm(normals, axis=-1), 1, atol=1e-6)
    # the ball's top is the indentation depth
    assert height.max() == pytest.approx(depth_mm, abs=1e-3)


def test_surface_normals_sign_convention() -> None:
    # height rising to the right (+x): the normal leans to -x; rising down (+y): to -y
    ramp = np.tile(np.arange(8, dtype=np.float64) * 0.1, (6, 1))  # 0.1 mm per px
    n = surface_normals(ramp, px_per_mm=10.0)  # slope 1 mm/mm
    assert np.allclose(n[..., 0], -1 / np.sqrt(2), atol=1e-6)
    assert np.allclose(n[..., 1], 0)
    n = surface_normals(ramp.T.copy(), px_per_mm=10.0)
    assert np.allclose(n[..., 1], -1 / np.sqrt(2), atol=1e-6)


def test_reference_is_uneven_and_contact_changes_colour() -> None:
    optics = GelOptics()
    ref = render_reference(optics).astype(int)
    # position-dependent lighting: red at the left edge, green at the right, blue below
    left, right = ref[:, :40].mean((0, 1)), ref[:, -40:].mean((0, 1))
    assert left[0] > right[0] + 20 and right[1] > left[1] + 20
    assert ref[-30:].mean((0, 1))[2] > ref[:30].mean((0, 1))[2] + 10
    pressed = render_rgb(ball_cap(optics, (160, 120), 3.0, 0.5), optics).astype(int)
    diff = np.abs(pressed - ref).sum(-1)
    ys, xs = np.mgrid[0:240, 0:320]
    r = np.hypot(xs - 160, ys - 120)
    assert (diff[r > 40] == 0).all()  # no noise given: untouched pixels unchanged
    assert diff[(r > 10) & (r < 20)].mean() > 20


def test_noise_has_the_given_std() -> None:
    optics = GelOptics(noise_std=3.0)
    a = render_reference(optics, rng=np.random.default_rng(0)).astype(float)
    b = render_reference(optics).astype(float)
    assert np.std(a - b) == pytest.approx(3.0, rel=0.05)


@pytest.mark.parametrize("name", OBJECT_NAMES)
def test_objects_shift_with_their_texture(name: str) -> None:
    optics = GelOptics()
    base = object_height(name, optics, centre_px=(150, 120), depth_mm=0.4, angle_deg=30,
                         rng=np.random.default_rng(5))
    moved = object_height(name, optics, centre_px=(150, 120), shift_px=(8.0, 0.0),
                          depth_mm=0.4, angle_deg=30, rng=np.random.default_rng(5))
    assert base.dtype == np.float32 and base.min() >= 0 and base.max() > 0.2
    # an 8 px shift to the right moves the same surface: compare away from the borders
    assert np.abs(moved[20:-20, 28:-20] - base[20:-20, 20:-28]).max() < 1e-4
    assert np.abs(moved - base).max() > 0.01


def test_texture_on_grid_equals_direct_evaluation() -> None:
    optics = GelOptics(width_px=40, height_px=30)
    tex = Texture(np.random.default_rng(1), n=7, wavelength_mm=(0.3, 1.0), rms_mm=0.02)
    ys, xs = np.mgrid[0:30, 0:40].astype(float)
    a = np.deg2rad(25.0)
    dx, dy = (xs - 12.5) / optics.px_per_mm, (ys - 9.0) / optics.px_per_mm
    direct = tex(np.cos(a) * dx + np.sin(a) * dy, -np.sin(a) * dx + np.cos(a) * dy)
    assert np.allclose(tex.on_grid(optics, (12.5, 9.0), 25.0), direct, atol=1e-12)


@pytest.mark.slow
def test_scene_layout_labels_and_truth(scene: Path) -> None:
    presses = sorted(p.name for p in (scene / "calibration").iterdir())
    assert presses == ["ball_00", "ball_01", "ball_02"]
    assert {p.name for p in (scene / "calibration" / "ball_01").iterdir()} == {
        "reference.png", "frame_0000.png", "timestamps.csv"}
    with open(scene / "trial_labels.csv", newline="") as fh:
        rows = list(csv.DictReader(fh))
    assert [r["trial"] for r in rows] == ["hex_key_small_00", "hex_key_small_01", "box_00",
                                          "box_01"]
    assert [r["slip"] for r in rows] == ["no_slip", "slip", "no_slip", "slip"]
    assert rows[0]["slip_onset_s"] == "" and rows[0]["direction"] == "none"
    for r in rows:
        assert r["origin"] == "simulated"
        if r["slip"] == "slip":
            assert float(r["slip_onset_s"]) >= 1.2
    trial = scene / "trials" / "box_01"
    frames = sorted(trial.glob("frame_*.png"))
    assert len(frames) == 27
    image = np.asarray(Image.open(frames[0]))
    assert image.shape == (240, 320, 3) and image.dtype == np.uint8
    times = (trial / "timestamps.csv").read_text().split()
    assert times[0] == "t_s" and float(times[16]) == pytest.approx(1.0)
    truth = read_truth(scene / "truth" / "box_01.npz")
    assert truth["height_mm"].shape == (27, 240, 320)
    assert truth["height_mm"].dtype == np.float32
    onset = float(rows[3]["slip_onset_s"])
    t = truth["t_s"]
    moving = np.abs(np.diff(truth["shift_px"], axis=0)).sum(1) + np.abs(
        np.diff(truth["angle_deg"])) > 1e-9
    # nothing moves before the labelled onset, and something does after it
    assert not moving[t[1:] <= onset].any() and moving[t[1:] > onset].any()
    press = read_truth(scene / "truth" / "ball_02.npz")
    with open(scene / "calibration_labels.csv", newline="") as fh:
        calib = {r["trial"]: r for r in csv.DictReader(fh)}
    assert float(calib["ball_02"]["true_centre_x_px"]) == pytest.approx(press["centre_px"][0])
    assert float(calib["ball_02"]["true_contact_radius_px"]) == pytest.approx(
        float(press["radius_px"]), abs=1e-3)
    meta = json.loads((scene / "scene.json").read_text())
    assert meta["seed"] == 3 and meta["optics"]["px_per_mm"] == 16.0


@pytest.mark.slow
def test_same_seed_same_bytes_other_seed_other_lighting(scene: Path, tmp_path: Path) -> None:
    cfg = small_config().with_overrides(per_object=1, objects=["hex_key_small"])
    a = simulate_digit_press(cfg, tmp_path / "a", seed=3)
    simulate_digit_press(cfg, tmp_path / "b", seed=4)
    for rel in ("calibration/ball_01/frame_0000.png", "trials/hex_key_small_00/frame_0010.png"):
        assert (a.out_dir / rel).read_bytes() == (scene / rel).read_bytes()
    ref_a = np.asarray(Image.open(tmp_path / "a/trials/hex_key_small_00/reference.png"), float)
    ref_b = np.asarray(Image.open(tmp_path / "b/trials/hex_key_small_00/reference.png"), float)
    assert np.abs(ref_a - ref_b).mean() > 2  # another seed, another unit's lighting


@pytest.mark.slow
def test_ingest_reads_the_scene(scene: Path, tmp_path: Path) -> None:
    from tactile_cli.store.trials import TactileFile

    out = tmp_path / "trials.h5"
    res = runner.invoke(app, ["ingest", str(scene / "trials"), "--trial-labels",
                              str(scene / "trial_labels.csv"), "--px-per-mm", "16",
                              "--out", str(out), "--no-progress"])
    assert res.exit_code == 0, res.output
    with TactileFile(out) as f:
        assert f.trial_names == ["box_00", "box_01", "hex_key_small_00", "hex_key_small_01"]
        trial = f.trial("box_01")
        assert trial.labels["slip"] == "slip" and trial.labels["object"] == "box"
        frames = trial.frames()
        assert len(frames) == 27
        assert f.sensor(frames.sensor_name).attrs["px_per_mm"] == 16.0
        png = np.asarray(Image.open(scene / "trials/box_01/frame_0005.png"))
        assert np.array_equal(frames[5], png)


def test_cli_writes_a_scene_and_prints_json(tmp_path: Path) -> None:
    cfg = tmp_path / "scene.yaml"
    cfg.write_text("calibration: {presses: 2}\ntrials: {per_object: 0}\n")
    res = runner.invoke(app, ["simulate", "digit-press", str(tmp_path / "s"), "--config",
                              str(cfg), "--seed", "1", "--json", "--no-progress"])
    assert res.exit_code == 0, res.output
    summary = json.loads(res.output)
    assert summary["n_calibration_presses"] == 2 and summary["n_trials"] == 0
    assert len(summary["ingest"]) == 1 and "--px-per-mm 16" in summary["ingest"][0]
    # --calibration-presses and --out override
    res = runner.invoke(app, ["simulate", "digit-press", "--out", str(tmp_path / "t"),
                              "--config", str(cfg), "--calibration-presses", "1",
                              "--no-progress"])
    assert res.exit_code == 0, res.output
    assert "1 calibration presses" in res.output


def test_cli_errors_are_one_line(tmp_path: Path) -> None:
    res = runner.invoke(app, ["simulate", "digit-press", str(tmp_path / "a"), "--out",
                              str(tmp_path / "b")])
    assert res.exit_code == 2 and "give the output folder once" in res.output
    res = runner.invoke(app, ["simulate", "digit-press", str(tmp_path / "a"), "--objects",
                              "cable,spoon"])
    assert res.exit_code == 2 and "spoon" in res.output and "Traceback" not in res.output
    bad = tmp_path / "bad.yaml"
    bad.write_text("trials: {per_object: 2, colour: red}\n")
    res = runner.invoke(app, ["simulate", "digit-press", str(tmp_path / "a"), "--config",
                              str(bad)])
    assert res.exit_code == 2 and "colour" in res.output and "bad.yaml" in res.output
    assert not (tmp_path / "a").exists()


def test_config_refuses_a_short_static_grip(tmp_path: Path) -> None:
    path = tmp_path / "c.yaml"
    path.write_text("trials:\n  static_s: [0.5, 1.0]\n")
    with pytest.raises(InputError, match="1.2 s"):
        load_digit_scene_config(path)


def test_help() -> None:
    res = runner.invoke(app, ["simulate", "digit-press", "--help"])
    assert res.exit_code == 0 and "--calibration-presses" in res.output


def test_shipped_config_repeats_the_defaults() -> None:
    repo = Path(__file__).resolve().parents[2]
    shipped = load_digit_scene_config(repo / "configs" / "scene_digit_press.yaml")
    assert shipped == DigitSceneConfig()


def test_held_grip_drifts_slowly() -> None:
    from tactile_cli.visuotactile.simulate import slow_drift

    drift = slow_drift(np.random.default_rng(0), 20_000)
    assert drift.std() == pytest.approx(1.0, rel=0.1)
    # frame-to-frame steps are a small part of the drift: no white jitter in a held grip
    assert np.abs(np.diff(drift)).mean() < 0.1
