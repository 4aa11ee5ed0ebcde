"""Eqs. 20-21 and the Fig. 23 slope: numerics, recovered speeds, and the two commands."""

from __future__ import annotations

import json

import numpy as np
import pytest
from PIL import Image
from typer.testing import CliRunner

from tactile_cli.cli import app
from tactile_cli.spatial import (
    SpatialConfig,
    centroid_velocity,
    estimate_slip_rates,
    fit_common_slope,
    integrate_displacement,
    slip_rate_from_centroids,
)

from ..factories.strip_events import OPTICS, STRIP_ROIS, make_strip_events, write_trials

runner = CliRunner()

ROIS_YAML = """\
version: 1
sensor: {width_px: 640, height_px: 480}
optics: {pixel_pitch_m: 9.0e-6, focal_length_m: 3.6e-3, strip_distance_m: 0.02}
rois:
  - {name: strip_1, x0: 100, y0: 120, x1: 160, y1: 360}
  - {name: strip_2, x0: 300, y0: 120, x1: 360, y1: 360}
  - {name: strip_3, x0: 480, y0: 120, x1: 540, y1: 360}
"""


@pytest.fixture
def rois_yaml(tmp_path):
    path = tmp_path / "rois.yaml"
    path.write_text(ROIS_YAML)
    return path


# -- numerics -------------------------------------------------------------------------------
def test_velocity_and_displacement_of_a_parabola():
    t = np.linspace(0, 1, 51)
    y = 3.0 * t ** 2 - 5.0 * t
    v = centroid_velocity(t, y)
    np.testing.assert_allclose(v[1:-1], 6.0 * t[1:-1] - 5.0, atol=1e-12)  # central differences
    d = integrate_displacement(t, 6.0 * t - 5.0)
    np.testing.assert_allclose(d, y - y[0], atol=1e-12)  # trapezoid is exact for a line
    stacked = integrate_displacement(t, np.stack([6.0 * t - 5.0, np.ones_like(t)], axis=1))
    np.testing.assert_allclose(stacked[:, 1], t)


def test_common_slope_recovers_slope_and_a_calibrated_se():
    rng = np.random.default_rng(0)
    t = np.arange(40) * 0.02
    true = -106.7
    slopes, ses = [], []
    for _ in range(400):
        weights = rng.integers(5, 200, size=(40, 3)).astype(float)
        y = np.array([300.0, 310.0, 290.0]) + true * t[:, None] + rng.normal(
            0, 11.5 / np.sqrt(weights))
        y[rng.random(y.shape) < 0.05] = np.nan  # a few empty bins
        fit = fit_common_slope(t, y, weights)
        slopes.append(fit.slope)
        ses.append(fit.slope_se)
    slopes, ses = np.array(slopes), np.array(ses)
    assert abs(slopes.mean() - true) < 3 * slopes.std() / np.sqrt(len(slopes))
    # the reported standard error matches the scatter of the estimates within 10 %
    assert np.mean(ses) == pytest.approx(slopes.std(), rel=0.1)
    assert fit.intercepts == pytest.approx([300, 310, 290], abs=2)
    with pytest.raises(ValueError, match="too few"):
        fit_common_slope(t[:2], y[:2, :1])


def test_slip_rate_from_exact_centroids():
    t = (np.arange(100) + 0.5) * 0.02
    v_px = float(OPTICS.m_to_px(0.004))
    y = 340.0 - v_px * np.clip(t - 0.6, 0, 1.0)
    cy = np.stack([y, y + 7.0], axis=1)
    res, trace = slip_rate_from_centroids(t, cy, slip_start_s=0.6, slip_end_s=1.6,
                                          edge_trim_s=0.1, optics=OPTICS, trial="x")
    assert res.status == "ok"
    assert res.velocity_px_s == pytest.approx(-v_px, rel=1e-9)
    assert res.speed_m_s == pytest.approx(0.004, rel=1e-9)
    span = res.displacement_end_s - res.displacement_start_s
    assert span == pytest.approx(0.98)
    assert res.displacement_m == pytest.approx(0.004 * span, rel=1e-9)
    assert res.displacement_fit_m == pytest.approx(0.004 * span, rel=1e-9)
    assert trace.in_slip.sum() == 50 and trace.in_fit.sum() == 40
    empty, none = slip_rate_from_centroids(t, np.full_like(cy, np.nan), slip_start_s=0.6,
                                           slip_end_s=1.6, optics=OPTICS)
    assert empty.status == "too_few_bins" and none is None


