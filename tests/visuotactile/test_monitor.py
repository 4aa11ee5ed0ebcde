"""The slip-avoidance state monitor and monitor manager (paper 002, sec. V): every
transition and edge, on hand-made signals at 30 Hz."""

from __future__ import annotations

import numpy as np
import pytest

from tactile_cli.errors import InputError
from tactile_cli.visuotactile.monitor import (
    MonitorManager,
    SlipMonitor,
    n_static_frames,
    replay,
    score_slips,
    static_threshold,
)
from tactile_cli.visuotactile.signals import moving_flags

RATE = 30.0


def kinds(events):
    return [e.kind for e in events]


def signal_with_peaks(n: int, peaks: dict[int, float], base: float = 0.1) -> np.ndarray:
    s = np.full(n, base)
    s[0] = np.nan
    for k, v in peaks.items():
        s[k] = v
    return s


def test_no_slip_to_slip_raises_grip_and_hold_timer_releases():
    mon = SlipMonitor(1.0, hold_s=3.0)
    assert mon.step(0.0, 0, 0.5) == []
    ev = mon.step(1.0, 30, 2.0)
    assert kinds(ev) == ["slip", "raise_grip"] and mon.mode == "slip"
    assert "2 > threshold 1" in ev[0].detail and ev[0].frame == 30 and ev[0].t_s == 1.0
    assert mon.step(3.9, 117, 0.5) == []  # 2.9 s quiet: still slip
    assert mon.mode == "slip"
    ev = mon.step(4.0, 120, 0.5)  # exactly hold_s after the last slip
    assert kinds(ev) == ["no_slip", "release_grip"] and mon.mode == "no_slip"


def test_threshold_exactly_equal_is_not_a_slip_and_nan_never_is():
    mon = SlipMonitor(1.0)
    assert mon.step(0.0, 0, 1.0) == [] and mon.mode == "no_slip"
    assert mon.step(0.1, 1, float("nan")) == [] and mon.mode == "no_slip"
    assert kinds(mon.step(0.2, 2, np.nextafter(1.0, 2.0))) == ["slip", "raise_grip"]


def test_new_slip_in_slip_mode_restarts_the_timer():
    mon = SlipMonitor(1.0, hold_s=3.0)
    mon.step(0.0, 0, 5.0)
    assert kinds(mon.step(2.5, 75, 5.0)) == ["timer_restart"]
    assert mon.step(5.4, 162, 0.0) == []  # 2.9 s after the restart, 5.4 s after the first
    assert kinds(mon.step(5.5, 165, 0.0)) == ["no_slip", "release_grip"]


def test_slip_at_exactly_hold_s_keeps_the_slip_mode():
    mon = SlipMonitor(1.0, hold_s=3.0)
    mon.step(0.0, 0, 5.0)
    assert kinds(mon.step(3.0, 90, 5.0)) == ["timer_restart"] and mon.mode == "slip"


def test_manager_ignores_slips_while_moving_and_judges_right_after():
    mgr = MonitorManager(SlipMonitor(1.0, hold_s=3.0), motion_s=0.5)
    assert kinds(mgr.step(1.0, 30, 5.0)) == ["slip", "raise_grip"]
    ev = mgr.step(1.2, 36, 5.0)  # gripper tightening: ignored, timer untouched
    assert kinds(ev) == ["ignored_moving"] and mgr.monitor.last_slip_s == 1.0
    assert mgr.step(1.4, 42, 0.5) == []  # below threshold while moving: nothing logged
    # the frame at 1.5 s shows the change since 1.4 s, when the gripper still moved
    assert kinds(mgr.step(1.5, 45, 5.0)) == ["ignored_moving"]
    # first frame whose change began after the motion: judged (a new slip restarts the timer)
    assert kinds(mgr.step(1.6, 48, 5.0)) == ["timer_restart"]


def test_slip_right_after_motion_ends_in_no_slip_mode_is_caught():
    mgr = MonitorManager(SlipMonitor(1.0, hold_s=3.0), motion_s=0.5)
    mgr.step(0.0, 0, 5.0)
    assert kinds(mgr.step(3.0, 90, 0.1)) == ["no_slip", "release_grip"]
    assert kinds(mgr.step(3.4, 102, 5.0)) == ["ignored_moving"]  # the release's own peak
    assert mgr.monitor.mode == "no_slip"
    assert kinds(mgr.step(3.5, 105, 5.0)) == ["ignored_moving"]  # change over 3.4-3.5 s
    assert kinds(mgr.step(3.6, 108, 5.0)) == ["slip", "raise_grip"]  # change after 3.5 s


