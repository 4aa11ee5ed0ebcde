"""Slip detection on the real Xela uSkin recordings, leave one trial out (issue 4, item 7).

The 7 trials of ../shared/data/xela_slip (3 with slip, 196 slip steps out of 2,195) are
ingested with configs/xela_slip.yaml. Every model family (configs/train_<family>_xela_
slip.yaml) is cross-validated leave-one-trial-out exactly as ``tactile train CONFIG --data
xela.h5 --cv loto`` and ``tactile evaluate RUN`` do (:func:`tactile_cli.learn.cv.train_cv`,
:func:`tactile_cli.learn.evaluate.evaluate`): one model per held-out trial, 6 training
trials, no validation trial. The per-step decisions of the 7 folds are pooled into one
confusion matrix per family: slip precision, recall and F1, accuracy, with 95 % intervals
(Wilson on the pooled counts for precision, recall and accuracy; a bootstrap over trials for
F1 and accuracy, since steps of one trial are not independent). Cost: training time per fold
and the batch-1 latency per window of the first fold's model (1 thread,
:func:`tactile_cli.learn.measure_latency`).

Writes benchmarks/figures/xela_loto.json and xela_loto.png (slip F1 against batch-1
latency, the chart of ``tactile compare``)::

    tactile ingest ../shared/data/xela_slip --mapping configs/xela_slip.yaml --out /tmp/xela.h5
    .venv/bin/python benchmarks/xela_loto.py --data /tmp/xela.h5
    .venv/bin/python benchmarks/xela_loto.py --data /tmp/xela.h5 --families mlp --epochs 1 \\
        --out /tmp/loto                        # a quick check

Without ``--data`` the recordings under ``--source`` are ingested into a temporary file.
"""

from __future__ import annotations

import argparse
import csv
import json
import math
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from tactile_cli._version import __version__  # noqa: E402
from tactile_cli.learn import load_config, runs  # noqa: E402
from tactile_cli.learn.compare import RunPoint, compare_points, plot_comparison  # noqa: E402
from tactile_cli.learn.cv import train_cv  # noqa: E402
from tactile_cli.learn.evaluate import evaluate  # noqa: E402
from tactile_cli.store.provenance import sha256_of, utc_now  # noqa: E402

FAMILIES = ("lstm", "cnn1d", "fnn", "mlp")
SLIP = "slip"
Z95 = 1.959963984540054


def wilson(k: int, n: int, z: float = Z95) -> list[float]:
    """95 % Wilson score interval [lo, hi] of a proportion k/n; [nan, nan] for n = 0."""
    if n <= 0:
        return [math.nan, math.nan]
    p = k / n
    den = 1 + z * z / n
    centre = (p + z * z / (2 * n)) / den
    half = z * math.sqrt(p * (1 - p) / n + z * z / (4 * n * n)) / den
    return [max(0.0, centre - half), min(1.0, centre + half)]


def counts_f1(tp: int, fp: int, fn: int) -> float:
    """F1 from counts; 0 when there is no true or predicted positive."""
    den = 2 * tp + fp + fn
    return 2 * tp / den if den else 0.0


def bootstrap_over_trials(per_trial: list[dict[str, int]], *, reps: int, seed: int
                          ) -> dict[str, list[float]]:
    """95 % percentile intervals of pooled slip F1 and accuracy when the trials are drawn
    with replacement (``per_trial``: tp, fp, fn, tn counts of each held-out trial)."""
    rng = np.random.default_rng(seed)
    c = np.array([[t["tp"], t["fp"], t["fn"], t["tn"]] for t in per_trial], dtype=np.int64)
    pick = rng.integers(0, len(c), size=(reps, len(c)))
    s = c[pick].sum(axis=1)  # (reps, 4)
    tp, fp, fn, tn = s.T
    den = 2 * tp + fp + fn
    f1 = np.divide(2 * tp, den, out=np.zeros(reps), where=den > 0)
    acc = (tp + tn) / s.sum(axis=1)
    no_slip = int((tp + fn == 0).sum())  # resamples that hold no slip trial at all
    return {"f1": [float(np.percentile(f1, 2.5)), float(np.percentile(f1, 97.5))],
            "accuracy": [float(np.percentile(acc, 2.5)), float(np.percentile(acc, 97.5))],
            "reps": reps, "reps_without_slip_steps": no_slip}


