"""Model-based ROI centroid trajectories (tactile_cli/synth/centroids.py) and
`tactile synth --centroids` (paper 000, sec. 5.2, eqs. 15, 19)."""

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
from tactile_cli.spatial import Roi, StripOptics, load_config
from tactile_cli.spatial.stream import channel_names
from tactile_cli.store import validate_file
from tactile_cli.synth import CentroidModel, SynthConfig, draw_centroids, load_synth_config
from tactile_cli.synth.config import CentroidsConfig

REPO = Path(__file__).resolve().parents[2]
ROIS = REPO / "configs" / "rois_marker_scene.yaml"
runner = CliRunner()

OPTICS = StripOptics(9e-6, 3.6e-3, 0.03)  # 26,667 px/m: 0.004 m/s = 106.7 px/s
ROI = Roi("s", 100, 80, 130, 420)
BIN_S = 0.02


def _model(rois=(ROI,), **cfg) -> CentroidModel:
    fixed = {"speeds_m_s": [0.004, 0.004], "band_height_px": [40.0, 40.0],
             "rest_inset_px": [25.0, 25.0], "roi_fraction": [1.0, 1.0], **cfg}
    return CentroidModel(tuple(rois), OPTICS, 640, 480, CentroidsConfig.model_validate(fixed),
                         opposite_fraction=0.5)


def _draw(mu, *, model=None, seed=0, background=0.0, slip=(1.0, 3.0), tau=0.3):
    t = (np.arange(len(mu)) + 0.5) * BIN_S
    return t, draw_centroids(t, np.asarray(mu, float), bin_s=BIN_S, slip_start_s=slip[0],
                             release_start_s=slip[1], tau_press_s=tau,
                             background_per_bin=background, model=model or _model(),
                             rng=np.random.default_rng(seed))


def test_rest_slip_at_eq15_speed_and_release_with_the_press_time_constant():
    mu = np.full(250, 40_000.0)  # 60,000 strip events per bin: the centroid is the band
    t, c = _draw(mu)
    y = c.centroid_px[:, 0, 1]
    assert c.slip_speed_m_s == 0.004
    assert c.slip_speed_px_s == pytest.approx(0.004 * 2 * 3.6e-3 / (0.03 * 9e-6))
    assert c.rest_y_px.tolist() == [420 - 25]  # 25 px inside the edge the slip leaves
    press = t < 1.0 - BIN_S
    # floored pixel positions: the mean of a band centred at c is c - 0.5
    np.testing.assert_allclose(y[press], 395 - 0.5, atol=0.25)  # 5 sd of 60,000 events
    z_x = (c.centroid_px[:, 0, 0] - ROI.centre_px[0]) * np.sqrt(c.weight[:, 0] * 12 / 899)
    assert np.abs(z_x).max() < 5  # x: the ROI's 30 columns, uniform
    sliding = (t > 1.05) & (t < 2.95)
    slope = np.polyfit(t[sliding], y[sliding], 1)[0]
    assert slope == pytest.approx(-c.slip_speed_px_s, rel=0.005)  # up: smaller y (Fig. 23)
    # after the release the displacement decays as exp(-t / tau_press)
    back = t > 3.05
    disp = y[back] - (395 - 0.5)
    tau = -1 / np.polyfit(t[back][disp < -2], np.log(-disp[disp < -2]), 1)[0]
    assert tau == pytest.approx(0.3, rel=0.05)
    # a bin of events averages the band's position: the bin [1.00, 1.02) s, labelled press
    # (centre 1.01 s) when the slip starts at 1.015 s, has moved for its last 5 ms
    _, c = _draw(mu[:60], slip=(1.015, 3.0))
    np.testing.assert_array_equal(c.band_y_px[:50, 0], 395.0)
    v = c.slip_speed_px_s
    assert c.band_y_px[50, 0] == pytest.approx(395 - v * 0.005**2 / 2 / 0.02, rel=1e-12)
    assert c.band_y_px[51, 0] == pytest.approx(395 - v * 0.015, rel=1e-12)


def test_noise_shrinks_with_the_events_of_the_bin():
    mu = np.concatenate([np.full(4000, 40.0), np.full(4000, 400.0)])  # no slip below
    _, c = _draw(mu, slip=(1000.0, 1001.0), seed=3)
    for part, mu_k in ((slice(0, 4000), 40.0), (slice(4000, None), 400.0)):
        y, n = c.centroid_px[part, 0, 1], c.weight[part, 0]
        assert n.mean() == pytest.approx(1.5 * mu_k, rel=0.02)  # (1 + beta) mu, one ROI
        resid = (y - (395 - 0.5)) * np.sqrt(n)  # sd of a mean of n uniforms on 40 px
        assert resid.std() == pytest.approx(40 / np.sqrt(12), rel=0.05)
        assert resid.mean() == pytest.approx(0.0, abs=0.75)  # 4 standard errors


