"""Imprint retention (``tactile slip-imprint``): a held object's imprint stays where the
grasp put it, a slipping one slides or fades; the threshold is learned by leave one object
out, and bad settings are refused in one line."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

from tactile_cli.cli import app
from tactile_cli.errors import InputError
from tactile_cli.store import StoreWriter
from tactile_cli.visuotactile.imprint import (
    best_threshold,
    imprint_change,
    mesh_means,
    slip_imprint_file,
    threshold_by_cv,
)
from tests.factories.gel_frames import shade, sphere_cap

runner = CliRunner()
SHAPE = (48, 64)


def _lift_heights(kind: str, n_frames: int = 18, *, x0: float = 30.0) -> np.ndarray:
    """(n, H, W) mm: no contact for 3 frames, a grasp pressing in over frames 3-8, then a
    lift: ``held`` deepens in place, ``slide`` moves 2 px a frame, ``fade`` shallows."""
    out = np.zeros((n_frames, *SHAPE))
    for k in range(3, n_frames):
        depth = 0.5 * min(1.0, (k - 2) / 6)
        x = x0
        if k > 10:
            if kind == "held":
                depth += 0.01 * (k - 10)
            elif kind == "slide":
                x += 2.0 * (k - 10)
            elif kind == "fade":
                depth *= max(0.05, 1 - 0.15 * (k - 10))
        out[k] = sphere_cap(SHAPE, (x, 24.0), 2.0, depth)
    return out


def _lifts_file(path: Path, kinds: list[tuple[str, str, str]]) -> Path:
    """Trials (name, object, kind): label slip=no_slip for ``held``, slip otherwise."""
    rng = np.random.default_rng(0)
    with StoreWriter(path, command="tests.visuotactile.test_imprint") as wr:
        s = wr.add_sensor("gel", kind="visuotactile", sample_rate_hz=30.0, width_px=SHAPE[1],
                          height_px=SHAPE[0])
        reference = shade(np.zeros(SHAPE), noise_std=1.0, rng=rng)
        for name, obj, kind in kinds:
            heights = _lift_heights(kind, x0=26.0 + 4 * rng.random())
            labels = {"object": obj, "slip": "no_slip" if kind == "held" else "slip",
                      "outcome": "ok" if kind == "held" else "fail"}
            if kind != "held":
                labels["slip_onset_s"] = 0.0
            t = wr.trial(name, labels=labels)
            t.write_frames(sensor=s, images=shade(heights, noise_std=1.0, rng=rng),
                           t_s=np.arange(len(heights)) / 30.0, reference=reference)
        wr.commit()
    return path


def test_mesh_means_are_cell_averages_and_a_too_dense_mesh_is_refused() -> None:
    maps = np.arange(2 * 4 * 6, dtype=np.float64).reshape(2, 4, 6)
    got = mesh_means(maps, (3, 2))
    assert got.shape == (2, 2, 3)
    assert got[1, 1, 2] == pytest.approx(maps[1, 2:4, 4:6].mean())
    with pytest.raises(ValueError, match="does not fit maps of 6x4 px"):
        mesh_means(maps, (7, 2))


def test_a_held_imprint_is_kept_and_a_sliding_or_fading_one_is_not() -> None:
    held = imprint_change(_lift_heights("held"), mesh=(16, 12))
    slide = imprint_change(_lift_heights("slide"), mesh=(16, 12))
    fade = imprint_change(_lift_heights("fade"), mesh=(16, 12))
    # grasp part: ceil(2/3 * 18) = 12 frames; held deepens, so its grasp frame is the last
    assert held.grasp_index == 11 and slide.grasp_index == 8  # first frame at full depth
    assert held.change < 0.01  # the contact widens a little as it deepens
    assert slide.change > 0.5 and fade.change > 0.5  # a fading cap shrinks its circle
    assert np.isnan(held.retention[: held.grasp_index + 1]).all()
    assert held.retention[-1] == pytest.approx(1 - held.change)
    with pytest.raises(ValueError, match="between 0 and 1"):
        imprint_change(_lift_heights("held"), grasp_part=1.0)
    with pytest.raises(ValueError, match="no contact imprint"):
        imprint_change(np.zeros((6, 12, 16)), mesh=(16, 12))


def test_a_reference_from_another_time_is_removed_by_the_first_frame_baseline() -> None:
    """A reference frame taken at another time adds one pattern to every map; taken
    relative to the first (no-contact) frame, the change is the same as without it."""
    pattern = sphere_cap(SHAPE, (12.0, 12.0), 3.0, 0.6)  # an old dent in the reference
    for kind in ("held", "slide"):
        clean = imprint_change(_lift_heights(kind), mesh=(16, 12)).change
        drifted = _lift_heights(kind) + pattern
        assert imprint_change(drifted, mesh=(16, 12)).change == pytest.approx(clean)
        as_given = imprint_change(drifted, mesh=(16, 12), baseline="reference").change
        if kind == "slide":  # the shared pattern props up the correlation: a slip hidden
            assert as_given < 0.5 * clean
    with pytest.raises(ValueError, match="`baseline`"):
        imprint_change(_lift_heights("held"), baseline="last")


def test_best_threshold_sits_in_the_gap_and_cv_scores_each_group_held_out() -> None:
    changes = [0.001, 0.004, 0.02, 0.08, 0.3, 0.002, 0.006, 0.06, 0.2]
    slipped = [False, False, False, True, True, False, False, True, True]
    choice = best_threshold(changes, slipped)
    assert choice.threshold == pytest.approx((0.02 + 0.06) / 2)
    assert choice.correct == 9
    # any threshold from the largest held change up to the smallest slip decides alike
    assert (choice.lo, choice.hi) == (0.02, 0.06)
    groups = ["a"] * 5 + ["b"] * 4
    cv = threshold_by_cv(changes, slipped, groups)
    # fold a is chosen on b (gap 0.006 .. 0.06): a's 0.02 is held, right; fold b on a's
    # gap 0.02 .. 0.08
    assert [f.threshold for f in cv.folds] == pytest.approx([0.033, 0.05])
    assert cv.correct == 9 and cv.n_trials == 9 and cv.interval[0] > 0.6
    # a group whose held trial sits above the other group's slips is decided wrong
    worse = threshold_by_cv([0.001, 0.3, 0.2, 0.25], [False, True, False, True], ["a", "a",
                            "b", "b"])
    assert worse.folds[1].correct == 1 and worse.correct == 3
    with pytest.raises(ValueError, match="at least two groups"):
        threshold_by_cv(changes, slipped, ["a"] * 9)


def test_slip_imprint_decides_held_out_objects_and_reports_json(tmp_path: Path) -> None:
    path = _lifts_file(tmp_path / "lifts.h5", [
        ("a0", "obj_a", "held"), ("a1", "obj_a", "slide"), ("a2", "obj_a", "fade"),
        ("b0", "obj_b", "held"), ("b1", "obj_b", "slide"), ("b2", "obj_b", "held")])
    res = slip_imprint_file(path, mesh=(16, 12))
    cv = res.threshold_cv
    assert cv is not None and cv.group_by == "object" and len(cv.folds) == 2
    assert cv.correct == 6
    assert [t.decided_slip for t in res.trials] == [False, True, True, False, True, False]
    out = runner.invoke(app, ["slip-imprint", str(path), "--mesh", "16x12", "--label",
                              "outcome", "--json", "--plot", str(tmp_path / "i.png")])
    assert out.exit_code == 0, out.output
    d = json.loads(out.output)
    assert d["threshold"] == "auto" and d["threshold_cv"]["cv_correct"] == 6
    assert d["accuracy_is_in_sample"] is True
    assert (tmp_path / "i.png").stat().st_size > 0
    text = runner.invoke(app, ["slip-imprint", str(path), "--mesh", "16x12", "--threshold",
                               str(cv.threshold)])
    assert "6/6 (threshold given, not tuned here)" in text.output


@pytest.mark.parametrize(("args", "message"), [
    (["--grasp-part", "1.2"], "--grasp-part (=1.2) must be between 0 and 1"),
    (["--threshold", "high"], "--threshold (='high') must be a number or 'auto'"),
    (["--label", "object"], "has label object='obj_a'; expected one of"),
    (["--label", "missing"], "--threshold auto needs labelled trials of both classes"),
    (["--mesh", "9000x2"], "the mesh 9000x2 does not fit maps of 64x48 px"),
    (["--baseline", "median"], "--baseline (='median') must be one of first, reference"),
])
def test_bad_settings_are_one_line_errors(tmp_path: Path, args: list[str],
                                          message: str) -> None:
    path = _lifts_file(tmp_path / "lifts.h5", [("a0", "obj_a", "held"),
                                               ("b0", "obj_b", "slide")])
    res = runner.invoke(app, ["slip-imprint", str(path), *args])
    assert res.exit_code == 2, res.output
    assert message in res.output and "Traceback" not in res.output


def test_an_existing_plot_is_kept_without_overwrite(tmp_path: Path) -> None:
    path = _lifts_file(tmp_path / "lifts.h5", [("a0", "obj_a", "held"),
                                               ("b0", "obj_b", "slide")])
    png = tmp_path / "keep.png"
    png.write_bytes(b"old")
    with pytest.raises(InputError, match="exists; pass `overwrite`"):
        slip_imprint_file(path, mesh=(16, 12), threshold=0.1, plot=png)
    assert png.read_bytes() == b"old"
    before = path.read_bytes()
    res = runner.invoke(app, ["slip-imprint", str(path), "--threshold", "0.1", "--mesh",
                              "16x12", "--plot", str(path), "--overwrite"])
    assert res.exit_code == 2 and "--plot" in res.output, res.output
    assert path.read_bytes() == before  # the recording is never the plot


@pytest.mark.parametrize("dtype", [np.uint8, np.uint16, np.float32])
def test_the_fast_channel_mean_equals_numpys_bit_for_bit(dtype: type) -> None:
    from tactile_cli.visuotactile.signals import _channel_mean

    rng = np.random.default_rng(3)
    top = 256 if dtype is np.uint8 else 65536
    images = rng.integers(0, top, (2, 7, 9, 3)).astype(dtype)
    assert np.array_equal(_channel_mean(images), images.mean(axis=-1, dtype=np.float32))
