"""Optics (eqs. 3, 15) and event frames (Fig. 13): exact counts, windows, median filter."""

from __future__ import annotations

import numpy as np
import pytest

from tactile_cli.spatial import (
    PAPER_FOCAL_LENGTH_M,
    PAPER_PIXEL_PITCH_M,
    StripOptics,
    accumulate_frames,
    iter_trial_frames,
    median_filter_frames,
)
from tactile_cli.store.trials import TactileFile

from ..factories.strip_events import H, W, make_strip_events, write_trials


# -- optics ---------------------------------------------------------------------------------
def test_eq15_metres_per_pixel_by_hand():
    o = StripOptics(PAPER_PIXEL_PITCH_M, PAPER_FOCAL_LENGTH_M, 0.03)
    # Delta H = 1 px * 9 um; Delta y = Delta H * delta / (2 f) = 9e-6 * 0.03 / 7.2e-3
    assert o.strip_m_per_px == pytest.approx(3.75e-5, rel=1e-12)
    assert o.magnification == pytest.approx(0.12)
    # the paper's robot speed, 4 mm/s, is 106.67 px/s of centroid motion
    assert o.m_to_px(0.004) == pytest.approx(106.6666667, rel=1e-9)
    np.testing.assert_allclose(o.px_to_m(o.m_to_px(np.array([0.002, 0.005]))), [0.002, 0.005])


def test_optics_matches_the_scene_conversion():
    from tactile_cli.scene import slip_px_per_m

    o = StripOptics(9e-6, 3.6e-3, 0.03)
    px_per_m = slip_px_per_m(focal_length_m=3.6e-3, strip_distance_m=0.03, pixel_pitch_m=9e-6)
    assert px_per_m * o.strip_m_per_px == pytest.approx(1.0, rel=1e-12)


@pytest.mark.parametrize("bad", [0.0, -1e-3, float("nan"), True])
def test_optics_rejects_non_positive(bad):
    with pytest.raises(ValueError, match="strip_distance_m"):
        StripOptics(9e-6, 3.6e-3, bad)


# -- frames ---------------------------------------------------------------------------------
def _reference(x, y, t, p, *, start_us, window_us, n_frames):
    pos = np.zeros((n_frames, H, W), np.int32)
    neg = np.zeros((n_frames, H, W), np.int32)
    k = (t - start_us) // window_us
    keep = (k >= 0) & (k < n_frames)
    np.add.at(pos, (k[keep & (p > 0)], y[keep & (p > 0)], x[keep & (p > 0)]), 1)
    np.add.at(neg, (k[keep & (p < 0)], y[keep & (p < 0)], x[keep & (p < 0)]), 1)
    return pos, neg


def test_accumulate_frames_equals_a_per_event_reference():
    tr = make_strip_events(end_s=0.5, press_s=(0.1, 0.2), slip_s=(0.2, 0.4), seed=3)
    pos, neg = accumulate_frames(tr.x, tr.y, tr.t, tr.p, width_px=W, height_px=H,
                                 start_us=50_000, window_us=40_000, n_frames=9)
    rp, rn = _reference(tr.x, tr.y, tr.t, tr.p, start_us=50_000, window_us=40_000, n_frames=9)
    np.testing.assert_array_equal(pos, rp)
    np.testing.assert_array_equal(neg, rn)
    in_windows = (tr.t >= 50_000) & (tr.t < 50_000 + 9 * 40_000)
    assert int(pos.sum() + neg.sum()) == int(in_windows.sum())
    assert pos.dtype == np.int32 and pos.shape == (9, H, W)


def test_window_edges_are_half_open():
    x = np.array([1, 1, 1]); y = np.array([2, 2, 2])  # noqa: E702
    t = np.array([999, 1000, 1999]); p = np.array([1, 1, -1], np.int8)  # noqa: E702
    pos, neg = accumulate_frames(x, y, t, p, width_px=4, height_px=4, start_us=0,
                                 window_us=1000, n_frames=2)
    assert pos[:, 2, 1].tolist() == [1, 1] and neg[:, 2, 1].tolist() == [0, 1]


def test_median_filter_removes_salt_keeps_blocks():
    frame = np.zeros((1, 20, 20), np.int32)
    frame[0, 3, 3] = 7  # an isolated noise pixel (salt)
    frame[0, 10:16, 10:16] = 2  # a 6x6 blob of events
    out = median_filter_frames(frame, 3)
    assert out[0, 3, 3] == 0
    assert (out[0, 11:15, 11:15] == 2).all()
    assert median_filter_frames(frame, 1) is frame
    with pytest.raises(ValueError, match="odd"):
        median_filter_frames(frame, 4)


def test_trial_frames_use_the_trial_origin(tmp_path):
    tr = make_strip_events(end_s=0.6, press_s=(0.1, 0.2), slip_s=(0.2, 0.5),
                           origin_us=3_000_000, seed=4)
    f = write_trials(tmp_path / "f.h5", {"t": tr})
    with TactileFile(f) as tf:
        batches = list(iter_trial_frames(tf.trial("t"), window_s=0.05, start_s=0.1, end_s=0.5,
                                         batch=3))
    t_s = np.concatenate([b.t_s for b in batches])
    np.testing.assert_allclose(t_s, 0.1 + 0.05 * np.arange(8))
    pos = np.concatenate([b.positive for b in batches])
    neg = np.concatenate([b.negative for b in batches])
    rp, rn = _reference(tr.x, tr.y, tr.t, tr.p, start_us=3_100_000, window_us=50_000,
                        n_frames=8)
    np.testing.assert_array_equal(pos, rp)
    np.testing.assert_array_equal(neg, rn)
    np.testing.assert_array_equal(batches[0].net, rp[:3] - rn[:3])


def test_event_windows_match_a_binary_search_over_all_events(tmp_path):
    tr = make_strip_events(end_s=0.4, press_s=(0.1, 0.2), slip_s=(0.2, 0.3),
                           origin_us=1_234_567, seed=8)
    f = write_trials(tmp_path / "f.h5", {"t": tr})
    rng = np.random.default_rng(1)
    bounds = np.concatenate([[tr.t[0], tr.t[-1], tr.t[-1] + 1, tr.t[0] - 5_000, 0],
                             rng.integers(tr.t[0] - 2_000, tr.t[-1] + 2_000, 60),
                             tr.t[rng.integers(0, tr.t.size, 30)]])
    with TactileFile(f) as tf:
        te = tf.trial("t").events
        assert te.origin_us == 1_234_567
        for a, b in zip(bounds[::2], bounds[1::2], strict=False):
            lo, hi = int(min(a, b)), int(max(a, b))
            ev = te.window_us(lo, hi)
            i, j = np.searchsorted(tr.t, [lo, hi], side="left")
            np.testing.assert_array_equal(ev.t_us, tr.t[i:j])
            np.testing.assert_array_equal(ev.x, tr.x[i:j])
        w = te.window(0.1, 0.2)
        assert w.n == int(((tr.t >= 1_334_567) & (tr.t < 1_434_567)).sum())
