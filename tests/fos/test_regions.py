"""Press/slip regions of a tactile file and the fit-fos protocol (paper 000, sec. 4.2).

Files from :mod:`tests.factories.fos_counts`: 12 trials with known FOS parameters, Poisson
counts like the scene's (press regions <= 96 bins, slips <= 64 bins, so every test here
shares one compiled solver per model).
"""

from __future__ import annotations

import h5py
import numpy as np
import pytest

from tactile_cli.errors import InputError
from tactile_cli.fos import FitStatus, fit_pulse
from tactile_cli.fos.protocol import NO_REGIONS, PRESS_FAILED, fit_regions, region_arrays
from tactile_cli.fos.regions import read_trial_regions

from ..factories.fos_counts import use_test_compilation_cache, write_counts_file

PAPER_R_PRESS = 0.983138
PAPER_R_SLIP = 0.999762


@pytest.fixture(scope="module", autouse=True)
def _compilation_cache():
    use_test_compilation_cache()


@pytest.fixture(scope="module")
def counts_file(tmp_path_factory):
    path = tmp_path_factory.mktemp("regions") / "counts.h5"
    truth = write_counts_file(path, n_trials=12, seed=1)
    return path, truth


@pytest.fixture(scope="module")
def fitted(counts_file):
    path, truth = counts_file
    trials = read_trial_regions(path)
    return trials, truth, fit_regions(trials, order=False)


def _rel(estimate, truth):
    return np.abs(np.asarray(estimate) / np.asarray(truth) - 1)


def test_regions_and_counts_from_a_count_stream(counts_file):
    path, truth = counts_file
    trials = read_trial_regions(path)
    assert [t.trial for t in trials] == [t["trial"] for t in truth]
    with h5py.File(path) as h5:
        data = h5["trials/trial_03/signals/event_counts/data"][()]
    tr, tt = trials[3], truth[3]
    np.testing.assert_array_equal(tr.net, data[:, 2])  # the `net` channel
    assert tr.press_s == (tt["press_start_s"], tt["slip_start_s"])
    assert tr.slip_s == (tt["slip_start_s"], tt["release_start_s"])
    assert (tr.regions_from, tr.counts_from, tr.bin_s) == ("annotations",
                                                            "signals/event_counts", 0.02)
    assert tr.force_level == tt["force_level"] and tr.labels["force_grade"].startswith("grade")
    inside = tr.in_region("press")
    assert tr.t_s[inside].min() >= tt["press_start_s"] and tr.t_s[inside].max() < tt[
        "slip_start_s"]


def test_events_give_the_same_counts_as_the_stream(tmp_path):
    stream, events = tmp_path / "stream.h5", tmp_path / "events.h5"
    write_counts_file(stream, n_trials=2, seed=5)
    write_counts_file(events, n_trials=2, seed=5, as_events=True)
    for a, b in zip(read_trial_regions(stream), read_trial_regions(events), strict=True):
        assert b.counts_from == "events"
        np.testing.assert_array_equal(a.net, b.net)
        np.testing.assert_allclose(a.t_s, b.t_s)
        assert a.press_s == b.press_s and a.slip_s == b.slip_s


def test_region_errors(tmp_path, counts_file):
    bare = tmp_path / "bare.h5"
    write_counts_file(bare, n_trials=1, seed=2, annotate=False)
    with pytest.raises(InputError) as exc:
        read_trial_regions(bare, regions="annotations")
    assert str(exc.value) == (f"{bare}, /trials/trial_00: no 'press' and 'slip' annotations; "
                              "add them at ingest (`tactile ingest --annotations FILE`) or pass "
                              "`regions='detect'`")
    path, _ = counts_file
    with pytest.raises(InputError) as exc:
        read_trial_regions(path, bin_s=0.01)
    assert str(exc.value) == (f"{path}, /trials/trial_00/signals/event_counts: the stream's "
                              "bins are 20 ms, not the 10 ms asked for; pass `bin_s=0.02`")
    with pytest.raises(InputError, match="no trial 'nope'"):
        read_trial_regions(path, trials=["nope"])
    with pytest.raises(ValueError, match="`regions`"):
        read_trial_regions(path, regions="guess")


def test_press_fits_recover_the_true_parameters(fitted):
    trials, truth, fits = fitted
    press = fits["press"]
    assert press.ok.all(), press.status
    ok_alpha = _rel(press.fit.alpha, [t["alpha_press"] for t in truth]) <= 0.05
    ok_tau = _rel(press.fit.tau_s, [t["tau_press_s"] for t in truth]) <= 0.05
    assert (ok_alpha & ok_tau).mean() >= 0.95
    assert _rel(press.fit.duration_s, [t["press_duration_s"] for t in truth]).max() <= 0.05
    assert (press.fit.pearson_r >= PAPER_R_PRESS).all()
    # what was fitted: bins of the region, times from its start
    i = 0
    m = press.mask[i]
    np.testing.assert_allclose(press.t_s[i][m], trials[i].t_s[trials[i].in_region("press")]
                               - truth[i]["press_start_s"])
    np.testing.assert_array_equal(press.y[i][m], trials[i].net[trials[i].in_region("press")])


