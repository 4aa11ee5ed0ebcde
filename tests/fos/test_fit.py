"""The batched FOS fits of paper 000, sec. 4.2 (eqs. 16-17) and the model-order choice.

Synthetic trials with known parameters, like the paper's: alpha in [1365, 2280] events per
20 ms bin, tau ~ 0.3 s, Poisson counting noise. All batches have 64 trials of 150 points so
that each solver configuration compiles once for the whole module.
"""

from __future__ import annotations

import json

import jax
import numpy as np
import pytest
from scipy import signal
from scipy.optimize import curve_fit

from tactile_cli.fos import (
    FitOptions,
    FitStatus,
    first_order_response,
    fit_pulse,
    fit_ramp,
    fit_second_order,
    fit_step,
    pulse_response,
    ramp_response,
    second_order_response,
    select_order,
    step_response,
)

DT_S = 0.02
N_POINTS = 150
N_TRIALS = 64
T_S = 1.5  # press length: half of the 3 s region
PAPER_R_PRESS = 0.983138
PAPER_R_SLIP = 0.999762


def make_trials(kind: str, *, seed: int, n_trials: int = N_TRIALS, mu=None, alpha=None,
                tau=None) -> dict:
    """Poisson counts around a first-order response (or around ``mu(t, alpha, tau)``)."""
    rng = np.random.default_rng(seed)
    alpha = rng.uniform(1365.0, 2280.0, n_trials) if alpha is None else alpha
    tau = rng.uniform(0.25, 0.35, n_trials) if tau is None else tau
    t = np.arange(N_POINTS) * DT_S
    if mu is None:
        mean = first_order_response(kind, t, alpha[:, None], tau[:, None],
                                    T_S if kind == "pulse" else None)
    else:
        mean = mu(t, alpha[:, None], tau[:, None])
    y = rng.poisson(np.clip(mean, 0, None)).astype(np.float64)
    return {"t": t, "y": y, "alpha": alpha, "tau": tau}


def within(estimate: np.ndarray, truth: np.ndarray, rel: float = 0.05) -> np.ndarray:
    return np.abs(estimate / truth - 1) <= rel  # NaN (failed) counts as outside


def pearson_of_truth(d: dict, kind: str) -> np.ndarray:
    """Per-trial R between the counts and the noise-free curve: what a perfect fit reaches."""
    mu = first_order_response(kind, d["t"], d["alpha"][:, None], d["tau"][:, None],
                              T_S if kind == "pulse" else None)
    return np.array([np.corrcoef(y, m)[0, 1] for y, m in zip(d["y"], mu, strict=True)])


def assert_paper_r(r, d: dict, kind: str, paper_r: float) -> None:
    # The fit reaches the noise floor (R of the true curve; least squares can trail it by a
    # hair) and, on Poisson noise, at least the R the paper reports for 95 % of the trials.
    assert np.all(r.pearson_r >= pearson_of_truth(d, kind) - 1e-5)
    assert (r.pearson_r >= paper_r).mean() >= 0.95


# ---------------------------------------------------------------------------- models
def test_models_are_the_paper_equations():
    t = np.linspace(0, 3, 301)
    a, tau, T = 1800.0, 0.3, 1.2
    eq16 = np.where(t < T, a * (1 - np.exp(-t / tau)),
                    a * (np.exp(-(t - T) / tau) - np.exp(-t / tau)))
    np.testing.assert_allclose(pulse_response(t, a, tau, T), eq16, rtol=1e-12, atol=1e-9)
    np.testing.assert_allclose(step_response(t, a, tau), a * (1 - np.exp(-t / tau)), rtol=1e-12)
    np.testing.assert_allclose(pulse_response(t, a, tau, np.inf), step_response(t, a, tau))
    eq17 = a * (t / tau - 1 + np.exp(-t / tau))
    np.testing.assert_allclose(ramp_response(t, a, tau), eq17, rtol=1e-9, atol=1e-9)


