"""Blocked splits and folds: whole stretches of recording order held out (issue 34, item 1)."""

from __future__ import annotations

import numpy as np
import pytest
from pydantic import ValidationError

from tactile_cli.errors import InputError
from tactile_cli.learn.config import SplitConfig
from tactile_cli.learn.data import TrialSeries
from tactile_cli.learn.splits import assign_splits, contiguous_blocks, cv_folds, fold_text


def _trial(name: str, file: str = "bt.h5", t0: float | None = None, **labels) -> TrialSeries:
    return TrialSeries(file, name, "", np.zeros((4, 1), np.float32), np.arange(4) * 0.01,
                       trial_labels=labels, time_origin_unix_s=t0)


def _slides(n_materials: int = 3, n_samples: int = 10, file: str = "bt.h5"
            ) -> list[TrialSeries]:
    """Material m, sample i (recorded as text, like the BioTac mapping's labels)."""
    return [_trial(f"mat{m}_{i}", file, material=f"mat{m}", sample=str(i))
            for m in range(1, n_materials + 1) for i in range(1, n_samples + 1)]


def _samples_of(keys) -> list[int]:
    return sorted({int(k.rsplit("_", 1)[1]) for k in keys})


def test_two_blocked_folds_are_samples_1_to_5_and_6_to_10_with_val_next_to_test():
    trials = _slides()
    plan = cv_folds(trials, SplitConfig(mode="blocked", by="sample", val_fraction=0.1),
                    seed=0, k=2)
    assert plan.mode == "blocked" and plan.by == "sample"
    assert [_samples_of(f.test_keys) for f in plan.folds] == [[1, 2, 3, 4, 5],
                                                              [6, 7, 8, 9, 10]]
    val = [[t.trial for t, s in zip(trials, f.assignment.splits, strict=True) if s == "val"]
           for f in plan.folds]
    # the latest training block validates: sample 10 when 1-5 are held out, 5 otherwise
    assert val == [["mat1_10", "mat2_10", "mat3_10"], ["mat1_5", "mat2_5", "mat3_5"]]
    assert [f.assignment.counts() for f in plan.folds] == \
        [{"train": 12, "val": 3, "test": 15}] * 2
    assert fold_text(2, 2, "blocked", "sample") == "2 folds (blocked by sample)"


def test_blocked_folds_never_interleave_and_are_contiguous_in_natural_order():
    trials = _slides(2, 10)
    plan = cv_folds(trials, SplitConfig(mode="blocked", by="sample", val_fraction=0.0),
                    seed=0, k=3)
    held = [_samples_of(f.test_keys) for f in plan.folds]
    # 10 values into 3 blocks as even as possible, "10" after "9" (natural order, not text)
    assert held == [[1, 2, 3], [4, 5, 6], [7, 8, 9, 10]]
    for samples in held:
        assert samples == list(range(samples[0], samples[-1] + 1))


def test_blocked_folds_ignore_the_seed_and_the_order_of_files_and_trials():
    trials = _slides(3, 6, "a.h5") + _slides(3, 6, "b.h5")
    cfg = SplitConfig(mode="blocked", by="sample", val_fraction=0.2)
    a = cv_folds(trials, cfg, seed=0, k=3)
    b = cv_folds(trials[::-1], cfg, seed=99, k=3)
    assert [sorted(f.test_keys) for f in a.folds] == [sorted(f.test_keys) for f in b.folds]
    for fa, fb in zip(a.folds, b.folds, strict=True):
        assert dict(zip((t.key for t in trials), fa.assignment.splits, strict=True)) == \
            dict(zip((t.key for t in trials[::-1]), fb.assignment.splits, strict=True))


def test_blocked_by_start_time_within_each_material():
    # material A recorded first, then B; B's trial 2 was recorded last
    times = {"A_1": 10.0, "A_2": 11.0, "A_3": 12.0, "A_4": 13.0,
             "B_1": 20.0, "B_2": 99.0, "B_3": 21.0, "B_4": 22.0}
    trials = [_trial(n, t0=t, material=n[0]) for n, t in times.items()]
    plan = cv_folds(trials, SplitConfig(mode="blocked", by="time_origin_unix_s",
                                        within="material", val_fraction=0.0), seed=0, k=2)
    assert [sorted(k.split("/")[1] for k in f.test_keys) for f in plan.folds] == \
        [["A_1", "A_2", "B_1", "B_3"], ["A_3", "A_4", "B_2", "B_4"]]
    assert plan.as_dict()["within"] == "material"
    across = cv_folds(trials, SplitConfig(mode="blocked", by="time_origin_unix_s",
                                          val_fraction=0.0), seed=0, k=2)
    assert sorted(k.split("/")[1] for k in across.folds[0].test_keys) == \
        ["A_1", "A_2", "A_3", "A_4"]