def test_slip_fits_subtract_the_press_tail_and_are_statistically_right(fitted):
    trials, truth, fits = fitted
    press, slip = fits["press"], fits["slip"]
    assert slip.ok.all(), slip.status
    i = 0
    region = trials[i].in_region("slip")
    tail = press.curve(i, trials[i].t_s[region] - truth[i]["press_start_s"])
    assert tail[0] > 10  # the press response still runs when the slip starts
    np.testing.assert_allclose(slip.y[i][slip.mask[i]], trials[i].net[region] - tail)
    # 1-1.2 s slips with the scene's noise determine tau to ~5 % (one standard error): the
    # errors must match the reported standard errors, not the 5 % target (see the test on
    # long slips below and the report)
    err_tau = slip.fit.tau_s - np.array([t["tau_slip_s"] for t in truth])
    err_alpha = slip.fit.alpha - np.array([t["alpha_slip"] for t in truth])
    assert np.all(np.abs(err_tau) <= 3.5 * slip.fit.tau_se_s)
    assert np.all(np.abs(err_alpha) <= 3.5 * slip.fit.alpha_se)
    assert np.median(slip.fit.tau_se_s / slip.fit.tau_s) > 0.02


def test_long_slips_reach_the_papers_accuracy_and_r(tmp_path):
    # The paper's slip R (0.999762) needs a ramp that grows a lot against the counting noise.
    # Measured with the scene's noise (net variance 2 |mu| + 40): slips of 1 s reach R 0.9988
    # (tau to 5.8 %), 2 s 0.9995, 4 s 0.99973; with plain Poisson counts 2 s reach 0.99973
    # and 4 s 0.99986. Here: plain Poisson counts, 4 s slips.
    path = tmp_path / "long.h5"
    truth = write_counts_file(path, n_trials=12, seed=3, slip_s=(3.9, 4.2), beta=0.0)
    fits = fit_regions(read_trial_regions(path), regions=("slip",), order=False)
    slip = fits["slip"]
    assert list(fits) == ["slip"] and slip.ok.all()
    ok = ((_rel(slip.fit.alpha, [t["alpha_slip"] for t in truth]) <= 0.05)
          & (_rel(slip.fit.tau_s, [t["tau_slip_s"] for t in truth]) <= 0.05))
    assert ok.mean() >= 0.95
    assert np.median(slip.fit.pearson_r) >= PAPER_R_SLIP


def test_poor_starting_values_converge_or_are_flagged(fitted):
    trials, truth, _ = fitted
    t, y, m = region_arrays(trials, "press")
    tau = np.array([tt["tau_press_s"] for tt in truth])
    alpha = np.array([tt["alpha_press"] for tt in truth])
    for factor in (0.02, 30.0):
        r = fit_pulse(t, y, m, tau0_s=factor * tau, duration0_s=np.full(len(tau), 1.0))
        good = r.ok & (_rel(r.alpha, alpha) <= 0.05) & (_rel(r.tau_s, tau) <= 0.05)
        assert np.all(good | ~r.ok), (factor, r.status)  # never converged and wrong
        assert np.all(np.isnan(r.alpha[~r.ok]))
        assert r.ok.mean() >= 0.5, (factor, r.status)


def test_a_failed_press_is_reported_for_the_slip(counts_file):
    path, _ = counts_file
    trials = read_trial_regions(path)
    dead = trials[0]
    silent = np.where(dead.in_region("press"), 0.0, dead.net)
    trials[0] = type(dead)(**{**dead.__dict__, "net": silent})
    fits = fit_regions(trials, order=False)
    assert fits["press"].status[0] == FitStatus.BAD_INPUT.value
    assert fits["slip"].status[0] == PRESS_FAILED
    assert "press fit failed" in fits["slip"].message(0)
    assert np.isnan(fits["slip"].fit.alpha[0])
    assert fits["slip"].ok[1:].all()


def test_order_verdicts(fitted):
    trials, _, _ = fitted
    fits = fit_regions(trials, order=True)
    for region in ("press", "slip"):
        rf = fits[region]
        assert (rf.verdict == "first_order").mean() >= 0.9, rf.verdict
        assert np.isfinite(rf.delta_bic).all()


def test_detected_regions(counts_file):
    path, truth = counts_file
    trials = read_trial_regions(path, regions="detect")
    assert {t.regions_from for t in trials} == {"detected"}
    for tr, tt in zip(trials, truth, strict=True):
        found = np.array([tr.press_s[0], tr.slip_s[0], tr.slip_s[1]])
        true = np.array([tt["press_start_s"], tt["slip_start_s"], tt["release_start_s"]])
        assert np.abs(found - true).max() <= 0.02, (tr.trial, found - true)  # within a bin
    press = fit_regions(trials, regions=("press",), order=False)["press"]
    ok = ((_rel(press.fit.alpha, [t["alpha_press"] for t in truth]) <= 0.05)
          & (_rel(press.fit.tau_s, [t["tau_press_s"] for t in truth]) <= 0.05))
    assert ok.mean() >= 0.95


def test_a_trial_without_regions_is_reported(counts_file):
    path, _ = counts_file
    trials = read_trial_regions(path)
    lost = trials[2]
    nan = (float("nan"), float("nan"))
    trials[2] = type(lost)(**{**lost.__dict__, "press_s": nan, "slip_s": nan,
                              "regions_from": "detected",
                              "regions_note": "segmentation failed: only one peak"})
    fits = fit_regions(trials, order=False)
    for region in ("press", "slip"):
        rf = fits[region]
        assert rf.status[2] == NO_REGIONS and not rf.ok[2]
        assert rf.message(2) == ("no press and slip regions (segmentation failed: only one "
                                 "peak); annotate the trial (`tactile ingest --annotations FILE`)")
        assert rf.ok[[0, 1, 3]].all()
