"""The slip signal (eq. 10), the adaptive threshold, decisions, scores and `tactile
slip-signal`."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

from tactile_cli.cli import app
from tactile_cli.errors import InputError
from tactile_cli.visuotactile.slip import (
    Rates,
    adaptive_threshold,
    best_scale,
    detect_slip,
    score_trial,
    slip_signal,
    slip_signal_file,
    trial_label,
)
from tests.factories.gel_frames import make_frames_file

runner = CliRunner()


def test_slip_signal_sums_absolute_changes_on_the_mesh() -> None:
    h = np.zeros((3, 6, 8))
    h[1, 1, 1] = 0.5       # a mesh unit of 4x3 (rows 1, 3, 5; cols 1, 3, 5, 7)
    h[2, 1, 1] = -0.25
    h[2, 0, 0] = 9.0       # not a unit of the 4x3 mesh
    s = slip_signal(h, (4, 3))
    assert np.isnan(s[0])
    np.testing.assert_allclose(s[1:], [0.5, 0.75])
    np.testing.assert_allclose(slip_signal(h)[1:], [0.5, 9.75])


def test_threshold_is_scale_times_static_mean_and_strict() -> None:
    s = np.r_[np.nan, np.full(30, 1.0), 2.0, 2.5, 1.0]
    assert adaptive_threshold(s) == pytest.approx(2.0)
    assert adaptive_threshold(s, n_static=2, scale=3.0) == pytest.approx(3.0)
    t = np.arange(s.size) / 30.0
    d = detect_slip(s, t)
    assert d.first_judged == 31
    assert d.detected and d.first_index == 32  # 2.0 equals the threshold: not a slip
    assert d.first_time_s == pytest.approx(32 / 30)
    assert d.peak_ratio() == pytest.approx(2.5)
    with pytest.raises(ValueError, match="needs 30 static"):
        adaptive_threshold(s[:20])
    with pytest.raises(ValueError, match="scale"):
        adaptive_threshold(s, scale=0.0)


def test_scores_onset_and_false_alarms() -> None:
    t = np.arange(60) / 30.0
    s = np.r_[np.nan, np.ones(59)]
    s[45] = 10.0
    d = detect_slip(s, t)
    hit = score_trial(d, slip=True, onset_s=t[45])
    assert hit.detected and not hit.false_alarm and hit.delay_s == 0.0
    late = score_trial(d, slip=True, onset_s=t[46])
    assert not late.detected and late.false_alarm
    fa = score_trial(d, slip=False, onset_s=None)
    assert fa.false_alarm and not fa.detected
    r = Rates.of([hit, fa])
    assert (r.n_slip, r.n_no_slip, r.detection_rate, r.false_alarms) == (1, 1, 1.0, 1)


def test_best_scale_separates_labelled_trials() -> None:
    t = np.arange(60) / 30.0
    slip = np.r_[np.nan, np.ones(59)]
    slip[50] = 6.0
    calm = np.r_[np.nan, np.ones(59)]
    calm[50] = 3.0  # a bump on the no-slip trial: scales below 3 call it a slip
    choice = best_scale([(slip, t), (calm, t)], [(True, t[50]), (False, None)])
    assert choice.rates.detection_rate == 1.0 and choice.rates.false_alarms == 0
    assert 3.0 <= choice.best_from and choice.best_to < 6.0
    assert choice.scale == pytest.approx(3.0)


def test_labels() -> None:
    assert trial_label({"slip": "no_slip"}, path="f", trial="a") == (False, None)
    assert trial_label({"slip": "slip", "slip_onset_s": 1.5}, path="f", trial="a") == (True, 1.5)
    assert trial_label({}, path="f", trial="a") == (None, None)
    with pytest.raises(InputError, match="slip_onset_s"):
        trial_label({"slip": "slip"}, path="f", trial="a")
    with pytest.raises(InputError, match="slip or no_slip"):
        trial_label({"slip": "maybe"}, path="f", trial="a")


@pytest.fixture(scope="module")
def frames_file(tmp_path_factory: pytest.TempPathFactory) -> Path:
    path = tmp_path_factory.mktemp("slip") / "frames.h5"
    make_frames_file(path, n_trials=4)
    return path


def test_intensity_source_detects_the_slips(frames_file: Path) -> None:
    res = slip_signal_file(frames_file, source="intensity", mesh=(16, 12))
    assert [t.source for t in res.trials] == ["intensity"] * 4
    by = {t.trial: t for t in res.trials}
    assert by["t_00"].score is not None and by["t_00"].score.detected
    assert by["t_00"].detection.first_time_s == pytest.approx(36 / 30)
    assert res.rates["intensity"].detection_rate == 1.0


def test_height_source_needs_a_model(frames_file: Path) -> None:
    with pytest.raises(InputError, match="run_dir"):
        slip_signal_file(frames_file, source="height")


@pytest.mark.slow
def test_cli_json_plot_and_errors(frames_file: Path, tmp_path: Path) -> None:
    res = runner.invoke(app, ["slip-signal", str(frames_file), "--source", "intensity",
                              "--mesh", "16x12", "--json", "--plot", str(tmp_path / "fig")])
    assert res.exit_code == 0, res.output
    d = json.loads(res.output)
    assert d["summary"]["intensity"]["detection_rate"] == 1.0
    t0 = d["trials"][0]
    assert t0["signal"][0] is None and len(t0["signal"]) == 45
    assert t0["threshold"] == pytest.approx(2 * np.mean(t0["signal"][1:31]))
    assert (tmp_path / "fig" / "slip_t_00_intensity.png").stat().st_size > 0
    res = runner.invoke(app, ["slip-signal", str(frames_file), "--source", "intensity"])
    assert res.exit_code == 0 and "detection rate" in res.output
    bad = runner.invoke(app, ["slip-signal", str(frames_file), "--mesh", "32by24"])
    assert bad.exit_code == 2 and "COLSxROWS" in bad.output
    bad = runner.invoke(app, ["slip-signal", str(frames_file), "--source", "height"])
    assert bad.exit_code == 2 and "--model" in bad.output
    bad = runner.invoke(app, ["slip-signal", str(frames_file), "--source", "intensity",
                              "--n-static", "50"])
    assert bad.exit_code == 2 and "50 static" in bad.output
    assert runner.invoke(app, ["slip-signal", "--help"]).exit_code == 0


def test_a_slip_without_its_onset_says_what_to_add():
    import pytest as _pytest

    from tactile_cli.errors import InputError as _InputError
    from tactile_cli.visuotactile.slip import trial_label

    assert trial_label({"slip": "slip", "slip_onset_s": "0.4"}, path="f.h5", trial="a") == (
        True, 0.4)
    assert trial_label({"slip": "no_slip"}, path="f.h5", trial="a") == (False, None)
    with _pytest.raises(_InputError) as err:
        trial_label({"slip": "slip"}, path="f.h5", trial="067_30_mm")
    assert str(err.value) == (
        "f.h5, /trials/067_30_mm/labels: slip trial '067_30_mm' has no numeric slip_onset_s "
        "label (=None): a slip is scored by the frame it is found at, so each trial labelled "
        "slip=slip needs its onset in seconds; add a slip_onset_s column to the table "
        "of trial labels the file was ingested with and ingest again, or decide whole lifts "
        "without onsets with `tactile slip-imprint`")