@pytest.mark.parametrize("zeta", [0.3, 1.0, 1.7])
def test_second_order_model_matches_scipy_lti(zeta):
    t = np.arange(N_POINTS) * DT_S
    tau, lead = 0.2, 0.13
    lti = signal.lti([lead, 1.0], [tau**2, 2 * zeta * tau, 1.0])
    np.testing.assert_allclose(second_order_response("step", t, 1.0, tau, zeta, lead_s=lead),
                               lti.step(T=t)[1], atol=1e-10)
    ramp = signal.lsim(lti, U=t, T=t)[1] / (2 * zeta * tau)
    np.testing.assert_allclose(second_order_response("ramp", t, 1.0, tau, zeta, lead_s=lead),
                               ramp, atol=1e-8)


def test_second_order_tends_to_first_order():
    t = np.arange(N_POINTS) * DT_S
    zeta = 1e5
    for kind in ("step", "pulse", "ramp"):
        np.testing.assert_allclose(
            second_order_response(kind, t, 1.0, 0.3 / (2 * zeta), zeta, T_S),
            first_order_response(kind, t, 1.0, 0.3, T_S), atol=1e-8)


# ---------------------------------------------------------------------------- accuracy
def test_pulse_known_duration_recovers_parameters_and_paper_r():
    d = make_trials("pulse", seed=1)
    r = fit_pulse(d["t"], d["y"], duration_s=T_S)
    assert r.ok.all(), dict(zip(*np.unique(r.status, return_counts=True), strict=True))
    assert within(r.alpha, d["alpha"]).mean() >= 0.95
    assert within(r.tau_s, d["tau"]).mean() >= 0.95
    assert_paper_r(r, d, "pulse", PAPER_R_PRESS)
    np.testing.assert_array_equal(r.duration_s, T_S)
    assert np.all(np.isnan(r.duration_se_s)) and np.all(r.tau_se_s > 0)
    assert r.n_params == 2 and np.all(r.n_steps >= 1)


def test_pulse_fitted_duration():
    d = make_trials("pulse", seed=2)
    r = fit_pulse(d["t"], d["y"])
    assert r.duration_fitted and r.n_params == 3
    assert r.ok.mean() >= 0.95
    assert within(r.alpha, d["alpha"]).mean() >= 0.95
    assert within(r.tau_s, d["tau"]).mean() >= 0.95
    assert within(r.duration_s, np.full(N_TRIALS, T_S), 0.02).mean() >= 0.95
    assert np.all(r.pearson_r[r.ok] >= PAPER_R_PRESS)


def test_ramp_recovers_parameters_and_paper_r():
    d = make_trials("ramp", seed=3, alpha=np.full(N_TRIALS, 1615.0),
                    tau=np.random.default_rng(3).uniform(0.3, 0.35, N_TRIALS))
    r = fit_ramp(d["t"], d["y"])
    assert r.ok.all()
    assert within(r.alpha, d["alpha"]).mean() >= 0.95
    assert within(r.tau_s, d["tau"]).mean() >= 0.95
    assert_paper_r(r, d, "ramp", PAPER_R_SLIP)


def test_step_recovers_parameters():
    d = make_trials("step", seed=4)
    r = fit_step(d["t"], d["y"])
    assert r.ok.all()
    assert within(r.alpha, d["alpha"]).mean() >= 0.95
    assert within(r.tau_s, d["tau"]).mean() >= 0.95
    assert np.all(np.isnan(r.duration_s))


def test_standard_errors_match_the_scatter_of_repeated_fits():
    # 64 noisy copies of one trial: the spread of the estimates is what the SE predicts.
    d = make_trials("pulse", seed=5, alpha=np.full(N_TRIALS, 1800.0),
                    tau=np.full(N_TRIALS, 0.3))
    r = fit_pulse(d["t"], d["y"], duration_s=T_S)
    for est, se in ((r.alpha, r.alpha_se), (r.tau_s, r.tau_se_s)):
        ratio = np.std(est, ddof=1) / np.median(se)
        assert 0.7 < ratio < 1.4, ratio