def test_hold_timer_keeps_counting_while_the_gripper_moves():
    # a long motion: the release comes at hold_s although every frame is ignored
    mgr = MonitorManager(SlipMonitor(1.0, hold_s=3.0), motion_s=10.0)
    mgr.step(0.0, 0, 5.0)
    assert kinds(mgr.step(3.0, 90, 5.0)) == ["ignored_moving", "no_slip", "release_grip"]


def test_per_frame_gripper_flags_override_the_motion_model():
    mgr = MonitorManager(SlipMonitor(1.0), motion_s=0.5)
    assert kinds(mgr.step(0.0, 0, 5.0, gripper_moving=True)) == ["ignored_moving"]
    mgr.step(1.0, 30, 5.0, gripper_moving=False)
    assert mgr.monitor.mode == "slip"
    # the model would call this frame "moving" (0.1 s after the command); the flag wins
    assert kinds(mgr.step(1.1, 33, 5.0, gripper_moving=False)) == ["timer_restart"]


def test_release_peak_is_not_a_slip_with_the_manager_but_is_without():
    """Fig. 14: each interference gives a pair of peaks; the second (the grip released)
    is ignored by the manager. Without it (motion_s=0) it is taken for a new slip and the
    grip is never released for long."""
    n = int(12 * RATE)
    t = np.arange(n) / RATE
    s = signal_with_peaks(n, {60: 3.0})  # slip at 2.0 s
    # the simulated gripper answers: tightening 2.0-2.5 s, loosening from the release on
    s[61:75] = 2.5
    release = 60 + int(3.0 * RATE)  # 3 s after the last judged slip
    s[release + 1:release + 12] = 2.5  # the second peak
    with_mgr = replay(s, t, threshold=1.0, motion_s=0.5)
    assert kinds(with_mgr.of_kind("slip", "raise_grip", "no_slip", "release_grip")) == [
        "slip", "raise_grip", "no_slip", "release_grip"]
    assert with_mgr.of_kind("release_grip")[0].frame == release
    ignored = [e.frame for e in with_mgr.of_kind("ignored_moving")]
    assert set(range(release + 1, release + 12)) <= set(ignored)
    assert set(range(61, 75)) <= set(ignored)
    assert with_mgr.mode[release - 1] and not with_mgr.mode[release:].any()
    assert with_mgr.moving[61:75].all() and not with_mgr.moving[76:release].any()
    without = replay(s, t, threshold=1.0, motion_s=0.0)
    # the tightening (and the later peak) taken for slips: the release delayed by them
    assert [e.frame for e in without.of_kind("timer_restart")][:14] == list(range(61, 75))
    assert without.of_kind("release_grip")[0].frame == release + 11 + 90
    s_quiet_tightening = s.copy()
    s_quiet_tightening[61:75] = 0.1
    without = replay(s_quiet_tightening, t, threshold=1.0, motion_s=0.0)
    assert without.of_kind("release_grip")[0].frame == release
    assert [e.frame for e in without.of_kind("raise_grip")] == [60, release + 1]


def test_end_of_recording_in_slip_mode():
    n = int(3 * RATE)
    t = np.arange(n) / RATE
    res = replay(signal_with_peaks(n, {75: 3.0}), t, threshold=1.0)
    assert kinds(res.events) == ["slip", "raise_grip"]
    assert res.mode[-1] and res.mode[75:].all() and not res.mode[:75].any()


def test_adaptive_threshold_request_starts_the_monitor_after_the_static_frames():
    n = 120
    t = np.arange(n) / RATE
    rng = np.random.default_rng(0)
    s = 0.1 + 0.02 * rng.random(n)
    s[0] = np.nan
    s[20] = 5.0  # a peak inside the static second is part of the mean, not a slip
    s[80] = 5.0
    res = replay(s, t)
    assert res.start_frame == 31 == n_static_frames(s, 30)
    assert res.threshold == pytest.approx(2.0 * np.mean(s[1:31]))
    assert [e.frame for e in res.of_kind("slip")] == [80]
    assert res.threshold == pytest.approx(static_threshold(s))


