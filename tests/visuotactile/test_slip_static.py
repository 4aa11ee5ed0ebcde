"""Issue 35, item 3: the slip signal says when its static frames were not static, and
learns its threshold scale from labelled trials (``--scale auto``, leave one group out)."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

from tactile_cli.cli import app
from tactile_cli.errors import InputError
from tactile_cli.visuotactile.slip import (
    check_static,
    detect_slip,
    parse_scale,
    scale_by_cv,
    slip_signal_file,
    wilson_interval,
)
from tests.factories.gel_frames import make_frames_file

runner = CliRunner()


def test_static_noise_passes_and_motion_is_flagged_with_its_reason() -> None:
    rng = np.random.default_rng(0)
    noise = np.r_[np.nan, 10 + rng.normal(0, 1, 20)]
    ok = check_static(noise, n_static=10)
    assert ok.static and ok.reason is None and ok.spread is not None and ok.spread < 0.2
    ramp = np.r_[np.nan, np.linspace(1, 8, 10), np.full(10, 8.0)]
    bad = check_static(ramp, n_static=10)
    assert not bad.static and bad.rise == pytest.approx(8.0)
    assert "rise 8.0 x" in bad.reason and "motion in the first frames" in bad.reason
    jump = np.r_[np.nan, np.ones(5), 9.0, np.ones(5)]
    flagged = check_static(jump, n_static=6)
    assert not flagged.static and "above the threshold" in flagged.reason
    assert "spread" in flagged.reason
    one = check_static(np.r_[np.nan, 3.0, 4.0], n_static=1)
    assert one.static and one.spread is None
    assert detect_slip(ramp, np.arange(ramp.size) / 30, n_static=10).static == bad


def test_a_non_static_start_is_flagged_per_trial_and_in_json(tmp_path: Path) -> None:
    path = tmp_path / "frames.h5"
    make_frames_file(path, n_trials=2, n_frames=14, onset_frame=3)  # t_00 slips at frame 3
    res = runner.invoke(app, ["slip-signal", str(path), "--source", "intensity", "--mesh",
                              "16x12", "--n-static", "6", "--json"])
    assert res.exit_code == 0, res.output
    d = json.loads(res.output)
    by = {t["trial"]: t for t in d["trials"]}
    assert by["t_00"]["static"] is False and "rise" in by["t_00"]["static_reason"]
    assert by["t_01"]["static"] is True and by["t_01"]["static_reason"] is None
    assert d["summary"]["intensity"]["n_not_static"] == 1
    text = runner.invoke(app, ["slip-signal", str(path), "--source", "intensity", "--mesh",
                               "16x12", "--n-static", "6"])
    assert "the static frames were not static in 1 of 2 trials (t_00:" in text.output


def _trial(rng: np.random.Generator, peak: float) -> tuple[np.ndarray, np.ndarray]:
    s = np.r_[np.nan, 1 + 0.05 * rng.standard_normal(10), 1 + 0.05 * rng.standard_normal(5)]
    s[13] = peak  # the largest judged signal over a static mean of about 1
    return s, np.arange(s.size) / 30.0


def test_scale_auto_recovers_a_threshold_that_separates_labelled_trials() -> None:
    rng = np.random.default_rng(1)
    signals, labels, groups = [], [], []
    for g in range(4):  # four objects, each one slip (peak 6) and one hold (peak 3)
        for slip, peak in ((True, 6.0), (False, 3.0)):
            signals.append(_trial(rng, peak + 0.3 * rng.random()))
            labels.append((slip, 0.0 if slip else None))
            groups.append(f"obj{g}")
    cv = scale_by_cv(signals, labels, groups, n_static=10)
    ratios = [detect_slip(s, t, n_static=10).peak_ratio() for s, t in signals]
    top_hold = max(r for r, (slip, _) in zip(ratios, labels, strict=True) if not slip)
    low_slip = min(r for r, (slip, _) in zip(ratios, labels, strict=True) if slip)
    assert top_hold < cv.best_from <= cv.scale <= cv.best_to < low_slip
    assert cv.scale == pytest.approx((cv.best_from + cv.best_to) / 2, abs=0.06)
    assert cv.group_by == "object" and [f.group for f in cv.folds] == [f"obj{g}"
                                                                       for g in range(4)]
    assert all(top_hold < f.scale < low_slip and f.correct == 2 for f in cv.folds)
    assert cv.rates.accuracy == 1.0 and cv.rates.correct == 8
    assert cv.accuracy_interval == pytest.approx(wilson_interval(8, 8))
    assert cv.accuracy_interval[0] == pytest.approx(0.6756, abs=1e-3)
    with pytest.raises(ValueError, match="at least two groups"):
        scale_by_cv(signals, labels, ["one"] * len(signals), n_static=10)


def test_scale_auto_on_a_file_and_its_errors(tmp_path: Path) -> None:
    path = tmp_path / "frames.h5"
    make_frames_file(path, n_trials=4, n_frames=14, onset_frame=8)  # one object: 'ball'
    res = slip_signal_file(path, source="intensity", mesh=(16, 12), n_static=5, scale="auto")
    cv = res.scale_cv["intensity"]
    assert cv.group_by == "trial" and len(cv.folds) == 4  # no two objects: trial groups
    assert all(t.detection.threshold == pytest.approx(
        cv.scale * np.mean(t.detection.signal[1:6])) for t in res.trials)
    assert res.as_dict(with_signal=False)["scale"] == "auto"
    assert parse_scale("AUTO") == "auto" and parse_scale("2.5") == 2.5
    with pytest.raises(InputError, match="positive number or 'auto'"):
        parse_scale("-1")
    bad = runner.invoke(app, ["slip-signal", str(path), "--scale", "fast"])
    assert bad.exit_code == 2
    assert bad.output.strip().splitlines()[-1] == (
        "tactile: error: --scale (='fast') must be a positive number or 'auto'")