def test_results_agree_with_curve_fit():
    d = make_trials("pulse", seed=6)
    r = fit_pulse(d["t"], d["y"], duration_s=T_S)
    for i in range(8):
        p, cov = curve_fit(lambda t, a, tau: pulse_response(t, a, tau, T_S), d["t"], d["y"][i],
                           p0=(2000.0, 0.3))
        np.testing.assert_allclose([r.alpha[i], r.tau_s[i]], p, rtol=2e-4)
        np.testing.assert_allclose([r.alpha_se[i], r.tau_se_s[i]], np.sqrt(np.diag(cov)),
                                   rtol=1e-2)


# ---------------------------------------------------------------------------- robustness
@pytest.mark.parametrize("factor", [0.01, 0.1, 10.0, 100.0])
def test_poor_starts_converge_for_known_duration(factor):
    d = make_trials("pulse", seed=7)
    r = fit_pulse(d["t"], d["y"], duration_s=T_S, tau0_s=d["tau"] * factor)
    np.testing.assert_allclose(r.start_tau_s, d["tau"] * factor)
    assert r.ok.all()
    assert within(r.tau_s, d["tau"]).mean() >= 0.95


@pytest.mark.parametrize(("tau_factor", "duration_factor", "some_fail"), [
    (0.01, 1.0, True), (0.01, 0.05, True), (30.0, 0.3, False), (100.0, 0.05, False)])
def test_poor_starts_converge_or_are_flagged_never_wrong_and_silent(tau_factor,
                                                                    duration_factor,
                                                                    some_fail):
    d = make_trials("pulse", seed=8)
    r = fit_pulse(d["t"], d["y"], tau0_s=d["tau"] * tau_factor,
                  duration0_s=T_S * duration_factor, keep_failed=True)
    good = within(r.tau_s, d["tau"]) & within(r.alpha, d["alpha"])
    assert np.all(good | ~r.ok), "a converged fit is off by more than 5 %"
    if some_fail:  # from 1 % of tau, T and tau trade off: these starts must get flagged
        assert (~r.ok).any() and np.all(~good[~r.ok])
    else:
        assert r.ok.mean() >= 0.95


def test_failed_fits_are_nan_unless_kept():
    d = make_trials("pulse", seed=8)
    kw = {"tau0_s": d["tau"] * 0.01, "duration0_s": 0.05 * T_S,
          "options": FitOptions(max_steps=3)}
    kept = fit_pulse(d["t"], d["y"], keep_failed=True, **kw)
    dropped = fit_pulse(d["t"], d["y"], **kw)
    assert (kept.status == FitStatus.MAX_STEPS.value).any()
    np.testing.assert_array_equal(kept.status, dropped.status)
    assert np.all(np.isnan(dropped.tau_s[~dropped.ok]))
    assert np.all(np.isfinite(kept.tau_s[~kept.ok]))


def test_ragged_trials_via_mask_equal_trimmed_fits():
    d = make_trials("pulse", seed=9)
    lengths = np.random.default_rng(9).integers(90, N_POINTS + 1, N_TRIALS)
    mask = np.arange(N_POINTS)[None, :] < lengths[:, None]
    y = np.where(mask, d["y"], -1.0e6)  # garbage in the padding must not matter
    r = fit_pulse(d["t"], y, mask, duration_s=T_S)
    assert r.ok.all()
    np.testing.assert_array_equal(r.n_points, lengths)
    for i in range(6):
        n = lengths[i]
        p, _ = curve_fit(lambda t, a, tau: pulse_response(t, a, tau, T_S), d["t"][:n],
                         d["y"][i, :n], p0=(2000.0, 0.3))
        np.testing.assert_allclose([r.alpha[i], r.tau_s[i]], p, rtol=2e-4)


