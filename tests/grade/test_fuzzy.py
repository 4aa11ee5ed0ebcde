"""The Mamdani core: membership functions, vectorised inference against a per-sample
reference and against scikit-fuzzy."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from tactile_cli.grade import load_config
from tactile_cli.grade.fuzzy import (
    MamdaniSystem,
    MembershipFunction,
    gaussmf,
    infer,
    trapmf,
    trimf,
)
from tactile_cli.grade.reference import infer_reference

MF = MembershipFunction
GRADES = ("light", "small", "small_medium", "medium", "small_big", "big")


def _system(resolution=None, *, inputs=None, outputs=None, out_range=(-0.2, 1.2), rules=None):
    inputs = inputs or [MF("trapmf", (0, 0, 10, 14)), MF("trapmf", (10, 14, 20, 24)),
                        MF("trimf", (20, 26, 32)), MF("trapmf", (26, 32, 40, 44)),
                        MF("trapmf", (40, 44, 50, 54)), MF("trapmf", (50, 54, 70, 70))]
    outputs = outputs or [MF("trimf", (c - 0.2, c, c + 0.2)) for c in np.arange(6) * 0.2]
    return MamdaniSystem(tuple(f"in{k}" for k in range(len(inputs))), tuple(inputs), (0, 70),
                         GRADES[:len(outputs)], tuple(outputs), out_range,
                         rules or tuple((k, k) for k in range(6)), resolution)


# -- membership functions ----------------------------------------------------------------------
def test_trimf_exact_at_key_points():
    x = np.array([-1.0, 0.0, 1.0, 2.0, 3.0, 4.0, 5.0])
    np.testing.assert_array_equal(trimf(x, (0, 2, 4)), [0, 0, 0.5, 1, 0.5, 0, 0])
    # shoulders: a vertical edge has membership 1 on it
    np.testing.assert_array_equal(trimf(x, (0, 0, 4)), [0, 1, 0.75, 0.5, 0.25, 0, 0])
    np.testing.assert_array_equal(trimf(x, (0, 4, 4)), [0, 0, 0.25, 0.5, 0.75, 1, 0])


def test_trapmf_and_gaussmf_exact_at_key_points():
    x = np.array([-1.0, 0.0, 1.0, 2.0, 3.0, 4.0, 6.0, 7.0])
    np.testing.assert_array_equal(trapmf(x, (0, 2, 4, 6)), [0, 0, 0.5, 1, 1, 1, 0, 0])
    np.testing.assert_array_equal(trapmf(x, (0, 0, 4, 6)), [0, 1, 1, 1, 1, 1, 0, 0])
    assert gaussmf(np.array([3.0]), 3.0, 0.5)[0] == 1.0
    np.testing.assert_allclose(gaussmf(np.array([2.5, 3.5]), 3.0, 0.5), np.exp(-0.5), rtol=0,
                               atol=1e-15)
    assert np.isnan(trapmf(np.array([np.nan]), (0, 1, 2, 3))[0])


def test_broadcast_memberships_equal_the_single_functions():
    s = _system()
    x = np.concatenate([np.linspace(-5, 75, 801), [0, 10, 14, 20, 26, 32, 70]])
    mu = s.input_membership(x)
    xc = np.clip(x, 0, 70)
    for k, mf in enumerate(s.input_mfs):  # slope as a reciprocal: rounding differs
        np.testing.assert_allclose(mu[:, k], mf(xc), rtol=0, atol=1e-15)


@pytest.mark.parametrize("kind,params,msg", [
    ("trimf", (0, 2), "takes 3 parameters"),
    ("trapmf", (0, 3, 2, 4), "must not decrease"),
    ("gaussmf", (0, 0), "sigma must be > 0"),
    ("bellmf", (0, 1, 2), "must be one of"),
])
def test_bad_membership_functions(kind, params, msg):
    with pytest.raises(ValueError, match=msg):
        MF(kind, params)


# -- inference ---------------------------------------------------------------------------------
def _same_grades(s, fast, ref):
    """Grades agree except on exact ties, where 1e-16 of rounding picks the side."""
    bounds = s.grade_boundaries
    crisp = np.nan_to_num(ref.crisp, nan=-99.0)
    tie = np.zeros(crisp.shape, bool) if bounds is None else (
        np.min(np.abs(crisp[:, None] - bounds), axis=1) < 1e-9)
    np.testing.assert_array_equal(fast.grade[~tie], ref.grade[~tie])


INPUTS = np.concatenate([np.random.default_rng(3).uniform(-10, 80, 150),
                         [0, 10, 12, 14, 20, 23, 26, 29, 32, 44, 52, 70, np.nan]])


@pytest.mark.parametrize("resolution", [None, 1001, 101, 7])
def test_closed_form_equals_reference(resolution):
    s = _system(resolution)
    assert s.method == "closed_form"
    fast, ref = infer(s, INPUTS), infer_reference(s, INPUTS)
    np.testing.assert_allclose(fast.crisp, ref.crisp, rtol=0, atol=1e-9, equal_nan=True)
    _same_grades(s, fast, ref)
    np.testing.assert_allclose(fast.firing, ref.firing, rtol=0, atol=1e-15)
    assert fast.grade[-1] == -1 and np.isnan(fast.crisp[-1])


def test_uneven_outputs_with_shoulders_equal_reference():
    outputs = [MF("trapmf", (0, 0, 0.1, 0.3)), MF("trimf", (0.15, 0.35, 0.5)),
               MF("trapmf", (0.45, 0.5, 0.55, 0.7)), MF("trimf", (0.55, 0.7, 0.8)),
               MF("trimf", (0.8, 0.85, 0.95)), MF("trapmf", (0.9, 0.95, 1, 1))]
    for res in (None, 257):
        s = _system(res, outputs=outputs, out_range=(0, 1))
        assert s.method == "closed_form"
        np.testing.assert_allclose(infer(s, INPUTS).crisp, infer_reference(s, INPUTS).crisp,
                                   rtol=0, atol=1e-9, equal_nan=True)


def test_gaussian_outputs_use_the_universe_and_equal_reference():
    outputs = [MF("gaussmf", (c, 0.08)) for c in np.arange(6) * 0.2]
    inputs = [MF("gaussmf", (c, 5.0)) for c in np.arange(6) * 12 + 5]
    s = _system(301, inputs=inputs, outputs=outputs)
    assert s.method == "universe"
    np.testing.assert_allclose(infer(s, INPUTS, chunk=50).crisp,
                               infer_reference(s, INPUTS).crisp, rtol=0, atol=1e-9,
                               equal_nan=True)
    with pytest.raises(ValueError, match="set a resolution"):
        _system(None, inputs=inputs, outputs=outputs)


def test_several_rules_per_output_take_the_max():
    rules = ((0, 0), (1, 1), (2, 1), (3, 3), (4, 4), (5, 5), (2, 2))
    s = _system(None, rules=rules)
    fast, ref = infer(s, INPUTS), infer_reference(s, INPUTS)
    np.testing.assert_allclose(fast.crisp, ref.crisp, rtol=0, atol=1e-9, equal_nan=True)
    np.testing.assert_array_equal(fast.cut[:, 1], np.maximum(fast.firing[:, 1],
                                                             fast.firing[:, 2]))


def test_fine_universe_converges_to_the_continuous_centroid():
    x = INPUTS[:-1]
    exact = infer(_system(None), x).crisp
    fine = infer(_system(100_001), x).crisp
    coarse = infer(_system(101), x).crisp
    assert np.max(np.abs(fine - exact)) < 1e-8
    assert np.max(np.abs(coarse - exact)) > 1e-5  # the corner cut is real at 101 points


def test_chunks_and_large_batches():
    s = _system(1001)
    x = np.random.default_rng(0).uniform(0, 70, 200_000)
    a, b = infer(s, x), infer(s, x, chunk=7919)
    # the same sums in other block sizes: BLAS may round the last bit differently
    np.testing.assert_allclose(a.crisp, b.crisp, rtol=1e-12, atol=1e-15)
    np.testing.assert_array_equal(a.grade, b.grade)
    assert a.firing.shape == (200_000, 6)


def test_grade_boundaries_sit_where_two_rules_fire_equally():
    s = _system(None)
    # in1 and in2 cross at 0.5 at x = 22 (in1 falls 20..24, in2 rises 20..26 -> 2/6 at 22)
    x = np.linspace(0, 70, 7001)
    res = infer(s, x)
    switch = x[1:][np.diff(res.grade) != 0]
    w = res.firing
    for k, xs in enumerate(switch):
        i = np.searchsorted(x, xs)
        assert abs(w[i - 1, k] - w[i - 1, k + 1]) < 0.02  # equal firing at the switch
    assert len(switch) == 5


# -- scikit-fuzzy --------------------------------------------------------------------------------
def test_agrees_with_scikit_fuzzy():
    skfuzzy = pytest.importorskip(
        "skfuzzy", reason="scikit-fuzzy is not installed (pip install scikit-fuzzy, or the "
        "dev extra); the per-sample reference tests above still run")
    del skfuzzy
    import warnings

    from tactile_cli.grade import default_config_path
    from tactile_cli.grade.reference import skfuzzy_infer, skfuzzy_simulation

    system = dataclasses.replace(load_config(default_config_path()).system(), resolution=1001)
    lo, hi = system.input_range
    x = np.concatenate([np.random.default_rng(1).uniform(lo - 1000, hi + 1000, 40),
                        [t.trapezoid[2] for t in system.input_mfs[:-1]]])
    with warnings.catch_warnings():
        # scikit-fuzzy 0.5 calls np.maximum with a positional `out` (deprecated in numpy 2.4)
        warnings.filterwarnings("ignore", "Passing more than 2 positional", DeprecationWarning)
        sk = skfuzzy_infer(skfuzzy_simulation(system), x)
    np.testing.assert_allclose(infer(system, x).crisp, sk, rtol=0, atol=1e-6)
