"""Trial-level splits and cross-validation folds (issue 11, items 1, 2 and 7)."""

from __future__ import annotations

from collections import Counter

import numpy as np
import pytest

from tactile_cli.errors import InputError
from tactile_cli.learn.config import SplitConfig
from tactile_cli.learn.data import TrialSeries
from tactile_cli.learn.splits import (
    assign_splits,
    cv_folds,
    held_out_trials,
    read_split_csv,
    split_from_mapping,
    trial_class,
)
from tactile_cli.natural import natural_sorted


def _trial(name: str, file: str = "f.h5", **labels) -> TrialSeries:
    x = np.zeros((4, 1), np.float32)
    slip = labels.pop("slip", None)
    sample = {} if slip is None else {"slip": np.asarray(slip, np.int64)}
    classes = {} if slip is None else {"slip": ("no_slip", "slip")}
    return TrialSeries(file, name, "", x, np.arange(4) * 0.01, sample, classes, labels)


def _materials(n_classes: int = 20, per_class: int = 10, file: str = "bt.h5"
               ) -> list[TrialSeries]:
    return [_trial(f"mat{m}_{i}", file, material=f"mat{m}", day=f"d{(m + i) % 4}")
            for m in range(1, n_classes + 1) for i in range(1, per_class + 1)]


def test_stratified_split_puts_every_class_in_every_split_in_proportion():
    trials = _materials()
    a = assign_splits(trials, SplitConfig(mode="stratified", by="material", val_fraction=0.1,
                                          test_fraction=0.2), seed=0)
    assert a.mode == "stratified" and a.counts() == {"train": 140, "val": 20, "test": 40}
    per = Counter((t.trial_labels["material"], s) for t, s in zip(trials, a.splits, strict=True))
    for m in range(1, 21):
        assert (per[(f"mat{m}", "test")], per[(f"mat{m}", "val")]) == (2, 1)
    assert a.warnings == ()


def test_random_split_of_the_same_data_is_not_stratified():
    """The failure the issue reports: a random split leaves materials out of test."""
    trials = _materials()
    a = assign_splits(trials, SplitConfig(mode="random", val_fraction=0.1, test_fraction=0.2),
                      seed=0)
    per = Counter(t.trial_labels["material"] for t, s in zip(trials, a.splits, strict=True)
                  if s == "test")
    assert sum(per.values()) == 40 and max(per.values()) > 2


def test_a_class_too_small_for_a_split_is_kept_for_training_with_a_warning():
    trials = _materials(3, 5) + [_trial("rare_1", material="rare")]
    a = assign_splits(trials, SplitConfig(mode="stratified", by="material", val_fraction=0.2,
                                          test_fraction=0.2), seed=1)
    rare = a.splits[-1]
    assert rare == "train"
    assert any("material=rare has 1 trial(s): none in val" in w for w in a.warnings)
    assert any("material=rare has 1 trial(s): none in test" in w for w in a.warnings)


def test_group_split_never_splits_a_group():
    trials = _materials(10, 6)
    a = assign_splits(trials, SplitConfig(mode="group", by="day", val_fraction=0.2,
                                          test_fraction=0.25), seed=5)
    sides: dict[str, set[str]] = {}
    for t, s in zip(trials, a.splits, strict=True):
        sides.setdefault(t.trial_labels["day"], set()).add(s)
    assert all(len(v) == 1 for v in sides.values())
    assert {s for v in sides.values() for s in v} == {"train", "val", "test"}


def test_splits_do_not_depend_on_file_or_trial_order():
    trials = _materials(5, 6, "a.h5") + _materials(5, 6, "b.h5")
    for mode in ("random", "stratified", "group"):
        cfg = SplitConfig(mode=mode, by="day", val_fraction=0.2, test_fraction=0.2)
        a = assign_splits(trials, cfg, seed=2)
        b = assign_splits(trials[::-1], cfg, seed=2)
        assert dict(zip((t.key for t in trials), a.splits, strict=True)) == \
            dict(zip((t.key for t in trials[::-1]), b.splits, strict=True)), mode


def test_per_sample_label_classes_a_trial_by_the_classes_it_holds():
    slip = _trial("s", slip=[0, 0, 1, 1])
    calm = _trial("c", slip=[0, 0, 0, -1])
    assert trial_class(slip, "slip") == "no_slip+slip"
    assert trial_class(calm, "slip") == "no_slip"
    with pytest.raises(InputError, match="no trial or per-sample label 'grip'"):
        trial_class(calm, "grip")