def test_bad_input_is_flagged_per_trial_not_raised():
    d = make_trials("pulse", seed=10)
    y, t, mask = d["y"].copy(), np.tile(d["t"], (N_TRIALS, 1)), np.ones_like(d["y"], bool)
    duration = np.full(N_TRIALS, T_S)
    y[0, 10] = np.nan  # NaN count
    mask[1, 3:] = False  # three points: too few for two parameters
    t[2, 20] = t[2, 19]  # times not increasing
    y[3] = 0.0  # no events
    duration[4] = -1.0  # impossible press length
    t[5, 40] = np.inf
    r = fit_pulse(t, y, mask, duration_s=duration)
    assert np.all(r.status[:6] == FitStatus.BAD_INPUT.value)
    assert np.all(np.isnan(r.tau_s[:6]))
    assert r.ok[6:].all()
    clean = fit_pulse(d["t"], d["y"], duration_s=T_S)
    np.testing.assert_allclose(r.tau_s[6:], clean.tau_s[6:], rtol=1e-12)


def test_argument_errors_name_the_argument():
    d = make_trials("pulse", seed=11)
    with pytest.raises(ValueError, match="`y`"):
        fit_pulse(d["t"], d["y"][0], duration_s=T_S)
    with pytest.raises(ValueError, match="`mask`"):
        fit_pulse(d["t"], d["y"], np.ones(d["y"].shape), duration_s=T_S)
    with pytest.raises(ValueError, match="`tau0_s`"):
        fit_pulse(d["t"], d["y"], duration_s=T_S, tau0_s=-0.3)
    with pytest.raises(ValueError, match="`duration_s`"):
        fit_pulse(d["t"], d["y"], duration_s=np.ones(3))
    with pytest.raises(ValueError, match="`kind`"):
        fit_second_order("press", d["t"], d["y"])
    with pytest.raises(ValueError, match="`solver`"):
        FitOptions(solver="newton")
    with pytest.raises(ValueError, match="`chunk_size`"):
        FitOptions(chunk_size=0)


def test_records_are_json_and_global_jax_config_is_untouched():
    x64_before = jax.config.jax_enable_x64
    d = make_trials("pulse", seed=12)
    r = fit_pulse(d["t"], d["y"], duration_s=T_S)
    assert jax.config.jax_enable_x64 == x64_before
    assert r.alpha.dtype == np.float64
    records = r.to_records()
    assert len(records) == N_TRIALS
    text = json.dumps(records, allow_nan=False)
    assert json.loads(text)[0]["status"] == "converged"
    assert records[0]["duration_se_s"] is None and records[0]["kind"] == "pulse"


# ---------------------------------------------------------------------------- model order
def test_second_order_fit_recovers_an_overdamped_system():
    tau, zeta = np.sqrt(0.08 * 0.3), 0.38 / (2 * np.sqrt(0.08 * 0.3))  # poles 80 and 300 ms
    d = make_trials("pulse", seed=13, mu=lambda t, a, _: second_order_response(
        "pulse", t, a, tau, zeta, T_S))
    r = fit_second_order("pulse", d["t"], d["y"], duration_s=T_S)
    assert r.ok.mean() >= 0.95 and r.n_params == 4
    assert within(r.alpha, d["alpha"]).mean() >= 0.95
    # tau and zeta trade off (SE ~4 %): check them against their own standard errors.
    for est, se, true in ((r.tau_s, r.tau_se_s, tau), (r.zeta, r.zeta_se, zeta),
                          (r.lead_s, r.lead_se_s, 0.0)):
        z = (est - true) / se
        assert np.nanmean(np.abs(z) < 3) >= 0.95
        assert 0.7 < np.nanstd(z) < 1.4


def test_first_order_data_choose_first_order():
    d = make_trials("pulse", seed=14)
    sel = select_order("pulse", d["t"], d["y"], duration_s=T_S)
    assert (sel.verdict == "first_order").mean() >= 0.9
    assert np.all(sel.second.rss[sel.second.ok] <= sel.first.rss[sel.second.ok] * (1 + 1e-9))


