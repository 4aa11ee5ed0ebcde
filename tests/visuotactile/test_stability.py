"""Stability of the slip signal (item 7): perturbations, breaking points, a tiny run and
the benchmark's --quick mode."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from tactile_cli.visuotactile.config import DigitSceneConfig
from tactile_cli.visuotactile.stability import (
    LevelResult,
    breaking_points,
    linear_gain,
    run_stability,
    with_noise,
)

ROOT = Path(__file__).resolve().parents[2]
TINY = {"optics": {"width_px": 80, "height_px": 60, "px_per_mm": 4.0},
        "trials": {"objects": ["cable"], "per_object": 3, "directions": ["-y", "+x"]}}


def test_linear_gain_scales_in_the_linear_domain():
    frames = np.full((2, 3, 4, 3), 100, dtype=np.uint8)
    out = linear_gain(frames, np.array([1.0, 1.21]), gamma=2.0)
    np.testing.assert_allclose(out[0], 100.0)
    np.testing.assert_allclose(out[1], 110.0, rtol=1e-6)  # 1.21 ** (1 / 2) = 1.1


def test_with_noise_has_the_asked_spread_and_zero_is_exact():
    values = np.full((200, 200), 128, dtype=np.uint8)
    rng = np.random.default_rng(0)
    assert np.array_equal(with_noise(values, 0.0, rng), values)
    noisy = with_noise(values, 8.0, rng).astype(float)
    assert noisy.std() == pytest.approx(8.0, rel=0.05)
    assert noisy.mean() == pytest.approx(128.0, abs=0.2)


def _row(axis, level, det, fa, source="intensity"):
    broken = det < 0.95 or fa > 0.05
    return LevelResult(axis, source, level, 10, 10, det, fa, None, broken)


def test_breaking_point_is_the_first_broken_level_away_from_the_baseline():
    rows = [_row("noise", 0.0, 1.0, 0.5), _row("noise", 2.0, 1.0, 0.0),
            _row("noise", 4.0, 0.9, 0.0), _row("noise", 8.0, 1.0, 0.0),
            _row("mesh", "32x24", 1.0, 0.0), _row("mesh", "4x3", 1.0, 0.1),
            _row("drift", 0.1, 1.0, 0.0)]
    bp = breaking_points(rows, baseline_noise=2.0)
    assert bp == {"noise": {"intensity": 4.0}, "mesh": {"intensity": "4x3"},
                  "drift": {"intensity": None}}
    assert _row("x", 1, 0.95, 0.05).broken is False  # limits themselves are not broken


@pytest.fixture(scope="module")
def tiny():
    cfg = DigitSceneConfig.model_validate(TINY)
    levels = {"noise": (2.0, 64.0), "drift": (0.5,), "step": (0.2,), "mesh": ((16, 12),)}
    return run_stability(cfg, [101], levels=levels), cfg, levels


@pytest.mark.slow
def test_tiny_run_detects_at_baseline_and_breaks_under_heavy_noise(tiny):
    result, cfg, levels = tiny
    assert result.n_trials == 3 and result.seeds == [101]
    rows = {(r.axis, r.level): r for r in result.results}
    assert set(rows) == {("noise", 2.0), ("noise", 64.0), ("drift", 0.5), ("step", 0.2),
                         ("mesh", "16x12")}
    base = rows[("noise", 2.0)]
    assert (base.n_slip, base.n_no_slip) == (2, 1)
    assert base.detection_rate == 1.0 and base.false_alarm_rate == 0.0 and not base.broken
    assert rows[("noise", 64.0)].detection_rate < 0.95
    assert result.breaking_points["noise"]["intensity"] == 64.0
    # deterministic: the same seeds give the same rates
    again = run_stability(cfg, [101], levels=levels)
    assert [r.as_dict() for r in again.results] == [r.as_dict() for r in result.results]


@pytest.mark.slow
def test_benchmark_quick_writes_png_and_json(tmp_path):
    out = tmp_path / "stab.png"
    res = subprocess.run([sys.executable, str(ROOT / "benchmarks" / "visuotactile_stability.py"),
                          "--quick", "--json", "--out", str(out)], capture_output=True,
                         text=True, timeout=120)
    assert res.returncode == 0, res.stderr
    data = json.loads(res.stdout)
    assert out.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert json.loads(out.with_suffix(".json").read_text())["results"] == data["results"]
    assert data["baseline"]["intensity"]["level"] == 2.0
    assert {"breaking_points", "seeds", "elapsed_s", "load_1min"} <= set(data)
    assert all(r["detection_ratio"] is not None for r in data["results"])


def test_unknown_axis_is_refused_before_any_work():
    with pytest.raises(ValueError, match="names 'light'; axes are noise, drift, step, mesh"):
        run_stability(DigitSceneConfig.model_validate(TINY), [101], axes=["noise", "light"])