def test_no_events_is_nan_with_weight_zero_and_background_is_uniform_over_the_roi():
    _, c = _draw(np.zeros(50))
    assert np.isnan(c.centroid_px).all() and (c.weight == 0).all()
    # background only: 640 x 480 px sensor, 30 x 340 px ROI
    rate = 200.0 * ROI.width_px * ROI.height_px / (640 * 480)
    _, c = _draw(np.zeros(3000), background=200.0, seed=1)
    assert c.weight.mean() == pytest.approx(rate, rel=0.03)
    measured = c.weight[:, 0] > 0
    assert measured.mean() == pytest.approx(1 - np.exp(-rate), abs=0.01)
    assert np.isnan(c.centroid_px[~measured]).all()
    assert np.isfinite(c.centroid_px[measured]).all()
    single = c.weight[:, 0] == 1  # one event: a pixel of the ROI
    ys = c.centroid_px[single, 0, 1]
    assert ys.min() >= ROI.y0_px and ys.max() <= ROI.y1_px - 1 and np.all(ys == np.round(ys))
    w = c.weight[measured, 0]
    pooled = (c.centroid_px[measured, 0] * w[:, None]).sum(axis=0) / w.sum()
    np.testing.assert_allclose(pooled, ROI.centre_px, atol=3)  # ~20,000 events: sd 0.7 px


def test_a_band_pushed_out_of_the_roi_loses_its_events():
    roi = Roi("short", 100, 300, 130, 420)  # 120 px tall; the slip travels 213 px
    _, c = _draw(np.full(200, 4000.0), model=_model((roi,)))
    assert c.weight[40, 0] == pytest.approx(6000, rel=0.05)  # at rest, wholly inside
    assert (c.weight[120:150, 0] == 0).all()  # band beyond y0 - 20: no event
    measured = c.weight[:, 0] > 0
    assert np.all(c.centroid_px[measured, 0, 1] >= roi.y0_px)  # whole pixels of the ROI


def test_speed_and_geometry_are_drawn_per_trial_within_the_config():
    cfg = {"speeds_m_s": [0.002, 0.005], "band_height_px": [30.0, 50.0],
           "rest_inset_px": [15.0, 35.0], "roi_fraction": [0.8, 1.0]}
    rois = (ROI, Roi("t", 200, 80, 230, 420))
    draws = [_draw(np.full(10, 100.0), model=_model(rois, **cfg), seed=s)[1] for s in range(40)]
    speeds = np.array([d.slip_speed_m_s for d in draws])
    assert speeds.min() >= 0.002 and speeds.max() <= 0.005 and speeds.std() > 5e-4
    for d in draws:
        assert d.slip_speed_px_s == pytest.approx(OPTICS.m_to_px(d.slip_speed_m_s))
        assert 30 <= d.band_height_px <= 50 and 0.8 <= d.roi_fraction <= 1.0
        assert np.all((d.rest_y_px >= 420 - 35) & (d.rest_y_px <= 420 - 15))
    assert len({tuple(d.rest_y_px) for d in draws}) == 40  # per ROI, per trial


def test_floored_positions_have_exact_moments():
    from tactile_cli.synth.centroids import floored_uniform_moments

    rng = np.random.default_rng(0)
    lo = np.array([300.0, 300.0, 10.2, 55.5, 7.0])
    hi = np.array([300.3, 340.0, 13.9, 55.5, 8.0])
    mean, var = floored_uniform_moments(lo, hi)
    u = lo + (hi - lo) * rng.random((400_000, 5))
    np.testing.assert_allclose(mean, np.floor(u).mean(axis=0), atol=0.02)
    np.testing.assert_allclose(var, np.floor(u).var(axis=0), atol=0.05, rtol=0.01)
    assert mean.tolist()[0] == 300.0 and var[0] == 0.0  # within one pixel
    assert mean[1] == pytest.approx(319.5) and mean[3] == 55.0 and var[3] == 0.0


def test_config_section_is_validated():
    with pytest.raises(ValueError, match=r"`roi_fraction` \(=\[0.5, 1.5\]\) must lie in"):
        CentroidsConfig.model_validate({"roi_fraction": [0.5, 1.5]})
    with pytest.raises(ValueError, match="direction_y"):
        CentroidsConfig.model_validate({"direction_y": 0})
    assert load_synth_config(REPO / "configs" / "synth_fos.yaml").centroids == CentroidsConfig()


def _read(path: Path) -> dict:
    out = {}
    with h5py.File(path) as h5:
        for name, g in h5["trials"].items():
            out[name] = {k: g[f"signals/{k}/data"][()] for k in g["signals"]}
            out[name]["action"] = {k: g[f"signals/{k}/sample_labels/action"][()]
                                   for k in g["signals"]}
            out[name]["t_s"] = {k: g[f"signals/{k}/t_s"][()] for k in g["signals"]}
            out[name]["labels"] = dict(g["labels"].attrs)
    return out


