"""Texture accuracy that predicts later recordings: stratified against blocked CV on real data.

Issue 34, items 1, 2 and 6. A stratified split holds out trials recorded between training
trials; a later session shares none of their sensor state. This study measures, for each
shipped texture config and the same seed, the per-trial accuracy of cross-validations that
differ only in ``data.split`` (each fold trains on the others and is scored on its held-out
trials; validation trials come from the fold's training trials by the same rule)::

    tactile train CONFIG --data FILE --cv K --out RUN     (data.split replaced per protocol)
    tactile evaluate RUN

BioTac (../shared/data/biotac_slide20, ingested with configs/biotac_slide20.yaml: 20
materials x samples 1-10, each material's samples recorded one after another) and every
``configs/train_*biotac_texture*.yaml``:

- ``stratified k2`` / ``stratified k5``: stratified by material (the protocol of issue 11);
- ``blocked k2``: blocked by ``sample``: samples 1-5 against 6-10, both ways;
- ``blocked k5``: blocked by ``sample``: pairs of samples (1-2, 3-4, ...), each held out once;
- ``time k2``: blocked by the trials' start time within each material (the true recording
  order: it differs from the sample numbers only where a sample was re-recorded later).

fabric_slide (../shared/data/fabric_slide, configs/fabric_slide.yaml: 7 fabrics, forces
120-250, speeds -150..150 mm/s, repetitions 0 and 1) and every ``configs/train_*fabric*.yaml``:

- ``stratified k2``: stratified by fabric;
- ``repetition k2``: blocked by ``rep``: train on repetition 0, test on 1, and back;
- ``force k5``: grouped by ``force``: each force setting held out once (never seen in
  training);
- ``speed k4``: grouped by ``speed``: 3 of the 12 speeds held out per fold.

Reported per config and protocol (all from ``tactile evaluate``'s metrics.json): per-trial
accuracy by majority vote (the headline) and by mean probability, each with a 95 % bootstrap
interval over trials (1,000 draws), per-window accuracy with its interval, the per-fold
per-trial accuracy (mean and sample sd over folds), how many held-out trials lie inside the
recording span of their class's training trials (``interleaving``), the largest input shift
(in training SDs, worst fold per channel), parameters and training time. The gap is
stratified minus blocked at the same k (the baseline is in the same run).

    .venv/bin/python benchmarks/texture_blocked_cv.py [--datasets biotac fabric]
        [--configs SUBSTRING...] [--protocols NAME...] [--work DIR] [--bt-data FILE]
        [--fabric-data FILE] [--jobs N] [--finished-only] [--json]

Writes benchmarks/figures/texture_blocked_cv.json. ``--work DIR`` keeps the ingested files
and the run folders; a second call reuses finished runs (same config and data), and
``--finished-only`` reports those without training the rest.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from tactile_cli._version import __version__  # noqa: E402
from tactile_cli.learn import runs  # noqa: E402
from tactile_cli.learn.config import load_config, parse_config  # noqa: E402
from tactile_cli.learn.cv import train_cv  # noqa: E402
from tactile_cli.learn.evaluate import evaluate  # noqa: E402
from tactile_cli.learn.trial_metrics import fmt_interval  # noqa: E402
from tactile_cli.store.writer import sha256_of, utc_now  # noqa: E402

SHARED = ROOT.parent / "shared" / "data"
DATASETS: dict[str, dict[str, Any]] = {
    "biotac": {
        "source": SHARED / "biotac_slide20", "mapping": "biotac_slide20.yaml",
        "configs": "train_*biotac_texture*.yaml", "file": "biotac_slide20.h5",
        "protocols": {
            "stratified k2": ({"mode": "stratified", "by": "material"}, 2),
            "blocked k2": ({"mode": "blocked", "by": "sample"}, 2),
            "stratified k5": ({"mode": "stratified", "by": "material"}, 5),
            "blocked k5": ({"mode": "blocked", "by": "sample"}, 5),
            "time k2": ({"mode": "blocked", "by": "time_origin_unix_s", "within": "material"},
                        2),
        },
    },
    "fabric": {
        "source": SHARED / "fabric_slide", "mapping": "fabric_slide.yaml",
        "configs": "train_*fabric*.yaml", "file": "fabric_slide.h5",
        "protocols": {
            "stratified k2": ({"mode": "stratified", "by": "fabric"}, 2),
            "repetition k2": ({"mode": "blocked", "by": "rep"}, 2),
            "force k5": ({"mode": "group", "by": "force"}, 5),
            "speed k4": ({"mode": "group", "by": "speed"}, 4),
        },
    },
}


def ingest(source: Path, mapping: str, out: Path) -> Path:
    """``tactile ingest SOURCE --mapping configs/MAPPING --out OUT`` (kept when present)."""
    if out.exists():
        return out
    exe = Path(sys.executable).with_name("tactile")
    subprocess.run([str(exe) if exe.exists() else "tactile", "ingest", str(source),
                    "--mapping", str(ROOT / "configs" / mapping), "--out", str(out)],
                   check=True, stdout=subprocess.DEVNULL)
    return out


def _config_with_split(path: Path, split: dict[str, Any]) -> Any:
    raw = load_config(path).model_dump(mode="json")
    raw["data"]["split"] = {**split, "val_fraction": raw["data"]["split"]["val_fraction"],
                            "test_fraction": 0.0}
    return parse_config(raw)


def run_dir(work: Path, cfg_path: Path, protocol: str) -> Path:
    return work / "runs" / f"{cfg_path.stem}__{protocol.replace(' ', '_')}"


def run_protocol(cfg_path: Path, protocol: str, split: dict[str, Any], k: int, data: Path,
                 work: Path, jobs: int | None) -> dict[str, Any]:
    """Cross-validate ``cfg_path`` under one protocol and read its evaluation."""
    config = _config_with_split(cfg_path, split)
    run = run_dir(work, cfg_path, protocol)
    started = time.perf_counter()
    trained = False
    if not (run / runs.RUN_JSON).is_file():
        train_cv(config, [data], run, k=k, jobs=jobs, config_path=cfg_path, overwrite=True,
                 command="benchmarks/texture_blocked_cv.py")
        trained = True
    wall = time.perf_counter() - started
    ev = evaluate(run, None, threads=1, latency=False, overwrite=True,
                  command="benchmarks/texture_blocked_cv.py")
    head = ev.heads[0]
    assert ev.cv is not None and head.per_trial is not None
    info = runs.read_run_info(run)
    inter, shift = ev.extra["interleaving"], ev.extra["shift"]
    return {
        "config": str(cfg_path.relative_to(ROOT)), "protocol": protocol, "k": k,
        "split": split, "family": ev.family, "n_params": ev.n_params,
        "n_trials": ev.n_trials, "n_windows": ev.n_windows,
        "trial_accuracy": head.per_trial["majority_accuracy"],
        "trial_accuracy_ci95": head.per_trial["majority_accuracy_ci95"],
        "trial_accuracy_mean_probability": head.per_trial["mean_probability_accuracy"],
        "trial_accuracy_mean_probability_ci95":
            head.per_trial["mean_probability_accuracy_ci95"],
        "window_accuracy": head.accuracy, "window_accuracy_ci95": head.accuracy_ci95,
        "fold_trial_accuracy": [f.get("per_trial_accuracy") for f in ev.cv["folds"]],
        "fold_trial_accuracy_mean": ev.cv["per_trial_accuracy_mean"],
        "fold_trial_accuracy_std": ev.cv["per_trial_accuracy_std"],
        "held_out": [len(f["test"]) for f in info["cv"]["folds"]],
        "interleaving": {k_: inter.get(k_) for k_ in ("order_by", "n_evaluated",
                                                       "n_inside_span", "n_inside_class_span",
                                                       "interleaved")},
        "max_abs_shift_sd": shift["max_abs_shift_sd"], "shift_flagged": shift["flagged"],
        "train_time_s": info["training"]["train_time_s"], "trained_now": trained,
        "wall_s": wall,
    }


def _pct(v: float | None) -> str:
    return "n/a" if v is None else f"{100 * v:.1f}"


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--datasets", nargs="+", default=list(DATASETS), choices=list(DATASETS))
    ap.add_argument("--configs", nargs="*", default=None,
                    help="only configs whose file name holds one of these strings")
    ap.add_argument("--protocols", nargs="*", default=None,
                    help="only these protocols (e.g. 'blocked k2')")
    ap.add_argument("--bt-data", type=Path, default=None, help="ingested biotac_slide20.h5")
    ap.add_argument("--fabric-data", type=Path, default=None, help="ingested fabric_slide.h5")
    ap.add_argument("--work", type=Path, default=None, help="keep ingests and runs here")
    ap.add_argument("--jobs", type=int, default=1, help="folds trained side by side")
    ap.add_argument("--finished-only", action="store_true",
                    help="report the runs already in --work, train none")
    ap.add_argument("--json", action="store_true", help="print the record as JSON")
    ap.add_argument("--out", type=Path, default=ROOT / "benchmarks" / "figures")
    args = ap.parse_args(argv)
    given = {"biotac": args.bt_data, "fabric": args.fabric_data}
    rows: list[dict[str, Any]] = []
    data_records = {}
    with tempfile.TemporaryDirectory(prefix="texture_blocked_") as tmp_s:
        work = args.work or Path(tmp_s)
        work.mkdir(parents=True, exist_ok=True)
        for name in args.datasets:
            spec = DATASETS[name]
            data = given[name] or ingest(spec["source"], spec["mapping"], work / spec["file"])
            data_records[name] = {"path": str(data), "sha256": sha256_of(data),
                                  "source": str(spec["source"]),
                                  "mapping": f"configs/{spec['mapping']}"}
            configs = sorted((ROOT / "configs").glob(spec["configs"]))
            if args.configs:
                configs = [c for c in configs if any(s in c.name for s in args.configs)]
            for cfg in configs:
                for protocol, (split, k) in spec["protocols"].items():
                    if args.protocols and protocol not in args.protocols:
                        continue
                    if args.finished_only and \
                            not (run_dir(work, cfg, protocol) / runs.RUN_JSON).is_file():
                        continue
                    row = run_protocol(cfg, protocol, split, k, data, work, args.jobs)
                    rows.append({"dataset": name, **row})
                    print(f"{name:6} {cfg.stem:42} {protocol:14} trial "
                          f"{_pct(row['trial_accuracy'])} % "
                          f"[{fmt_interval(row['trial_accuracy_ci95'])}]", file=sys.stderr)
    gaps = []
    for r in rows:
        if r["protocol"].startswith("stratified"):
            for b in rows:
                if b["config"] == r["config"] and b["k"] == r["k"] and b is not r and \
                        not b["protocol"].startswith("stratified"):
                    gaps.append({"config": r["config"], "k": r["k"],
                                 "against": b["protocol"],
                                 "stratified_minus_blocked_pp":
                                     100 * (r["trial_accuracy"] - b["trial_accuracy"])})
    record = {"format": "tactile-texture-blocked-cv", "format_version": 1,
              "tool_version": __version__, "created_utc": utc_now(),
              "command": " ".join([Path(sys.argv[0]).name, *(argv or sys.argv[1:])]),
              "data": data_records, "rows": rows, "gaps": gaps,
              "interval": "95 % bootstrap over held-out trials (1,000 draws, seed 0)"}
    args.out.mkdir(parents=True, exist_ok=True)
    out = args.out / "texture_blocked_cv.json"
    if out.exists() and (args.configs or args.protocols or len(args.datasets) < len(DATASETS)):
        out = args.out / "texture_blocked_cv.partial.json"  # a subset keeps the full record
    tmp_json = out.with_name(out.name + ".tmp")
    tmp_json.write_text(json.dumps(record, indent=2) + "\n", encoding="utf-8")
    os.replace(tmp_json, out)
    if args.json:
        print(json.dumps(record, indent=2))
        return 0
    print(f"{'data':6} {'config':42} {'protocol':14} {'trial %':>7} {'95% CI':>11} "
          f"{'folds mean+-sd':>15} {'window %':>8} {'inside':>6} {'shift':>5}")
    for r in rows:
        inter = r["interleaving"]
        inside = inter["n_inside_class_span"] if inter["n_inside_class_span"] is not None \
            else inter["n_inside_span"]
        print(f"{r['dataset']:6} {Path(r['config']).stem:42} {r['protocol']:14} "
              f"{_pct(r['trial_accuracy']):>7} {fmt_interval(r['trial_accuracy_ci95']):>11} "
              f"{_pct(r['fold_trial_accuracy_mean']):>6} +- "
              f"{_pct(r['fold_trial_accuracy_std']):>5} {_pct(r['window_accuracy']):>8} "
              f"{'?' if inside is None else inside:>6} {r['max_abs_shift_sd']:5.2f}")
    for g in gaps:
        print(f"gap {Path(g['config']).stem} k{g['k']}: stratified - {g['against']} = "
              f"{g['stratified_minus_blocked_pp']:+.1f} pp")
    print(f"wrote {out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