@pytest.mark.parametrize("shape", ["overdamped", "saturating"])
def test_second_order_and_saturating_data_choose_second_order(shape):
    tau2, zeta2 = np.sqrt(0.08 * 0.3), 0.38 / (2 * np.sqrt(0.08 * 0.3))
    if shape == "overdamped":
        def mu(t, a, _):
            return second_order_response("pulse", t, a, tau2, zeta2, T_S)
    else:  # a "big force" press: the FOS response flattened by A tanh(x/A), A = 0.8 alpha
        def mu(t, a, tau):
            return 0.8 * a * np.tanh(pulse_response(t, a, tau, T_S) / (0.8 * a))
    d = make_trials("pulse", seed=15, mu=mu)
    sel = select_order("pulse", d["t"], d["y"], duration_s=T_S)
    assert (sel.verdict == "second_order").mean() >= 0.9
    assert np.all(sel.delta[sel.verdict == "second_order"] > sel.min_delta)
    rec = sel.to_records()[0]
    assert {"verdict", "delta_bic", "delta_aic", "first_tau_s", "second_zeta"} <= rec.keys()
    json.dumps(sel.to_records(), allow_nan=False)


def test_gauss_newton_option_agrees_and_flags_what_it_cannot_reach():
    d = make_trials("pulse", seed=16)
    gn = FitOptions(solver="gauss_newton")
    lm = fit_pulse(d["t"], d["y"], duration_s=T_S)
    r = fit_pulse(d["t"], d["y"], duration_s=T_S, options=gn)
    assert r.ok.all()
    np.testing.assert_allclose(r.tau_s, lm.tau_s, rtol=1e-3)
    far = fit_pulse(d["t"], d["y"], duration_s=T_S, tau0_s=d["tau"] * 100, options=gn,
                    keep_failed=True)
    assert (~far.ok).any()  # undamped steps from 100x off: LM converges, GN cannot
    assert np.all(within(far.tau_s, d["tau"]) | ~far.ok)


# ---------------------------------------------------------------------------- one program
@pytest.mark.slow
def test_the_compiled_solver_matches_the_models_and_autodiff():
    """The solver's written-out first-order Jacobian equals autodiff of the projected
    residual, and its second-order basis equals :func:`second_order_basis` (all kinds)."""
    import jax.numpy as jnp

    from tactile_cli.fos import solver
    from tactile_cli.fos.models import second_order_basis, unit_response

    rng = np.random.default_rng(21)
    t = np.arange(100) * DT_S + 0.01
    y = rng.poisson(1000.0, 100).astype(float)
    m = (np.arange(100) < 90).astype(float)
    with jax.enable_x64(True):
        for kind, fit_t, dur in (("pulse", False, 0.73), ("pulse", True, np.inf),
                                 ("step", False, np.inf), ("ramp", False, np.inf)):
            flags = solver.Flags(jnp.bool_(kind == "ramp"), jnp.bool_(False), jnp.bool_(fit_t))
            theta = jnp.array([np.log(0.3), 0.0, np.log(0.71)])
            args = (jnp.asarray(t), jnp.asarray(y), jnp.asarray(m), jnp.asarray(dur), 1e-3,
                    theta, flags)
            value, rows = solver._first_value_and_jacobian(theta, args)

            def reference(th, kind=kind, fit_t=fit_t, dur=dur):
                tau, big_t = jnp.exp(th[0]), (jnp.exp(th[2]) if fit_t else dur)
                b = unit_response("ramp" if kind == "ramp" else "pulse", jnp.asarray(t), tau,
                                  None if kind == "ramp" else big_t)
                g = jnp.sum(m * b * y) / jnp.sum(m * b * b)
                return (y - g * b) * m * 1e-3

            np.testing.assert_allclose(value, reference(theta), atol=1e-12)
            np.testing.assert_allclose(rows.T, jax.jacfwd(reference)(theta), atol=1e-12)
        for kind in ("pulse", "step", "ramp"):
            for zeta in (0.4, 1.0, 1.7):
                b = solver._second_basis(jnp.asarray(t), 0.2, zeta,
                                         0.73 if kind == "pulse" else np.inf, kind == "ramp")
                ref = np.stack(second_order_basis(kind, t, 0.2, zeta,
                                                  0.73 if kind == "pulse" else None), axis=1)
                np.testing.assert_allclose(b, ref, atol=1e-12)


