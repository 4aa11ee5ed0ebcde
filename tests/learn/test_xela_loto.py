"""benchmarks/xela_loto.py on the real Xela recordings: 1 family x 2 folds x 1 epoch."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from tests.conftest import load_benchmark, shared_path


def _module():
    return load_benchmark("xela_loto")


def test_wilson_interval_known_value() -> None:
    lo, hi = _module().wilson(5, 10)
    assert abs(lo - 0.2366) < 1e-4 and abs(hi - 0.7634) < 1e-4


@pytest.mark.slow
def test_loto_quick_run_writes_pooled_metrics(tmp_path: Path) -> None:
    source = shared_path("xela_slip")
    mod = _module()
    rc = mod.main(["--source", str(source), "--families", "mlp", "--epochs", "1",
                   "--jobs", "1", "--out", str(tmp_path)])
    assert rc == 0
    rec = json.loads((tmp_path / "xela_loto.json").read_text())
    assert (tmp_path / "xela_loto.png").stat().st_size > 10_000
    assert len(rec["data"]["trials"]) == 7 and len(rec["folds"]) == 7
    (fam,) = rec["families"]
    assert fam["family"] == "mlp" and fam["n_params"] > 0
    p = fam["pooled"]
    folds = fam["per_trial"]
    assert [t["trial"] for t in folds] == rec["folds"]
    assert p["n"] == sum(t["n_steps"] for t in folds) == p["tp"] + p["fp"] + p["fn"] + p["tn"]
    # 196 of the 2,195 steps are slip, all in the three 2022-02-22 trials
    assert p["tp"] + p["fn"] == 196 and p["n"] == 2195
    assert sorted(t["trial"] for t in folds if t["slip_steps"]) == sorted(
        t for t in rec["folds"] if "2022-02-22" in t)
    assert sum(map(sum, p["confusion_matrix"])) == p["n"]
    assert p["accuracy"] == (p["tp"] + p["tn"]) / p["n"]
    assert fam["latency"]["batch1_ms_median"] > 0
    assert set(fam["bootstrap_over_trials95"]) >= {"f1", "accuracy"}