@pytest.mark.slow
def test_synth_cli_adds_the_stream_and_keeps_the_counts(tmp_path):
    plain, with_c, again = tmp_path / "plain.h5", tmp_path / "c.h5", tmp_path / "again.h5"
    for out, extra in ((plain, []), (with_c, ["--centroids", str(ROIS)]),
                       (again, ["--centroids", str(ROIS)])):
        result = runner.invoke(app, ["synth", "--n", "6", "--seed", "4", "--out", str(out),
                                     *extra])
        assert result.exit_code == 0, result.output
    assert "ROI centroids from" in result.output
    assert validate_file(with_c).ok
    a, b, c = _read(plain), _read(with_c), _read(again)
    rois = load_config(ROIS).rois
    names = channel_names(rois)
    centre = np.array([r.centre_px for r in rois])
    for trial in a:
        # the event counts are those of a run without --centroids
        np.testing.assert_array_equal(a[trial]["event_counts"], b[trial]["event_counts"])
        np.testing.assert_array_equal(b[trial]["roi_centroids"], c[trial]["roi_centroids"])
        d = b[trial]["roi_centroids"]
        assert d.dtype == np.float32 and d.shape[1] == len(names) == 24
        assert np.isfinite(d).all()
        flags, counts = d[:, 8:12], d[:, 12:16]
        assert set(np.unique(flags)) <= {0.0, 1.0}
        np.testing.assert_array_equal(flags, (counts > 0).astype(np.float32))
        xy = d[:, :8].reshape(-1, 4, 2)
        # eq. 20: the velocity channels are the measured centroids' differences per second
        v = d[:, 16:24].reshape(-1, 4, 2)
        both = (flags[1:] > 0) & (flags[:-1] > 0)
        np.testing.assert_allclose(v[1:][both], (np.diff(xy, axis=0) / 0.02)[both],
                                   rtol=1e-4, atol=1e-2)
        assert (v[1:][~both] == 0).all() and (v[0] == 0).all()
        np.testing.assert_allclose(xy[flags == 0], np.broadcast_to(centre, xy.shape)[flags == 0])
        np.testing.assert_array_equal(b[trial]["action"]["roi_centroids"],
                                      b[trial]["action"]["event_counts"])
        np.testing.assert_array_equal(b[trial]["t_s"]["roi_centroids"],
                                      b[trial]["t_s"]["event_counts"])
        lab = b[trial]["labels"]
        assert 0.001 <= lab["slip_speed_m_s"] <= 0.006 and lab["slip_direction_y"] == -1
        assert "slip_speed_m_s" not in a[trial]["labels"]
        # the slip moves every strip up (Fig. 23): y at the release is below y at the slip
        t = b[trial]["t_s"]["roi_centroids"]
        y = xy[..., 1]
        before = (t > lab["slip_start_s"] - 0.2) & (t < lab["slip_start_s"])
        end = (t > lab["release_start_s"] - 0.2) & (t < lab["release_start_s"])
        drop = y[before].mean(axis=0) - y[end].mean(axis=0)
        expect = lab["slip_speed_px_s"] * (lab["release_start_s"] - lab["slip_start_s"] - 0.1)
        np.testing.assert_allclose(drop, min(expect, 250), rtol=0.35)
    with h5py.File(with_c) as h5:
        s = h5["sensors/roi_centroids"]
        assert s["channel_names"].asstr()[()].tolist() == names
        assert s.attrs["kind"] == "event_camera" and s.attrs["bin_s"] == 0.02
        assert [r["name"] for r in json.loads(s.attrs["rois_json"])] == [r.name for r in rois]
        assert s.attrs["strip_distance_m"] == 0.03
        config = json.loads(h5.attrs["config_json"])
        assert config["centroids"]["rois_config"] == str(ROIS)
        assert str(ROIS) in h5["provenance/sources/path"].asstr()[()].tolist()
    with h5py.File(plain) as h5:
        assert "roi_centroids" not in h5["sensors"]


def test_synth_cli_centroid_errors(tmp_path):
    out = tmp_path / "o.h5"
    missing = runner.invoke(app, ["synth", "--n", "2", "--out", str(out), "--centroids",
                                  str(tmp_path / "nope.yaml")])
    assert missing.exit_code == 2
    assert missing.output.strip() == f"tactile: error: {tmp_path / 'nope.yaml'}: file not found"
    raw = yaml.safe_load(ROIS.read_text())
    no_optics = tmp_path / "no_optics.yaml"
    no_optics.write_text(yaml.safe_dump({k: v for k, v in raw.items() if k != "optics"}))
    r = runner.invoke(app, ["synth", "--n", "2", "--out", str(out), "--centroids",
                            str(no_optics)])
    assert r.exit_code == 2 and "has no `optics`" in r.output and not out.exists()
    other_bin = tmp_path / "bin.yaml"
    other_bin.write_text(yaml.safe_dump({**raw, "centroid": {**raw["centroid"],
                                                             "bin_s": 0.01}}))
    r = runner.invoke(app, ["synth", "--n", "2", "--out", str(out), "--centroids",
                            str(other_bin)])
    assert r.exit_code == 2
    assert "centroid.bin_s (=0.01) differs from the synth bin_s (=0.02)" in r.output
    with pytest.raises(InputError, match="is for a 640x480 px sensor; the recording.s is 320x"):
        from tactile_cli.synth import centroid_model

        centroid_model(ROIS, SynthConfig(width_px=320, height_px=240))