def ingest(source: Path, tmp: Path) -> Path:
    """Ingest the recordings with configs/xela_slip.yaml into ``tmp``/xela.h5."""
    exe = Path(sys.executable).with_name("tactile")
    cmd = [str(exe) if exe.exists() else "tactile", "ingest", str(source), "--mapping",
           str(ROOT / "configs" / "xela_slip.yaml"), "--out", str(tmp / "xela.h5")]
    subprocess.run(cmd, check=True, stdout=subprocess.DEVNULL)
    return tmp / "xela.h5"


def per_trial_counts(predictions: Path, classes: list[str]) -> list[dict[str, Any]]:
    """tp, fp, fn, tn of the slip class per held-out trial, from an evaluation's
    predictions.csv (one row per step: trial, slip_true, slip_pred)."""
    rows: dict[str, dict[str, Any]] = {}
    with open(predictions, newline="", encoding="utf-8") as f:
        for r in csv.DictReader(f):
            t = rows.setdefault(r["trial"].split("/", 1)[-1],
                                {"tp": 0, "fp": 0, "fn": 0, "tn": 0})
            true, pred = r[f"{SLIP}_true"] == SLIP, r[f"{SLIP}_pred"] == SLIP
            t["tp" if true and pred else "fn" if true else "fp" if pred else "tn"] += 1
    out = []
    for trial in sorted(rows):
        c = rows[trial]
        n = sum(c.values())
        out.append({"trial": trial, "n_steps": n, "slip_steps": c["tp"] + c["fn"], **c,
                    "slip_f1": counts_f1(c["tp"], c["fp"], c["fn"]) if c["tp"] + c["fn"]
                    else None, "accuracy": (c["tp"] + c["tn"]) / n})
    return out


def run_family(family: str, data: Path, tmp: Path, *, seed: int, epochs: int | None,
               jobs: int | None) -> dict[str, Any]:
    """``tactile train --cv loto`` and ``tactile evaluate`` of one family, through the
    library; the slip-class figures of the pooled held-out decisions."""
    cfg_path = ROOT / "configs" / f"train_{family}_xela_slip.yaml"
    cfg = load_config(cfg_path).with_overrides(seed=seed, epochs=epochs)
    res = train_cv(cfg, [data], tmp / family, k="loto", jobs=jobs, config_path=cfg_path,
                   command="benchmarks/xela_loto.py",
                   on_fold=lambda i, s: print(f"  {family} fold {i}: {s['train_time_s']:.1f} s",
                                              flush=True))
    ev = evaluate(res.run_dir, None, threads=1, command="benchmarks/xela_loto.py")
    cm = next(h for h in ev.heads if h.head == SLIP)
    classes = list(cm.classes)
    slip = cm.per_class[classes.index(SLIP)]
    per_trial = per_trial_counts(ev.out_dir / runs.PREDICTIONS_CSV, classes)
    tp, fp, fn, tn = (sum(t[k] for t in per_trial) for k in ("tp", "fp", "fn", "tn"))
    times = [f["train_time_s"] for f in res.folds]
    lat = ev.latency
    assert lat is not None
    return {
        "family": family, "config": str(cfg_path.relative_to(ROOT)),
        "config_resolved": json.loads(json.dumps(cfg.model_dump(mode="json"))),
        "n_params": ev.n_params, "size_mb": ev.size_mb,
        "pooled": {"classes": classes, "confusion_matrix": cm.confusion_matrix,
                   "n": cm.n, "tp": tp, "fp": fp, "fn": fn, "tn": tn,
                   "slip_precision": slip.precision, "slip_recall": slip.recall,
                   "slip_f1": slip.f1, "accuracy": cm.accuracy, "macro_f1": cm.macro_f1,
                   "slip_precision_wilson95": wilson(tp, tp + fp),
                   "slip_recall_wilson95": wilson(tp, tp + fn),
                   "accuracy_wilson95": wilson(tp + tn, cm.n)},
        "bootstrap_over_trials95": bootstrap_over_trials(per_trial, reps=2000, seed=seed),
        "warnings": ev.warnings,
        "per_trial": per_trial,
        "train_time_s": {"total": float(sum(times)), "per_fold_mean": float(np.mean(times))},
        "latency": lat.as_dict(),
    }


