"""``tactile_cli.learn`` loads its names on first use: the split rules (used by the taxel
chain) import without torch, and the package still exposes every name it did."""

from __future__ import annotations

import subprocess
import sys

import numpy as np
import pytest

from tactile_cli.learn.config import SplitConfig
from tactile_cli.learn.data import TrialSeries
from tactile_cli.learn.splits import cv_folds, stratified_fold_of


def _run(code: str) -> str:
    return subprocess.run([sys.executable, "-c", code], check=True, capture_output=True,
                          text=True).stdout.strip()


@pytest.mark.slow
def test_importing_the_split_rules_does_not_import_torch():
    out = _run("import sys, tactile_cli.learn.splits, tactile_cli.taxel.pipeline; "
               "import tactile_cli.learn as L; L.assign_splits, L.TrainConfig; "
               "print('torch' in sys.modules)")
    assert out == "False"


@pytest.mark.slow
def test_one_name_one_meaning_train_and_evaluate_are_modules():
    """``learn.train`` and ``learn.evaluate`` are the modules, whether or not they were
    imported first; the verbs are ``train_run`` and ``evaluate_run`` (issue 30, item 5)."""
    out = _run("import sys, types; import tactile_cli.learn as L; "
               "first = (isinstance(L.train, types.ModuleType), "
               "isinstance(L.evaluate, types.ModuleType)); "
               "import tactile_cli.learn.train, tactile_cli.learn.evaluate; "
               "from tactile_cli.learn import train, evaluate, train_run, evaluate_run; "
               "import tactile_cli as tc; "
               "print(first, train.__name__, evaluate.__name__, "
               "isinstance(train_run, types.FunctionType), evaluate_run.__module__, "
               "tc.train_run is train_run, hasattr(tc, 'train'), 'train' in L.__all__, "
               "L.build_model.__module__, sorted(L.__all__) == sorted(set(L.__all__)), "
               "'torch' in sys.modules)")
    assert out == ("(True, True) tactile_cli.learn.train tactile_cli.learn.evaluate True "
                   "tactile_cli.learn.pipeline True False False tactile_cli.learn.models True "
                   "True")


def test_every_public_name_resolves():
    import tactile_cli.learn as learn

    for name in learn.__all__:
        assert getattr(learn, name) is not None, name
    assert set(learn.__all__) <= set(dir(learn))


def test_taxel_folds_are_the_cv_folds_of_tactile_train():
    from tactile_cli.taxel.pipeline import stratified_folds

    rng = np.random.default_rng(0)
    names = [f"trial_{i}" for i in range(37)]
    slip = rng.choice(["world", "finger", "none"], size=37)
    trials = [TrialSeries("scene.h5", n, "", np.zeros((4, 1)), np.arange(4) * 0.01, {}, {},
                          {"slip": str(s)}) for n, s in zip(names, slip, strict=True)]
    plan = cv_folds(trials, SplitConfig(mode="stratified", by="slip", val_fraction=0.0), 5, 5)
    keys = [f"scene.h5/{n}" for n in names]
    ours = stratified_folds(keys, slip, 5, 5)
    for fold in plan.folds:
        assert sorted(fold.test_keys) == sorted(k for k, f in zip(keys, ours, strict=True)
                                                if f == fold.index)
    assert stratified_fold_of(keys, slip.tolist(), 5, 5) == ours.tolist()


@pytest.mark.slow
def test_submodules_are_reachable_as_attributes():
    out = _run("import tactile_cli.learn as L; print(L.splits.__name__, L.runs.__name__, "
               "hasattr(L, 'no_such_name'))")
    assert out == "tactile_cli.learn.splits tactile_cli.learn.runs False"


@pytest.mark.slow
def test_commands_that_read_records_do_not_import_torch(tmp_path_factory, action_file,
                                                        heldout_file):
    """`info`, `compare` and `report` read run records, not weights: they start without
    torch (about 1 s of import per process; `info FILE` took 1.9 s instead of 0.6 s while
    the run module imported torch at its top). Loading a model still imports it."""
    from .tiny_runs import tiny_runs

    run = str(tiny_runs(tmp_path_factory, action_file, heldout_file)["lstm"])
    out_dir = tmp_path_factory.mktemp("no_torch")
    out = _run("import sys; from tactile_cli.cli import app; "
               "from tactile_cli.learn import runs; "
               f"r = {run!r}; o = {str(out_dir)!r}; "
               "[app(a, standalone_mode=False) for a in (['info', r], "
               "['compare', r, '--out', o + '/cmp'], ['report', r, '--out', o + '/rep'])]; "
               "print('torch' in sys.modules); runs.load_run(r).load_model(); "
               "print('torch' in sys.modules)")
    assert out.split("\n")[-2:] == ["False", "True"]
