"""How much of a cross-validated figure is the seed? One config, one split, several seeds.

A figure on a small real set can move more with the seed (initial weights, batch order,
a forest's bootstraps) than between the models it is meant to rank: on the 20 GelSight
lifts the shipped CNN-LSTM decides 85 % of an unseen object's lifts at seed 0 and 65-70 % at
seeds 1-4 (benchmarks/RESULTS.md, "Seeds"). This script trains and evaluates a config as
``tactile train CONFIG --data FILE... --cv K --seed S`` and ``tactile evaluate RUN`` do
(:func:`tactile_cli.learn.pipeline.train_run`, :func:`tactile_cli.learn.cv.evaluate_cv`),
once per seed, same folds (the split does not depend on the seed when ``data.split`` is
grouped or blocked; a stratified or random split is drawn from the seed too, and the record
says which), and prints each seed's figures beside their mean, sample SD, min and max:

    .venv/bin/python benchmarks/seed_spread.py configs/train_cnn2d_biotac_texture_zscore.yaml \\
        --data biotac_slide20.h5 --cv 2 --seeds 0 1 2 [--json] [--record out.json]

Figures per seed (the primary head): per-window accuracy and macro F1 of the pooled held-out
folds, and, where the evaluation has them, per-trial majority and mean-probability accuracy.
Keys of ``--json``: ``seeds``, ``by_seed`` (one row per seed), ``summary`` (metric ->
``{"mean", "sd", "min", "max", "spread"}``; ``spread`` = max - min, ``sd`` with ddof 1),
``split_depends_on_seed``. Results do not depend on the thread count: every fold trains on
the config's ``optim.threads`` in this process (``--jobs 1``).
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from tactile_cli._version import __version__  # noqa: E402
from tactile_cli.errors import InputError  # noqa: E402
from tactile_cli.learn.config import load_config  # noqa: E402
from tactile_cli.learn.cv import evaluate_cv, parse_cv  # noqa: E402
from tactile_cli.learn.pipeline import train_run  # noqa: E402
from tactile_cli.store.provenance import sha256_of, utc_now  # noqa: E402

#: metric name -> where it is in a primary head of metrics.json
METRICS = {
    "window_accuracy": ("accuracy",),
    "window_macro_f1": ("macro_f1",),
    "trial_majority_accuracy": ("per_trial", "majority_accuracy"),
    "trial_mean_probability_accuracy": ("per_trial", "mean_probability_accuracy"),
}


def _get(head: dict[str, Any], path: tuple[str, ...]) -> float | None:
    value: Any = head
    for key in path:
        if not isinstance(value, dict) or value.get(key) is None:
            return None
        value = value[key]
    return float(value)


def one_seed(config: Path, data: list[Path], k: int | str, seed: int, work: Path
             ) -> dict[str, Any]:
    """Train and evaluate ``config`` at ``seed``; the primary head's figures and folds."""
    run = work / f"seed{seed}"
    started = time.perf_counter()
    train_run(config, data, out=run, seed=seed, cv=k, jobs=1, overwrite=True,
              device="cpu")
    ev = evaluate_cv(run, None, latency=False, command="seed_spread", overwrite=True)
    metrics = json.loads((ev.out_dir / "metrics.json").read_text(encoding="utf-8"))
    head = metrics["heads"][metrics["primary_head"]]
    row: dict[str, Any] = {"seed": seed, "run": str(run), "wall_time_s":
                           time.perf_counter() - started}
    for name, path in METRICS.items():
        row[name] = _get(head, path)
    row["folds"] = [{k_: f.get(k_) for k_ in ("fold", "accuracy", "per_trial_accuracy")}
                    for f in metrics["cv"]["folds"]]
    return row


def summarise(rows: list[dict[str, Any]]) -> dict[str, dict[str, float]]:
    """metric -> mean, sample sd (0 for one seed), min, max and spread over the seeds."""
    out = {}
    for name in METRICS:
        values = [r[name] for r in rows if r[name] is not None]
        if not values:
            continue
        out[name] = {"mean": statistics.fmean(values),
                     "sd": statistics.stdev(values) if len(values) > 1 else 0.0,
                     "min": min(values), "max": max(values),
                     "spread": max(values) - min(values), "n_seeds": len(values)}
    return out


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("config", type=Path, help="a training config (configs/train_*.yaml)")
    ap.add_argument("--data", type=Path, nargs="+", required=True, help="tactile HDF5 files")
    ap.add_argument("--cv", default="5", help="folds (an integer >= 2) or loto")
    ap.add_argument("--seeds", type=int, nargs="+", default=[0, 1, 2])
    ap.add_argument("--work", type=Path, default=None,
                    help="keep the run folders here (default: a temporary folder)")
    ap.add_argument("--record", type=Path, default=None, help="write the record here")
    ap.add_argument("--json", action="store_true", help="print the record as JSON")
    args = ap.parse_args(argv)
    for path in (args.config, *args.data):
        if not path.is_file():
            print(f"error: {path}: file not found", file=sys.stderr)
            return 2
    if len(set(args.seeds)) != len(args.seeds):
        print("error: --seeds: a seed is given twice", file=sys.stderr)
        return 2
    try:  # a bad config, data or --cv: one line naming it, as `tactile train` says it
        k = parse_cv(args.cv)
        split = load_config(args.config).data.split
        with tempfile.TemporaryDirectory(prefix="seed_spread_") as tmp:
            work = args.work if args.work is not None else Path(tmp)
            work.mkdir(parents=True, exist_ok=True)
            rows = []
            for seed in args.seeds:
                print(f"seed {seed}", file=sys.stderr, flush=True)
                rows.append(one_seed(args.config, args.data, k, seed, work))
    except InputError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    record = {
        "format": "tactile-seed-spread", "format_version": 1, "tool_version": __version__,
        "created_utc": utc_now(),
        "command": " ".join([Path(sys.argv[0]).name, *sys.argv[1:]]) if argv is None
        else "main(" + " ".join(argv) + ")",
        "config": str(args.config), "config_sha256": sha256_of(args.config),
        "data": [{"path": str(p), "sha256": sha256_of(p)} for p in args.data],
        "cv": k, "split": split.model_dump(mode="json"),
        "split_depends_on_seed": split.mode in ("auto", "random", "stratified"),
        "seeds": args.seeds, "by_seed": rows, "summary": summarise(rows),
    }
    if args.record is not None:
        tmp_path = args.record.with_name(args.record.name + ".tmp")
        tmp_path.write_text(json.dumps(record, indent=1) + "\n", encoding="utf-8")
        os.replace(tmp_path, args.record)
    if args.json:
        print(json.dumps(record, indent=1))
        return 0
    names = [n for n in METRICS if n in record["summary"]]
    print("| seed | " + " | ".join(names) + " |")
    print("|---:|" + "---:|" * len(names))
    for r in rows:
        print(f"| {r['seed']} | " + " | ".join(f"{r[n]:.1%}" for n in names) + " |")
    for stat in ("mean", "sd", "min", "max", "spread"):
        print(f"| {stat} | " + " | ".join(f"{record['summary'][n][stat]:.1%}" for n in names)
              + " |")
    if record["split_depends_on_seed"]:
        print(f"note: data.split is {split.mode}: the folds may change with the seed too",
              file=sys.stderr)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