def chart(results: list[dict[str, Any]], out_png: Path, data_name: str) -> str:
    points = []
    for r in results:
        p = r["pooled"]
        lat = r["latency"]
        points.append(RunPoint(
            run="", label=r["family"], family=r["family"], eval_name=data_name,
            metrics_path="", score=p["slip_f1"], accuracy=p["accuracy"],
            macro_f1=p["macro_f1"], latency_ms=lat["batch1_ms_median"],
            latency_p95_ms=lat["batch1_ms_p95"], windows_per_s=lat["windows_per_s"],
            n_params=r["n_params"], size_mb=r["size_mb"], n_windows=p["n"],
            split="loto", primary_head=SLIP, latency_threads=lat["threads"], cpu=lat["cpu"]))
    cmp = compare_points(points, margin_pp=0.5, metric=f"f1:{SLIP}", data_name=data_name)
    n_folds = len(results[0]["per_trial"])
    png = plot_comparison(cmp, title=f"Xela slip, leave one trial out ({n_folds} folds "
                                     "pooled): slip F1 against batch-1 latency")
    tmp = out_png.with_name(out_png.name + ".tmp")
    tmp.write_bytes(png)
    os.replace(tmp, out_png)
    return cmp.summary()


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", type=Path, default=None,
                    help="ingested xela.h5 (default: ingest --source into a temporary file)")
    ap.add_argument("--source", type=Path, default=ROOT.parent / "shared" / "data" / "xela_slip")
    ap.add_argument("--families", nargs="+", default=list(FAMILIES), choices=FAMILIES)
    ap.add_argument("--jobs", type=int, default=None,
                    help="folds trained at once (default: the cores)")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--epochs", type=int, default=None, help="override optim.epochs")
    ap.add_argument("--out", type=Path, default=ROOT / "benchmarks" / "figures")
    args = ap.parse_args(argv)
    started = time.perf_counter()
    args.out.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory(prefix="xela_loto_") as tmp_s:
        tmp = Path(tmp_s)
        data = args.data if args.data is not None else ingest(args.source, tmp)
        if not data.is_file():
            print(f"error: {data}: data file not found; ingest it first (see --help)",
                  file=sys.stderr)
            return 2
        results = []
        for fam in args.families:
            print(f"{fam}: leave one trial out", flush=True)
            results.append(run_family(fam, data, tmp, seed=args.seed, epochs=args.epochs,
                                      jobs=args.jobs))
        data_sha = sha256_of(data)
        trials = [t["trial"] for t in results[0]["per_trial"]]
    summary = chart(results, args.out / "xela_loto.png", "xela_slip")
    record = {
        "format": "tactile-xela-loto", "format_version": 1, "tool_version": __version__,
        "created_utc": utc_now(), "command": " ".join([Path(sys.argv[0]).name, *sys.argv[1:]])
        if argv is None else "main(" + " ".join(argv) + ")",
        "data": {"path": str(args.data) if args.data else f"ingested from {args.source}",
                 "sha256": data_sha, "trials": trials},
        "seed": args.seed, "epochs_override": args.epochs, "folds": trials,
        "metric": "slip-class F1 of the pooled held-out decisions (one per step)",
        "families": results, "chart_summary": summary,
        "wall_time_s": time.perf_counter() - started,
    }
    out_json = args.out / "xela_loto.json"
    tmp_json = out_json.with_name(out_json.name + ".tmp")
    tmp_json.write_text(runs.dumps(record) + "\n", encoding="utf-8")
    os.replace(tmp_json, out_json)
    print(f"{'family':7} {'slip P':>7} {'slip R':>7} {'slip F1':>8} {'F1 95% (trials)':>17} "
          f"{'acc':>7} {'train s':>8} {'b1 ms':>7}")
    for r in results:
        p, b = r["pooled"], r["bootstrap_over_trials95"]
        print(f"{r['family']:7} {p['slip_precision']:7.3f} {p['slip_recall']:7.3f} "
              f"{p['slip_f1']:8.3f}   [{b['f1'][0]:.3f}, {b['f1'][1]:.3f}] "
              f"{p['accuracy']:7.3f} {r['train_time_s']['total']:8.1f} "
              f"{r['latency']['batch1_ms_median']:7.3f}")
    print(f"wrote {out_json} and {args.out / 'xela_loto.png'} "
          f"({record['wall_time_s']:.0f} s)")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