def test_blocked_train_val_test_split_holds_out_the_latest_recordings():
    trials = _slides(4, 10)
    a = assign_splits(trials, SplitConfig(mode="blocked", by="sample", val_fraction=0.1,
                                          test_fraction=0.2), seed=0)
    assert a.mode == "blocked" and a.counts() == {"train": 28, "val": 4, "test": 8}
    side = {int(t.trial_labels["sample"]): s for t, s in zip(trials, a.splits, strict=True)}
    assert side == {**dict.fromkeys(range(1, 8), "train"), 8: "val", 9: "test", 10: "test"}


def test_blocked_errors_and_warnings():
    with pytest.raises(ValidationError, match="`mode: blocked` needs `by`"):
        SplitConfig(mode="blocked")
    with pytest.raises(ValidationError, match="`within` goes with `mode: blocked` only"):
        SplitConfig(mode="stratified", by="material", within="material")
    with pytest.raises(InputError, match="label 'sample' has 2 value"):
        cv_folds(_slides(2, 2), SplitConfig(mode="blocked", by="sample"), seed=0, k=3)
    with pytest.raises(InputError, match="no trial label 'session' to order the blocks by"):
        cv_folds(_slides(2, 4), SplitConfig(mode="blocked", by="session"), seed=0, k=2)
    with pytest.raises(InputError, match="trial has no start time"):
        cv_folds(_slides(2, 4), SplitConfig(mode="blocked", by="time_origin_unix_s"), seed=0,
                 k=2)
    # two values, two folds: no block is left to validate on, and that is said
    plan = cv_folds(_slides(2, 2), SplitConfig(mode="blocked", by="sample", val_fraction=0.2),
                    seed=0, k=2)
    assert [f.assignment.counts() for f in plan.folds] == \
        [{"train": 2, "val": 0, "test": 2}] * 2
    assert plan.folds[0].assignment.warnings == ("sample has 1 value(s): none left for val",)
    with pytest.raises(InputError, match="label 'sample' has 1 value"):
        assign_splits(_slides(2, 1), SplitConfig(mode="blocked", by="sample",
                                                 test_fraction=0.2), seed=0)
    uneven = _slides(1, 4) + [_trial("rare_1", material="rare", sample="1")]
    plan = cv_folds(uneven, SplitConfig(mode="blocked", by="sample", within="material",
                                        val_fraction=0.0), seed=0, k=2)
    assert any("material=rare has 1 value(s) of sample, fewer than the 2 folds" in w
               for w in plan.warnings)


def test_contiguous_blocks_are_as_even_as_possible():
    assert contiguous_blocks([1] * 7, 3) == [0, 0, 1, 1, 2, 2, 2]
    assert contiguous_blocks([100, 1, 1], 3) == [0, 1, 2]  # every block holds a value
    assert contiguous_blocks([5, 1, 1, 1, 1, 1], 2) == [0, 1, 1, 1, 1, 1]
    assert contiguous_blocks([3], 1) == [0]
    with pytest.raises(ValueError, match="between 1 and the number of values"):
        contiguous_blocks([1, 1], 3)


def test_blocks_larger_than_the_fraction_asked_are_said():
    """Blocked by repetition with 2 repetitions: val_fraction 0.1 holds out a whole
    repetition, half the trials; the split says so instead of training on half silently."""
    trials = [_trial(f"f{i}_{r}", rep=str(r)) for i in range(10) for r in (0, 1)]
    a = assign_splits(trials, SplitConfig(mode="blocked", by="rep", val_fraction=0.1),
                      seed=0)
    assert a.counts() == {"train": 10, "val": 10, "test": 0}
    assert a.warnings == (
        "val: 10 of 20 trial(s) (50 %) for val_fraction 0.1: whole blocks of rep are held out "
        "and 2 value(s) make blocks that large; give more values of rep, or val_fraction 0 (no "
        "early stopping) if that is too much to hold out",)
    # blocks near the fraction asked: nothing to say (4 of 40 for 0.1)
    assert assign_splits(_slides(4, 10), SplitConfig(mode="blocked", by="sample",
                                                     val_fraction=0.1), seed=0).warnings == ()


def test_the_folds_without_validation_are_named_once():
    from tactile_cli.learn.cv import _fold_split_warnings

    plan = cv_folds(_slides(2, 2), SplitConfig(mode="blocked", by="sample", val_fraction=0.2),
                    seed=0, k=2)
    assert _fold_split_warnings(plan) == [
        "fold(s) 0, 1: sample has 1 value(s): none left for val (no validation trials: "
        "patience and monitor do nothing; the last epoch is kept)"]