@pytest.mark.parametrize("mode", ["random", "stratified", "group"])
def test_k_folds_hold_out_every_trial_exactly_once(mode):
    trials = _materials(10, 5)
    by = "day" if mode == "group" else "material"
    plan = cv_folds(trials, SplitConfig(mode=mode, by=by, val_fraction=0.2), seed=0, k=4)
    held = [k for f in plan.folds for k in f.test_keys]
    assert sorted(held) == sorted(t.key for t in trials)
    for f in plan.folds:
        splits = dict(zip((t.key for t in trials), f.assignment.splits, strict=True))
        assert {k for k, s in splits.items() if s == "test"} == set(f.test_keys)
        assert "val" in splits.values() and "train" in splits.values()
    if mode == "stratified":  # 5 trials per class over 4 folds: 1 or 2 per fold
        for f in plan.folds:
            per = Counter(k.split("/")[1].split("_")[0] for k in f.test_keys)
            assert set(per.values()) <= {1, 2} and len(per) == 10
    if mode == "group":
        day = {t.key: t.trial_labels["day"] for t in trials}
        for f in plan.folds:
            inside = {day[k] for k in f.test_keys}
            assert not inside & {day[t.key] for t in trials if t.key not in f.test_keys}


def test_leave_one_trial_out_and_fold_errors():
    trials = _materials(2, 3)
    plan = cv_folds(trials, SplitConfig(mode="random", val_fraction=0.0), seed=0, k="loto")
    assert len(plan.folds) == 6 and all(len(f.test_keys) == 1 for f in plan.folds)
    assert all(f.assignment.counts() == {"train": 5, "val": 0, "test": 1} for f in plan.folds)
    with pytest.raises(InputError, match="cannot make 7 folds"):
        cv_folds(trials, SplitConfig(mode="random"), seed=0, k=7)
    with pytest.raises(InputError, match="has 4 group"):
        cv_folds(_materials(2, 3), SplitConfig(mode="group", by="day"), seed=0, k=5)
    with pytest.raises(InputError, match="cross-validation makes its own folds"):
        cv_folds(trials, SplitConfig(mode="attribute"), seed=0, k=2)


def test_stratified_folds_warn_about_a_class_with_fewer_trials_than_folds():
    trials = _materials(3, 5) + [_trial("rare_1", material="rare")]
    plan = cv_folds(trials, SplitConfig(mode="stratified", by="material", val_fraction=0.0),
                    seed=0, k=5)
    assert any("material=rare has 1 trial(s), fewer than the 5 folds" in w
               for w in plan.warnings)


def test_split_csv_sets_every_trial_and_names_bad_rows(tmp_path):
    trials = [_trial("t1", "a.h5"), _trial("t2", "a.h5"), _trial("t1", "b.h5")]
    good = tmp_path / "split.csv"
    good.write_text('file,trial,split\na.h5,t1,train\n"a.h5","t2",val\nb.h5,t1,test\n')
    a = split_from_mapping(trials, read_split_csv(good), source=good)
    assert a.splits == ("train", "val", "test")
    short = tmp_path / "short.csv"
    short.write_text("trial,split\nt2,test\n")
    with pytest.raises(InputError, match="trial a.h5/t1 has no split"):
        split_from_mapping(trials, read_split_csv(short), source=short)
    bad = tmp_path / "bad.csv"
    bad.write_text("trial,split\nt1,train\nt2,holdout\n")
    with pytest.raises(InputError, match=r"row 3: split 'holdout' is not one of"):
        read_split_csv(bad)


def test_test_trials_prefer_the_run_s_recorded_split(tmp_path):
    trials = _materials(2, 5)
    csv = tmp_path / "split.csv"
    csv.write_text("file,trial,split\n" + "".join(
        f"/x/bt.h5,{t.trial},{'test' if t.trial.endswith('_1') else 'train'}\n"
        for t in trials))
    held = held_out_trials(trials, split_csv=csv, split=SplitConfig(mode="random"), seed=0)
    assert [t.trial for t in held] == ["mat1_1", "mat2_1"]


def test_natural_order_of_classes():
    assert natural_sorted(["mat10", "mat2", "mat1", "10", "9"]) == \
        ["9", "10", "mat1", "mat2", "mat10"]


def test_fold_text_names_leave_one_trial_out():
    from tactile_cli.learn.splits import fold_text

    assert fold_text("loto", 7, "random") == "7 folds (leave one trial out)"
    assert fold_text(5, 5, "stratified", "material") == "5 folds (stratified by material)"
    assert fold_text(4, 4, "random") == "4 folds (random)"