# -- recordings -------------------------------------------------------------------------------
def test_recovers_known_speeds_including_the_papers(strip_file):
    est = estimate_slip_rates(strip_file, SpatialConfig(STRIP_ROIS, OPTICS))
    by = {e.result.trial: e.result for e in est}
    assert set(by) == {"slow", "paper", "fast"}
    for name, truth in (("slow", 0.002), ("paper", 0.004), ("fast", 0.006)):
        r = by[name]
        assert r.status == "ok" and r.truth_speed_m_s == truth
        assert abs(r.speed_rel_error) < 0.02, (name, r.speed_rel_error)
        assert abs(r.speed_m_s - truth) < 5 * r.speed_se_m_s + 0.002 * truth
        span = r.displacement_end_s - r.displacement_start_s
        assert r.displacement_m == pytest.approx(truth * span, rel=0.03)
        assert r.background_px_hz == pytest.approx(20_000 / 2 / (640 * 480), rel=0.1)
        assert r.region_source == "annotations" and r.n_rois_used == 3


def test_without_background_subtraction_the_speed_is_biased_low(strip_file):
    from tactile_cli.spatial import CentroidOptions

    cfg = SpatialConfig(STRIP_ROIS, OPTICS, centroid=CentroidOptions(background="none"))
    r = estimate_slip_rates(strip_file, cfg, trials=["paper"])[0].result
    # 2.3 % of the ROI events are background, which shrinks the slope by about as much
    assert -0.04 < r.speed_rel_error < -0.01 and r.background_px_hz is None


def test_labels_give_the_region_when_annotations_are_missing(tmp_path):
    tr = make_strip_events(seed=9)
    tr.labels.update(slip_start_s=0.8, release_start_s=1.6)
    f = write_trials(tmp_path / "f.h5", {"t": tr}, with_annotations=False)
    r = estimate_slip_rates(f, SpatialConfig(STRIP_ROIS, OPTICS))[0].result
    assert r.region_source == "labels" and r.status == "ok"
    assert r.message == "no approach annotation: background not subtracted"
    del tr.labels["slip_start_s"]
    g = write_trials(tmp_path / "g.h5", {"t": tr}, with_annotations=False)
    r = estimate_slip_rates(g, SpatialConfig(STRIP_ROIS, OPTICS))[0].result
    assert r.status == "no_slip_region"


# -- commands ---------------------------------------------------------------------------------
@pytest.mark.slow
def test_slip_rate_command_json_table_and_plot(strip_file, rois_yaml, tmp_path):
    out = runner.invoke(app, ["slip-rate", str(strip_file), "--rois", str(rois_yaml), "--json",
                              "--plot", str(tmp_path / "plots")])
    assert out.exit_code == 0, out.output
    data = json.loads(out.output)
    assert data["tool_name"] == "tactile-cli" and data["inputs"][0]["path"] == str(strip_file)
    assert data["config"]["config"]["optics"]["strip_distance_m"] == 0.02
    speeds = {t["trial"]: t["speed_m_s"] for t in data["trials"]}
    assert speeds["paper"] == pytest.approx(0.004, rel=0.02)
    assert data["summary"]["n_ok"] == 3 and data["summary"]["max_abs_rel_error"] < 0.02
    pngs = sorted(p.name for p in (tmp_path / "plots").glob("*.png"))
    assert pngs == ["slip_fast.png", "slip_paper.png", "slip_slow.png"]
    assert json.loads((tmp_path / "plots" / "slip_rate.json").read_text())["trials"][0][
        "trial"] == data["trials"][0]["trial"]
    table = runner.invoke(app, ["slip-rate", str(strip_file), "--rois", str(rois_yaml),
                                "-t", "paper"])
    assert table.exit_code == 0
    assert "paper" in table.output and "0.004000" in table.output and "slow" not in table.output


def test_slip_rate_proposes_rois_with_sensor_optics(tmp_path):
    f = write_trials(tmp_path / "f.h5", {"t": make_strip_events(seed=11)}, sensor_optics=True)
    out = runner.invoke(app, ["slip-rate", str(f), "--json"])
    assert out.exit_code == 0, out.output
    r = json.loads(out.output)["trials"][0]
    assert len(r["rois"]) == 3 and abs(r["speed_rel_error"]) < 0.03


@pytest.mark.parametrize("args, message", [
    (["-t", "nope"], "{f}: no trial 'nope' with events; see `tactile info {f}`"),
    (["--rois", "{bad}"], "{bad}: ROI s (x 600..700, y 0..10) lies outside the 640x480 px "
                          "sensor; keep 0 <= x0 < x1 <= 640 and 0 <= y0 < y1 <= 480"),
    (["--rois", "{unknown}"], "{unknown}: unknown key `centroid.polarty` (allowed here: "
                              "polarity, median, bin_s, background)"),
    ([], "{f}: no optics to convert px to m: the sensor lacks pixel_pitch_m, focal_length_m, "
         "strip_distance_m and no config gave them; pass --rois CONFIG with an `optics:` "
         "section (pixel_pitch_m, focal_length_m, strip_distance_m)"),
])
def test_slip_rate_bad_input_is_one_line_exit_2(strip_file, tmp_path, args, message):
    bad = tmp_path / "bad.yaml"
    bad.write_text("rois: [{name: s, x0: 600, y0: 0, x1: 700, y1: 10}]\n")
    unknown = tmp_path / "unknown.yaml"
    unknown.write_text("centroid: {polarty: positive}\n")
    subst = {"f": strip_file, "bad": bad, "unknown": unknown}
    result = runner.invoke(app, ["slip-rate", str(strip_file),
                                 *[a.format(**subst) for a in args]])
    assert result.exit_code == 2
    assert result.stderr.strip() == f"tactile: error: {message.format(**subst)}"


