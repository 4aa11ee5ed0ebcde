"""Issue 12, item 3: step regions found in a sampled signal (``fit-fos --stream NAME
--regions detect``), pulse fits of a press and its release, and the order verdict that
tells a relaxing press from a first-order one.

Known truth everywhere: the signals are first-order steps (or two-mode relaxations) with
onsets, gains and time constants drawn per channel, plus white noise; the detector must find
the onsets to within a sample or two (a fifth of tau for slow rises in noise) and the fits
must recover the parameters.
"""

from __future__ import annotations

import json

import numpy as np
import pytest
from typer.testing import CliRunner

from tactile_cli.cli import app
from tactile_cli.fos.step_detect import detect_steps, noise_sigma
from tactile_cli.store import StoreWriter

from ..factories.fos_counts import use_test_compilation_cache
from .stream_steps import PRESS, write_stream_file

runner = CliRunner()
RATE_HZ = 200.0


@pytest.fixture(scope="module", autouse=True)
def _compilation_cache():
    use_test_compilation_cache()


def _step(t, onset, alpha, tau):
    return np.where(t >= onset, alpha * -np.expm1(-np.clip(t - onset, 0, None) / tau), 0.0)


# -- the detector on arrays -------------------------------------------------------------

@pytest.mark.parametrize("seed", range(12))
def test_onset_found_near_the_true_one(seed):
    rng = np.random.default_rng(100 + seed)
    t = np.arange(0, 3, 1 / RATE_HZ)
    onset = rng.uniform(0.3, 1.5)
    alpha, tau = rng.uniform(0.5, 3) * rng.choice([-1, 1]), rng.uniform(0.01, 0.3)
    noise = abs(alpha) / rng.uniform(30, 200)
    x = 4.0 + _step(t, onset, alpha, tau) + rng.normal(0, noise, t.size)
    steps = detect_steps(t, x)
    assert len(steps) == 1
    # a slow rise in noise starts at a less sharp point: within 1.5 samples or a fifth of tau
    assert abs(steps[0].start_s - onset) <= max(1.5 / RATE_HZ, 0.2 * tau)
    assert steps[0].label == ("rise" if alpha > 0 else "fall")
    assert steps[0].end_s == pytest.approx(t[-1] + 1 / RATE_HZ)


def test_noise_alone_has_no_step():
    t = np.arange(0, 5, 1 / RATE_HZ)
    rng = np.random.default_rng(7)
    found = [detect_steps(t, rng.normal(0, 1, t.size)) for _ in range(50)]
    assert sum(len(f) for f in found) == 0
    assert detect_steps(t, np.zeros_like(t)) == []


def test_relaxation_is_not_a_second_step_but_a_release_is():
    t = np.arange(0, 3, 1 / RATE_HZ)
    rng = np.random.default_rng(3)
    x = (_step(t, 0.5, 2.0, 0.04) - _step(t, 0.5, 0.6, 0.5) - _step(t, 2.0, 1.4, 0.04)
         + rng.normal(0, 0.02, t.size))
    steps = detect_steps(t, x)
    assert [s.label for s in steps] == ["rise", "fall"]
    assert abs(steps[0].start_s - 0.5) <= 1 / RATE_HZ and abs(steps[1].start_s - 2.0) <= 1 / RATE_HZ
    assert steps[0].end_s == steps[1].start_s


def test_quantised_counts_have_a_noise_floor():
    t = np.arange(0, 2, 1 / RATE_HZ)
    x = np.round(_step(t, 1.0, 40.0, 0.05))  # ADC counts, no noise: MAD of diffs is 0
    assert noise_sigma(x) == pytest.approx(0.25)
    steps = detect_steps(t, x)
    assert len(steps) == 1 and abs(steps[0].start_s - 1.0) <= 1 / RATE_HZ


# -- through the command ----------------------------------------------------------------

def _fit(path, *args):
    result = runner.invoke(app, ["fit-fos", str(path), "--stream", "taxels", *args, "--json"])
    assert result.exit_code == 0, result.output
    return json.loads(result.stdout)