def test_one_compilation_serves_every_model_and_batch_size():
    from tactile_cli.fos import compile_cache
    from tactile_cli.fos.fit import _bucket

    assert [_bucket(n) for n in (1, 32, 33, 48, 49, 64, 65, 100, 150, 200, 300)] == [
        32, 32, 48, 48, 64, 64, 96, 128, 192, 256, 384]
    before = set(compile_cache._PROGRAMS)
    d = make_trials("pulse", seed=17, n_trials=N_TRIALS)
    fit_pulse(d["t"], d["y"][:3], duration_s=T_S)  # 3 trials, 150 points: bucket 192
    fit_pulse(d["t"][:140], d["y"][:, :140])  # T fitted, 64 trials, 140 points
    fit_ramp(d["t"], make_trials("ramp", seed=18, n_trials=100)["y"])  # two chunks
    fit_step(d["t"], make_trials("step", seed=19, n_trials=5)["y"])
    select_order("pulse", d["t"], d["y"][:10], duration_s=T_S)  # and the second order
    new = set(compile_cache._PROGRAMS) - before
    assert {(rows, points) for _, rows, points in new} <= {(64, 192)}
    default = {spec for spec, _, _ in compile_cache._PROGRAMS
               if spec.solver == "levenberg_marquardt" and spec.max_steps == 64}
    assert len(default) == 1  # pulse, step, ramp, both orders: one specialisation


@pytest.mark.slow
def test_the_traced_program_is_saved_and_reloaded(tmp_path, monkeypatch):
    """With the cache enabled, the solver is exported to the cache folder; a fresh process
    (here: an emptied program table) loads it, and a damaged file is traced anew."""
    pytest.importorskip("flatbuffers")
    from tactile_cli.fos import compile_cache

    monkeypatch.setenv("TACTILE_CACHE_DIR", str(tmp_path))
    monkeypatch.setattr(compile_cache, "_PROGRAMS", {})
    monkeypatch.setattr(compile_cache, "_EXPORT_DIR", compile_cache.program_cache_dir())
    d = make_trials("ramp", seed=20, n_trials=8)
    first = fit_ramp(d["t"][:40], d["y"][:, :40])
    files = list((tmp_path / "fos").glob("solver-*-64x48.jaxexport"))
    assert len(files) == 1
    monkeypatch.setattr(compile_cache, "_PROGRAMS", {})
    again = fit_ramp(d["t"][:40], d["y"][:, :40])
    np.testing.assert_array_equal(again.tau_s, first.tau_s)
    files[0].write_bytes(b"not a program")
    monkeypatch.setattr(compile_cache, "_PROGRAMS", {})
    np.testing.assert_array_equal(fit_ramp(d["t"][:40], d["y"][:, :40]).tau_s, first.tau_s)
    assert files[0].read_bytes() != b"not a program"  # traced and saved again


def test_a_stalled_ramp_on_flattening_counts_is_reported_saturated():
    """A slip whose counts flatten (saturation) is not first-order: when its ramp fit runs
    out of steps the status says so instead of advising more steps."""
    from tactile_cli.fos.fit import _flattens

    t = np.arange(N_POINTS) * DT_S
    ramp = ramp_response(t, 1615.0, 0.3)
    flat = 2500.0 * np.tanh(ramp / 2500.0)
    y = np.stack([flat, ramp])
    mask = np.ones_like(y, bool)
    assert _flattens(np.tile(t, (2, 1)), y, mask).tolist() == [True, False]
    r = fit_ramp(t, y, options=FitOptions(max_steps=1))
    assert r.status.tolist() == [FitStatus.SATURATED.value, FitStatus.MAX_STEPS.value]
    assert "saturated, not first-order" in FitStatus.SATURATED.message
    assert "raise `max_steps`" not in FitStatus.SATURATED.message
