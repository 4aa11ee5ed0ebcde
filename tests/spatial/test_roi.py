"""ROIs, eq. 19 centroids, background subtraction, ROI proposals and the config loader."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from tactile_cli.errors import InputError
from tactile_cli.spatial import (
    Roi,
    accumulate_frames,
    centroids_from_sums,
    check_rois_on_sensor,
    load_config,
    median_filter_frames,
    propose_rois,
    roi_centroid_series,
    roi_weight_sums,
)
from tactile_cli.spatial.roi import drop_outside, subtract_background
from tactile_cli.store.trials import TactileFile

from ..factories.strip_events import OPTICS, STRIP_ROIS, H, W, make_strip_events, write_trials

REPO = Path(__file__).resolve().parents[2]


def test_eq19_centroid_by_hand():
    roi = Roi("r", 10, 20, 20, 30)
    # bin 0: (12, 21) twice and (15, 27) once; bin 1: nothing in the ROI; bin 2: (19, 29)
    x = np.array([12, 12, 15, 5, 19, 11])
    y = np.array([21, 21, 27, 25, 29, 22])
    t = np.array([0, 10, 19, 30, 45, 46])
    p = np.array([1, 1, 1, 1, 1, -1], np.int8)  # the last one is negative: not counted
    sums = roi_weight_sums(x, y, t, p, [roi], start_us=0, bin_us=20, n_bins=3,
                           width_px=W, height_px=H)
    c = centroids_from_sums(sums)
    assert c[0, 0].tolist() == pytest.approx([(12 + 12 + 15) / 3, (21 + 21 + 27) / 3])
    assert np.isnan(c[1, 0]).all()
    assert c[2, 0].tolist() == [19.0, 29.0]
    assert sums[:, 0, 0].tolist() == [3.0, 0.0, 1.0]
    both = roi_weight_sums(x, y, t, p, [roi], start_us=0, bin_us=20, n_bins=3, polarity="both",
                           width_px=W, height_px=H)
    assert both[2, 0, 0] == 2.0


def test_median_centroid_equals_filtered_frames(tmp_path):
    tr = make_strip_events(end_s=0.5, press_s=(0.1, 0.2), slip_s=(0.2, 0.45), seed=5)
    rois = (*STRIP_ROIS, Roi("edge", 0, 0, 40, 30))  # touches the sensor's corner
    sums = roi_weight_sums(tr.x, tr.y, tr.t, tr.p, rois, start_us=0, bin_us=50_000,
                           n_bins=10, median=3, width_px=W, height_px=H)
    pos, _ = accumulate_frames(tr.x, tr.y, tr.t, tr.p, width_px=W, height_px=H, start_us=0,
                               window_us=50_000, n_frames=10)
    filt = median_filter_frames(pos, 3).astype(np.float64)
    for j, r in enumerate(rois):
        sub = filt[:, r.y0_px:r.y1_px, r.x0_px:r.x1_px]
        w = sub.sum(axis=(1, 2))
        np.testing.assert_allclose(sums[:, j, 0], w)
        np.testing.assert_allclose(sums[:, j, 2], (sub.sum(axis=2) * np.arange(r.y0_px, r.y1_px))
                                   .sum(axis=1))


def test_background_subtraction_is_exact_for_a_uniform_background():
    roi = Roi("r", 0, 0, 10, 40)
    ys, xs = np.mgrid[0:40, 0:10]
    x = np.concatenate([xs.ravel(), np.full(50, 4)])  # one event on every pixel + a band
    y = np.concatenate([ys.ravel(), np.full(50, 33)])
    t = np.zeros(x.size, np.int64)
    p = np.ones(x.size, np.int8)
    sums = roi_weight_sums(x, y, t, p, [roi], start_us=0, bin_us=10, n_bins=1,
                           width_px=W, height_px=H)
    raw = centroids_from_sums(sums)[0, 0]
    assert raw[1] == pytest.approx((ys.sum() + 50 * 33) / 450)  # pulled towards the middle
    clean = centroids_from_sums(subtract_background(sums, [roi], 1.0))[0, 0]
    assert clean.tolist() == pytest.approx([4.0, 33.0])
    # more background than events: the bin is dropped, not given a wild centroid
    assert np.isnan(centroids_from_sums(subtract_background(sums, [roi], 2.0))).all()
    # 50 events left over a background of 400 +- 20 keep their centroid (2.5 sd); the same
    # 50 over a background of 1,600 +- 40 are within 2 sd of its counting noise: dropped
    uniform = np.array([400.0, 400.0 * 4.5, 400.0 * 19.5])  # one event per pixel
    assert np.isfinite(centroids_from_sums(subtract_background(sums, [roi], 1.0))).all()
    noisier = sums + 3 * uniform
    assert np.isnan(centroids_from_sums(subtract_background(noisier, [roi], 4.0))).all()


def test_a_centroid_outside_its_roi_is_dropped_with_its_weight():
    rois = (Roi("a", 0, 0, 10, 40), Roi("b", 20, 0, 30, 40))
    centroid = np.array([[[4.0, 33.0], [25.0, 500.0]], [[-3.0, 10.0], [29.0, 39.0]]])
    weight = np.array([[50.0, 0.05], [2.0, 7.0]])
    c, w = drop_outside(centroid, weight, rois)
    assert np.isnan(c[0, 1]).all() and np.isnan(c[1, 0]).all()
    assert c[0, 0].tolist() == [4.0, 33.0] and c[1, 1].tolist() == [29.0, 39.0]
    assert w.tolist() == [[50.0, 0.0], [0.0, 7.0]]


def test_rois_must_lie_on_the_sensor():
    check_rois_on_sensor(STRIP_ROIS, W, H)
    with pytest.raises(InputError) as err:
        check_rois_on_sensor([Roi("s", 600, 10, 660, 20)], W, H, source="c.yaml")
    assert str(err.value) == ("c.yaml: ROI s (x 600..660, y 10..20) lies outside the 640x480 px "
                              "sensor; keep 0 <= x0 < x1 <= 640 and 0 <= y0 < y1 <= 480")
    with pytest.raises(ValueError, match="x0 < x1"):
        Roi("bad", 5, 0, 5, 10)


def test_propose_rois_finds_the_strips_from_a_press():
    tr = make_strip_events(seed=6)
    press = (tr.t >= 300_000) & (tr.t < 800_000) & (tr.p > 0)
    density = np.bincount(tr.y[press] * W + tr.x[press], minlength=W * H).reshape(H, W)
    rois = propose_rois(density, pad_px=(2, 2))
    assert [r.name for r in rois] == ["roi_1", "roi_2", "roi_3"]
    for got, strip in zip(rois, STRIP_ROIS, strict=True):
        # the band at rest: x over the strip, y around y1 - 20 +- 6 px
        assert got.x0_px <= strip.x0_px + 2 and got.x1_px >= strip.x1_px - 2
        assert abs(got.x0_px - strip.x0_px) <= 6 and abs(got.x1_px - strip.x1_px) <= 6
        assert got.y0_px <= strip.y1_px - 26 and got.y1_px >= strip.y1_px - 14
        assert got.height_px < 30
    assert propose_rois(np.zeros((H, W))) == []


def test_centroid_series_shape_and_times(tmp_path):
    tr = make_strip_events(end_s=1.0, press_s=(0.1, 0.3), slip_s=(0.3, 0.8), seed=7,
                           origin_us=2_000_000)
    f = write_trials(tmp_path / "f.h5", {"t": tr})
    with TactileFile(f) as tf:
        t_s, c = roi_centroid_series(tf.trial("t"), STRIP_ROIS, 0.02)
    assert c.shape == (50, 3, 2) and t_s.shape == (50,)
    np.testing.assert_allclose(t_s, 0.01 + 0.02 * np.arange(50))
    # at rest in the press the band sits at y1 - 20.5 px (its pixels floor the position);
    # the raw series keeps the background, 2.3 % of the ROI's events, which pull it ~2.3 px
    # towards the ROI's middle (y 240)
    rest = c[(t_s > 0.12) & (t_s < 0.28), :, 1]
    expected = [0.977 * (r.y1_px - 20.5) + 0.023 * 239.5 for r in STRIP_ROIS]
    np.testing.assert_allclose(np.nanmean(rest, axis=0), expected, atol=1.5)
    with TactileFile(f) as tf, pytest.raises(InputError,
                                             match="no trial 'nope'; the file has 1 trial"):
        roi_centroid_series(tf.trial("nope"), STRIP_ROIS)


# -- config -------------------------------------------------------------------------------
def test_repo_config_loads():
    cfg = load_config(REPO / "configs" / "rois_marker_scene.yaml")
    assert [r.name for r in cfg.rois] == ["strip1", "strip2", "strip3", "strip4"]
    assert cfg.optics.strip_m_per_px == pytest.approx(3.75e-5)
    assert cfg.centroid.polarity == "positive" and cfg.centroid.subtract_background
    assert cfg.slip.edge_trim_s == 0.1


@pytest.mark.parametrize("text, message", [
    ("rois: [{name: a, x0: 0, y0: 0, x1: 5, y1: 5}]\noptic: {}\n",
     "unknown key `optic` (allowed here: version, sensor, optics, rois, centroid, slip)"),
    ("optics: {pixel_pitch_m: 9.0e-6, focal_length_m: 3.6e-3, strip_distance: 0.03}\n",
     "unknown key `optics.strip_distance` (allowed here: pixel_pitch_m, focal_length_m, "
     "strip_distance_m)"),
    ("rois: [{name: a, x0: 0, y0: 0, x1: 5, y1: 5, colour: red}]\n",
     "unknown key `rois[0].colour` (allowed here: name, x0, y0, x1, y1)"),
    ("rois: [{name: a, x0: 0, y0: 0, x1: 5.5, y1: 5}]\n",
     "`rois[0].x1` must be a whole number of px (got 5.5)"),
    ("sensor: {width_px: 64, height_px: 48}\nrois: [{name: a, x0: 0, y0: 0, x1: 65, y1: 5}]\n",
     "ROI a (x 0..65, y 0..5) lies outside the 64x48 px sensor; keep 0 <= x0 < x1 <= 64 and "
     "0 <= y0 < y1 <= 48"),
    ("centroid: {median: 3, background: approach}\n",
     "`centroid.background: approach` needs `centroid.median: 1` (the median filter already "
     "removes isolated background events); set `background: none`"),
    ("version: 2\n", "`version` is 2; this tool reads version 1"),
    ("rois: [\n", "not valid YAML (expected the node content, but found '<stream end>'); "
                  "check the indentation and quoting there"),
])
def test_config_errors_name_the_key(tmp_path, text, message):
    cfg = tmp_path / "c.yaml"
    cfg.write_text(text)
    with pytest.raises(InputError) as err:
        load_config(cfg)
    where = ", line 2, column 1" if message.startswith("not valid YAML") else ""
    assert str(err.value) == f"{cfg}{where}: {message}"


def test_scene_json_is_read_as_a_config(tmp_path):
    scene = {"format": "tactile-marker-events", "format_version": 1,
             "sensor": {"width_px": 640, "height_px": 480, "pixel_pitch_m": 9e-6,
                        "focal_length_m": 3.6e-3, "strip_distance_m": 0.03,
                        "slip_px_per_m": 26666.7},
             "rois": [{"name": "strip1", "x0_px": 125, "y0_px": 215, "x1_px": 155,
                       "y1_px": 425}]}
    path = tmp_path / "scene.json"
    path.write_text(json.dumps(scene))
    cfg = load_config(path)
    assert cfg.rois == (Roi("strip1", 125, 215, 155, 425),)
    assert cfg.optics == OPTICS.__class__(9e-6, 3.6e-3, 0.03)
    assert (cfg.width_px, cfg.height_px) == (640, 480)
    del scene["sensor"]["strip_distance_m"]
    path.write_text(json.dumps(scene))
    with pytest.raises(InputError, match="scene.json: `sensor` lacks strip_distance_m"):
        load_config(path)