@pytest.mark.slow
def test_detected_regions_recover_the_steps(tmp_path):
    path = tmp_path / "bare.h5"
    truth = write_stream_file(path, n_trials=3, annotate=False, seed=11)
    out = _fit(path, "--regions", "detect")
    region = out["regions"]["taxels"]
    # the temperature channel holds no step: named, not fitted, not an error
    assert region["no_step"] == [f"trial_{k}/temp" for k in range(3)]
    fits = {(f["trial"], f["channel"]): f for f in region["fits"]}
    assert len(fits) == len(truth)
    for tr in truth:
        f = fits[(tr["trial"], tr["channel"])]
        assert f["region"] == "rise" and f["status"] == "converged"
        assert abs(f["region_start_s"] - PRESS[0]) <= 1 / RATE_HZ + 1e-9
        assert f["tau_s"] == pytest.approx(tr["tau_s"], rel=0.05)
        assert f["alpha"] == pytest.approx(tr["alpha"], abs=0.03)
    result = runner.invoke(app, ["fit-fos", str(path), "--stream", "taxels", "--regions",
                                 "detect", "--channels", "fz_0,temp"])
    assert result.exit_code == 0, result.output
    assert "no step found (not fitted) in 3 curve(s): trial_0/temp" in result.output


def test_no_step_anywhere_is_one_line(tmp_path):
    path = tmp_path / "bare.h5"
    write_stream_file(path, n_trials=1, annotate=False)
    result = runner.invoke(app, ["fit-fos", str(path), "--stream", "taxels", "--regions",
                                 "detect", "--channels", "temp"])
    assert result.exit_code == 2
    assert "no step found in stream 'taxels'" in result.output
    assert "--min-snr" in result.output and len(result.output.strip().splitlines()) == 1


def _press_file(path, rows):
    """One trial per row of (alpha N, tau s, relax fraction, relax tau s, release s|None)."""
    t = np.arange(0, 3, 1 / RATE_HZ)
    rng = np.random.default_rng(5)
    with StoreWriter(path, command="test") as w:
        sensor = w.add_sensor("pad", kind="taxel_array", sample_rate_hz=RATE_HZ,
                              channel_names=["fz"], channel_units=["N"])
        for k, (alpha, tau, frac, tau_r, release) in enumerate(rows):
            x = _step(t, 0.5, alpha, tau) - _step(t, 0.5, frac * alpha, tau_r)
            if release is not None:  # the press ends: its response decays (eq. 16)
                x = _step(t, 0.5, alpha, tau) - _step(t, release, alpha, tau)
            x = x + 0.2 + rng.normal(0, 0.01, t.size)
            w.trial(f"trial_{k}").write_signal("taxels", sensor=sensor, data=x[:, None], t_s=t)
        w.commit()


@pytest.mark.slow
def test_relaxing_presses_are_flagged_not_first_order(tmp_path):
    path = tmp_path / "relax.h5"
    rows = [(2.0, 0.03, 0.3, 0.4, None), (1.5, 0.05, 0.2, 0.8, None),
            (2.0, 0.04, 0.0, 1.0, None), (1.0, 0.08, 0.0, 1.0, None)]
    _press_file(path, rows)
    fits = _fit(path, "--regions", "detect")["regions"]["taxels"]["fits"]
    verdicts = [f["order_verdict"] for f in fits]
    assert verdicts[:2] == ["relaxation", "relaxation"]
    assert verdicts[2] in ("first_order", "undecided") and verdicts[3] in ("first_order",
                                                                           "undecided")
    for f, (_, tau, frac, tau_r, _) in zip(fits[:2], rows[:2], strict=True):
        assert f["relax_fraction"] == pytest.approx(frac, abs=0.02)
        assert f["relax_tau_s"] == pytest.approx(tau_r, rel=0.05)
        assert f["rise_tau_s"] == pytest.approx(tau, rel=0.05)
    for f in fits[2:]:
        assert f["relax_fraction"] is None
    result = runner.invoke(app, ["fit-fos", str(path), "--stream", "taxels", "--regions",
                                 "detect"])
    assert "relaxation (30 % over 0.4" in result.output


@pytest.mark.slow
def test_pulse_joins_a_press_and_its_release(tmp_path):
    path = tmp_path / "pulse.h5"
    rows = [(2.0, 0.05, 0.0, 1.0, 1.7), (1.2, 0.1, 0.0, 1.0, 2.1)]
    _press_file(path, rows)
    fits = _fit(path, "--regions", "detect", "--model", "pulse")["regions"]["taxels"]["fits"]
    assert [f["region"] for f in fits] == ["pulse", "pulse"]
    for f, (alpha, tau, _, _, release) in zip(fits, rows, strict=True):
        assert f["status"] == "converged" and f["model"] == "pulse"
        assert f["duration_s"] == pytest.approx(release - 0.5, abs=1.5 / RATE_HZ)
        assert f["tau_s"] == pytest.approx(tau, rel=0.05)
        assert f["alpha"] == pytest.approx(alpha, rel=0.02)
    # a known T is taken as given
    fits = _fit(path, "--regions", "detect", "--model", "pulse", "--press-duration",
                "1.2")["regions"]["taxels"]["fits"]
    assert fits[0]["duration_s"] == pytest.approx(1.2)