@pytest.mark.slow
def test_frames_command_writes_pngs_sheet_and_provenance(strip_file, rois_yaml, tmp_path):
    out = tmp_path / "frames"
    result = runner.invoke(app, ["frames", str(strip_file), "--out", str(out), "-t", "paper",
                                 "--window-ms", "200", "--median", "3", "--rois", str(rois_yaml),
                                 "--json"])
    assert result.exit_code == 0, result.output
    rec = json.loads(result.output)
    assert rec["outputs"][0]["n_frames"] == 10  # 2.0 s in 200 ms windows
    frames = sorted((out / "paper").glob("frame_*.png"))
    assert len(frames) == 10
    with Image.open(frames[4]) as im:
        assert im.size == (640, 480) and im.mode == "RGB"
        assert "tactile-cli" in im.text["Software"]
        rgb = np.asarray(im)
    # the 0.8-1.0 s frame: strip events (green) inside the ROIs, little else after the median
    green = rgb[..., 1] > 0
    assert green[120:360, 100:160].sum() > 100 and green[:100].sum() < 20
    assert (out / "paper" / "contact_sheet.png").exists()
    assert json.loads((out / "frames.json").read_text())["config"]["median"] == 3
    again = runner.invoke(app, ["frames", str(strip_file), "--out", str(out), "-t", "paper"])
    assert again.exit_code == 2
    assert again.stderr.strip() == (f"tactile: error: {out / 'paper'}: holds PNGs of an earlier "
                                    "run; pass --overwrite to replace them")
    sheet = runner.invoke(app, ["frames", str(strip_file), "--out", str(out), "-t", "paper",
                                "--overwrite", "--sheet-only", "--kind", "net"])
    assert sheet.exit_code == 0 and not list((out / "paper").glob("frame_*.png"))


@pytest.mark.parametrize("args, message", [
    (["-t", "nope"], "{f}: no trial 'nope'; the file has 3 trial(s): slow, paper, fast"),
    (["--median", "4"], "--median (=4) must be an odd whole number of px >= 1 (1 = no filter)"),
    (["--window-ms", "0"], "--window-ms (=0) must be > 0"),
    (["--kind", "rgb"], "--kind (='rgb') must be one of polarity, net, positive, negative"),
    (["--rois", "{small}"], "{small}: the config is for a 320x240 px sensor; the recording's "
                            "is 640x480 px: use the config of that sensor"),
    (["--rois", "{bad}"], "{bad}: ROI s (x 0..10, y 470..490) lies outside the 640x480 px "
                          "sensor; keep 0 <= x0 < x1 <= 640 and 0 <= y0 < y1 <= 480"),
])
def test_frames_bad_input_is_one_line_exit_2(strip_file, tmp_path, args, message):
    small = tmp_path / "small.yaml"
    small.write_text("sensor: {width_px: 320, height_px: 240}\n")
    bad = tmp_path / "bad.yaml"
    bad.write_text("rois: [{name: s, x0: 0, y0: 470, x1: 10, y1: 490}]\n")
    subst = {"f": strip_file, "small": small, "bad": bad}
    result = runner.invoke(app, ["frames", str(strip_file), "--out", str(tmp_path / "o"),
                                 *[a.format(**subst) for a in args]])
    assert result.exit_code == 2
    assert result.stderr.strip() == f"tactile: error: {message.format(**subst)}"
    assert not (tmp_path / "o").exists()


def test_eq21_end_weights_in_blocks_equal_the_full_operator():
    from tactile_cli.spatial.slip_rate import (
        _end_weights,
        centroid_velocity,
        integrate_displacement,
    )

    t = np.sort(np.random.default_rng(0).uniform(0.0, 2.0, 300))
    full = integrate_displacement(t, centroid_velocity(t, np.eye(t.size)))[-1]
    assert np.array_equal(_end_weights(t, block=7), full)
    y = np.random.default_rng(1).normal(size=t.size)
    assert _end_weights(t) @ y == pytest.approx(
        integrate_displacement(t, centroid_velocity(t, y))[-1])
