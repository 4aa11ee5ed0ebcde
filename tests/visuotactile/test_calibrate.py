"""Calibration labels (paper 002, sec. II-B): contact circles, sphere normals, the pixel
table of `tactile normal-labels`, and the normal MLP trained on it through `tactile train`."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

from tactile_cli.cli import app
from tactile_cli.store.trials import TactileFile
from tactile_cli.visuotactile.calibrate import (
    PIXEL_CHANNELS,
    find_contact_circle,
    normal_rmse,
    sphere_normals,
)
from tactile_cli.visuotactile.config import DigitSceneConfig
from tactile_cli.visuotactile.render import GelOptics, render_reference, render_rgb
from tactile_cli.visuotactile.shapes import ball_cap, contact_radius_px
from tactile_cli.visuotactile.simulate import simulate_digit_press

runner = CliRunner()
REPO = Path(__file__).resolve().parents[2]


def _calibration_file(folder: Path, seed: int, presses: int, *, px_per_mm: bool = True) -> Path:
    cfg = DigitSceneConfig.model_validate({"calibration": {"presses": presses},
                                      "trials": {"per_object": 0}})
    scene = folder / f"scene{seed}"
    simulate_digit_press(cfg, scene, seed=seed)
    out = folder / f"calib{seed}{'' if px_per_mm else '_noscale'}.h5"
    args = ["ingest", str(scene / "calibration"), "--trial-labels",
            str(scene / "calibration_labels.csv"), "--out", str(out), "--no-progress"]
    res = runner.invoke(app, args + (["--px-per-mm", "16"] if px_per_mm else []))
    assert res.exit_code == 0, res.output
    return out


@pytest.fixture(scope="module")
def files(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    root = tmp_path_factory.mktemp("calib")
    train = _calibration_file(root, 10, 10)
    test = _calibration_file(root, 11, 4)
    pixels = root / "pixels.h5"
    res = runner.invoke(app, ["normal-labels", str(train), "--out", str(pixels), "--json",
                              "--flat-per-press", "1500", "--no-progress"])
    assert res.exit_code == 0, res.output
    return {"root": root, "train": train, "test": test, "pixels": pixels,
            "summary": json.loads(res.output)}


@pytest.mark.parametrize(("centre", "radius_mm", "depth_mm"),
                         [((160.0, 120.0), 3.0, 0.5), ((61.3, 187.8), 2.0, 0.3),
                          ((250.6, 70.2), 3.0, 0.8)])
def test_circle_found_within_half_a_pixel(centre: tuple[float, float], radius_mm: float,
                                          depth_mm: float) -> None:
    optics = GelOptics()
    rng = np.random.default_rng(0)
    ref = render_reference(optics, rng=rng)
    frame = render_rgb(ball_cap(optics, centre, radius_mm, depth_mm), optics, rng=rng)
    fit = find_contact_circle(frame, ref)
    assert fit.ok
    assert np.hypot(fit.x_px - centre[0], fit.y_px - centre[1]) < 0.5
    assert fit.radius_px == pytest.approx(contact_radius_px(optics, radius_mm, depth_mm),
                                          abs=0.75)


def test_no_contact_is_a_status_not_an_error() -> None:
    optics = GelOptics()
    rng = np.random.default_rng(1)
    fit = find_contact_circle(render_reference(optics, rng=rng),
                              render_reference(optics, rng=rng))
    assert not fit.ok and np.isnan(fit.radius_px)


def test_sphere_normals_follow_eqs_5_to_8() -> None:
    n = sphere_normals((40, 50), (20.0, 15.0), 10.0, ball_radius_mm=2.0, px_per_mm=8.0)
    # a pixel 8 px right of the centre: d_PV = 1 mm, b = arccos(1/2), a = 0
    assert np.allclose(n[15, 28], [0.5, 0.0, np.sqrt(3) / 2], atol=1e-6)
    # 6 px above (row - 6): a = -90 deg, nx = 0, ny = -cos b
    d = 6 / 8 / 2.0
    assert np.allclose(n[9, 20], [0.0, -d, np.sqrt(1 - d * d)], atol=1e-6)
    assert np.array_equal(n[15, 31], [0, 0, 1])  # 11 px out: outside the circle
    assert np.allclose(np.linalg.norm(n, axis=-1), 1, atol=1e-6)


@pytest.mark.slow
def test_pixel_table(files: dict) -> None:
    summary = files["summary"]
    assert summary["n_presses"] == 10 and summary["n_failed"] == 0
    assert summary["px_per_mm"] == 16.0
    assert summary["centre_error_px"]["max"] < 1.0
    assert summary["radius_error_px"]["max"] < 1.0
    assert summary["n_flat_pixels"] == 10 * 1500
    assert summary["n_flat_left_out"] == 10 * 320 * 240 - summary["n_pixels"]
    with TactileFile(files["pixels"]) as f:
        assert len(f.trial_names) == 10
        trial = f.trial("ball_03")
        sig = trial.signal("pixels")
        assert sig.channel_names == PIXEL_CHANNELS
        # the unit the presses came from, for the run trained on it (issue 35, item 4)
        assert sig.sensor.attrs["sensor_unit"] == "visuotactile"  # the ingest's sensor name
        assert sig.sensor.attrs["sensor_unit_from"] == "sensor name"
        assert (sig.sensor.width_px, sig.sensor.height_px) == (320, 240)
        labels = trial.sample_labels("pixels")
        assert set(labels) == {"nx", "ny", "nz"}
        data = sig.data
        nz = labels["nz"].values
        row = data[0]
        lab = trial.labels
        # the first rows are the contact pixels: inside the fitted circle, normals tilted
        assert np.hypot(row[0] - lab["fit_centre_x_px"],
                        row[1] - lab["fit_centre_y_px"]) <= lab["fit_radius_px"]
        flat = nz == 1.0
        assert flat.sum() == 1500 and (nz[~flat] < 1).all()
        # dR = R - R_reference
        with TactileFile(files["train"]) as src:
            frames = src.trial("ball_03").frames()
            x, y = int(row[0]), int(row[1])
            pixel = frames[0][y, x].astype(float)
            expect = pixel - frames.reference[y, x].astype(float)
        assert np.array_equal(row[2:5], expect) and np.array_equal(row[5:8], pixel)


def test_missing_scale_is_one_line(files: dict, tmp_path: Path) -> None:
    noscale = _calibration_file(tmp_path, 12, 1, px_per_mm=False)
    res = runner.invoke(app, ["normal-labels", str(noscale), "--out", str(tmp_path / "p.h5")])
    assert res.exit_code == 2
    assert "px_per_mm" in res.output and "--px-per-mm" in res.output
    assert len(res.output.strip().splitlines()) == 1 and not (tmp_path / "p.h5").exists()


@pytest.mark.slow
def test_mlp_beats_the_flat_predictor_on_held_out_presses(files: dict) -> None:
    from tactile_cli.visuotactile.normals import NormalModel

    run = files["root"] / "run"
    res = runner.invoke(app, ["train", str(REPO / "configs" / "train_mlp_normals.yaml"),
                              "--data", str(files["pixels"]), "--out", str(run), "--epochs",
                              "10", "--no-progress"])
    assert res.exit_code == 0, res.output
    model = NormalModel.from_run(run)
    assert model.input_kind == "difference"
    score = normal_rmse(model.predict, files["test"])  # presses of another seed
    assert score.truth == "scene" and len(score.per_image) == 4
    assert score.rmse_contact < 0.6 * score.baseline_rmse_contact
    assert score.rmse < 0.8 * score.baseline_rmse


def test_missing_ball_radius_is_one_line(files: dict, tmp_path: Path) -> None:
    scene = files["root"] / "scene11"
    bare = tmp_path / "bare.h5"
    res = runner.invoke(app, ["ingest", str(scene / "calibration"), "--px-per-mm", "16",
                              "--out", str(bare), "--no-progress"])
    assert res.exit_code == 0, res.output
    res = runner.invoke(app, ["normal-labels", str(bare), "--out", str(tmp_path / "p.h5")])
    assert res.exit_code == 2 and "ball_radius_mm" in res.output and "bare.h5" in res.output


@pytest.mark.slow
def test_plot_writes_the_circle_sheet(files: dict, tmp_path: Path) -> None:
    res = runner.invoke(app, ["normal-labels", str(files["test"]), "--out",
                              str(tmp_path / "p.h5"), "--plot", str(tmp_path / "fig")])
    assert res.exit_code == 0, res.output
    assert "centre error against the scene truth" in res.output
    png = tmp_path / "fig" / "circles.png"
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    # the plot folder is checked before any work: a file there is refused
    (tmp_path / "f2").write_text("x")
    res = runner.invoke(app, ["normal-labels", str(files["test"]), "--out",
                              str(tmp_path / "q.h5"), "--plot", str(tmp_path / "f2")])
    assert res.exit_code == 2 and not (tmp_path / "q.h5").exists()


def test_help() -> None:
    res = runner.invoke(app, ["normal-labels", "--help"])
    assert res.exit_code == 0 and "--flat-per-press" in res.output