def test_too_few_static_frames_is_a_clear_error():
    s = np.full(20, 0.1)
    s[0] = np.nan
    with pytest.raises(InputError, match="needs 30 static slip signals but the recording "
                       "has 19 .20 frames."):
        replay(s, np.arange(20) / RATE)


@pytest.mark.parametrize("kwargs, message", [
    ({"threshold": -1.0}, "`threshold` .=-1.0. must be a finite non-negative"),
    ({"threshold": 1.0, "hold_s": 0.0}, "`hold_s` .=0.0. must be a finite positive"),
    ({"threshold": 1.0, "motion_s": float("nan")}, "`motion_s` .=nan. must be"),
    ({"threshold": 1.0, "gripper_moving": [True] * 3}, "`gripper_moving` .3,. must match"),
])
def test_bad_arguments_are_input_errors(kwargs, message):
    with pytest.raises(InputError, match=message):
        replay(np.zeros(10), np.arange(10) / RATE, **kwargs)


def test_score_slips_counts_caught_missed_false_and_delay():
    score = score_slips(np.array([1.1, 1.2, 4.0, 9.3]), [1.0, 6.0, 9.3], match_s=0.5)
    assert (score.caught, score.missed, score.false_slips) == (2, 1, 1)
    assert score.delays_s == pytest.approx([0.1, 0.0])
    assert score_slips(np.array([2.0]), []).false_slips == 1
    # a slow slip judged until it ends is one interference, not false slips
    slow = score_slips(np.array([1.1, 2.0, 2.9, 3.6]), [1.0], ends_s=[3.0], match_s=0.5)
    assert (slow.caught, slow.false_slips) == (1, 1) and slow.delays_s == pytest.approx([0.1])
    assert score_slips(np.array([2.0]), [1.0], ends_s=[None]).false_slips == 1


@pytest.mark.parametrize("motion_s", [0.3, 0.31, 0.01])
def test_motion_intervals_give_the_same_frames_as_the_manager_model(motion_s):
    """Flags from `gripper_moving` intervals (as the avoidance scene writes them) and the
    manager's own motion_s model skip exactly the same frames."""
    n = int(10 * RATE)
    t = np.arange(n) / RATE
    s = signal_with_peaks(n, {45: 3.0, 50: 3.0, 200: 3.0})
    model = replay(s, t, threshold=1.0, motion_s=motion_s)
    commands = [e.t_s for e in model.of_kind("raise_grip", "release_grip")]
    assert len(commands) >= 3
    flags = moving_flags(t, [(c, c + motion_s) for c in commands])
    assert np.array_equal(flags, model.moving)
    with_flags = replay(s, t, threshold=1.0, motion_s=99.0, gripper_moving=flags)
    assert with_flags.events == model.events


def test_hold_timer_is_not_moved_by_rounded_frame_times():
    # 9.966667 - 6.966667 is 2.9999999999999996 in floating point: still hold_s
    mon = SlipMonitor(1.0, hold_s=3.0)
    mon.step(6.966667, 209, 5.0)
    assert 9.966667 - 6.966667 < 3.0
    assert kinds(mon.step(9.966667, 299, 0.0)) == ["no_slip", "release_grip"]


@pytest.mark.parametrize("px", ["NaN", "-16", "\"wide\""])
def test_a_scene_folder_with_a_bad_px_per_mm_is_one_input_error(tmp_path, px):
    """Found by the damaged-input corpus: `tactile monitor SCENE` took optics.px_per_mm NaN
    from scene.json without a word (and a text value ended in a ValueError)."""
    from tactile_cli.errors import InputError
    from tactile_cli.visuotactile.monitor_replay import frames_folder_plan

    (tmp_path / "trials").mkdir()
    (tmp_path / "scene.json").write_text('{"optics": {"px_per_mm": ' + px + '}}')
    with pytest.raises(InputError, match="px_per_mm") as err:
        frames_folder_plan(tmp_path)
    assert "scene.json" in str(err.value) and "\n" not in str(err.value)
