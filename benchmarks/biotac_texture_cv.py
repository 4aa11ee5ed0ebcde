"""Texture of 20 materials on the real BioTac recordings, 5-fold stratified cross-validation.

The 200 trials of ../shared/data/biotac_slide20 (Gao et al., IROS 2020; 20 materials x 10
slides) are ingested with configs/biotac_slide20.yaml and each model config is
cross-validated exactly as the CLI does it::

    tactile train configs/train_<model>_biotac_texture.yaml --data bt.h5 --cv 5 --out RUN
    tactile evaluate RUN

Folds are stratified by material (2 held-out trials of every material per fold; one
validation trial per material from the fold's training trials), so no trial is on both
sides. Reported per model: per-window accuracy and macro F1 with 95 % bootstrap intervals
over trials, per-trial accuracy by majority vote and by mean probability with intervals,
the mean and sample standard deviation over folds, and the cost (parameters, batch-1
latency, training time). The trials are all the data there is: these are cross-validated
estimates, not figures on recordings held out from every choice (the configs were written
once, before these numbers were seen, and not tuned on them).

    .venv/bin/python benchmarks/biotac_texture_cv.py [--models cnn2d mlp] [--folds 5] [--json]

Writes benchmarks/figures/biotac_texture_cv.json.
"""

from __future__ import annotations

import argparse
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
from tactile_cli.learn import load_config, runs  # noqa: E402
from tactile_cli.learn.cv import train_cv  # noqa: E402
from tactile_cli.learn.evaluate import evaluate  # noqa: E402
from tactile_cli.store.provenance import sha256_of, utc_now  # noqa: E402

MODELS = ("cnn2d", "mlp")


def ingest(source: Path, out: Path) -> Path:
    exe = Path(sys.executable).with_name("tactile")
    subprocess.run([str(exe) if exe.exists() else "tactile", "ingest", str(source),
                    "--mapping", str(ROOT / "configs" / "biotac_slide20.yaml"), "--out",
                    str(out)], check=True, stdout=subprocess.DEVNULL)
    return out


def run_model(model: str, data: Path, tmp: Path, folds: int, jobs: int | None
              ) -> dict[str, Any]:
    cfg_path = ROOT / "configs" / f"train_{model}_biotac_texture.yaml"
    cfg = load_config(cfg_path)
    started = time.perf_counter()
    res = train_cv(cfg, [data], tmp / model, k=folds, jobs=jobs, config_path=cfg_path,
                   command="benchmarks/biotac_texture_cv.py")
    wall = time.perf_counter() - started
    ev = evaluate(res.run_dir, None, threads=1, command="benchmarks/biotac_texture_cv.py")
    m = next(h for h in ev.heads if h.head == "material")
    assert ev.cv is not None and ev.latency is not None and m.per_trial is not None
    return {
        "model": model, "family": ev.family, "config": str(cfg_path.relative_to(ROOT)),
        "n_params": ev.n_params, "size_mb": ev.size_mb, "n_trials": ev.n_trials,
        "n_windows": ev.n_windows,
        "window_accuracy": m.accuracy, "window_accuracy_ci95": m.accuracy_ci95,
        "window_macro_f1": m.macro_f1, "window_macro_f1_ci95": m.macro_f1_ci95,
        "trial_accuracy_majority": m.per_trial["majority_accuracy"],
        "trial_accuracy_majority_ci95": m.per_trial["majority_accuracy_ci95"],
        "trial_accuracy_mean_probability": m.per_trial["mean_probability_accuracy"],
        "trial_accuracy_mean_probability_ci95": m.per_trial["mean_probability_accuracy_ci95"],
        "folds": ev.cv["folds"], "window_accuracy_fold_mean": ev.cv["accuracy_mean"],
        "window_accuracy_fold_std": ev.cv["accuracy_std"],
        "trial_accuracy_fold_mean": ev.cv["per_trial_accuracy_mean"],
        "trial_accuracy_fold_std": ev.cv["per_trial_accuracy_std"],
        "batch1_ms_median": ev.latency.batch1_ms_median,
        "train_wall_s": wall, "jobs": res.jobs, "warnings": ev.warnings,
    }


def _pct(ci: list[float] | None) -> str:
    return "n/a" if ci is None else f"{100 * ci[0]:.1f}-{100 * ci[1]:.1f}"


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", type=Path, default=None, help="ingested biotac_slide20.h5")
    ap.add_argument("--source", type=Path,
                    default=ROOT.parent / "shared" / "data" / "biotac_slide20")
    ap.add_argument("--models", nargs="+", default=list(MODELS), choices=MODELS)
    ap.add_argument("--folds", type=int, default=5)
    ap.add_argument("--jobs", type=int, default=None)
    ap.add_argument("--json", action="store_true", help="print the record as JSON")
    ap.add_argument("--out", type=Path, default=ROOT / "benchmarks" / "figures")
    args = ap.parse_args(argv)
    with tempfile.TemporaryDirectory(prefix="biotac_cv_") as tmp_s:
        tmp = Path(tmp_s)
        data = args.data or ingest(args.source, tmp / "biotac_slide20.h5")
        results = [run_model(m, data, tmp, args.folds, args.jobs) for m in args.models]
        record = {"format": "tactile-biotac-texture-cv", "format_version": 1,
                  "tool_version": __version__, "created_utc": utc_now(),
                  "command": " ".join([Path(sys.argv[0]).name, *(argv or sys.argv[1:])]),
                  "data": {"sha256": sha256_of(data), "source": str(args.source)},
                  "folds": args.folds, "models": results}
    args.out.mkdir(parents=True, exist_ok=True)
    out = args.out / "biotac_texture_cv.json"
    tmp_json = out.with_name(out.name + ".tmp")
    tmp_json.write_text(runs.dumps(record) + "\n", encoding="utf-8")
    os.replace(tmp_json, out)
    if args.json:
        print(runs.dumps(record))
        return 0
    print(f"{'model':6} {'params':>7} {'window acc':>10} {'95% CI':>11} {'trial acc':>9} "
          f"{'95% CI':>11} {'folds (trial)':>15} {'b1 ms':>6} {'train s':>7}")
    for r in results:
        print(f"{r['model']:6} {r['n_params']:7,} {100 * r['window_accuracy']:9.1f}% "
              f"{_pct(r['window_accuracy_ci95']):>11} {100 * r['trial_accuracy_majority']:8.1f}% "
              f"{_pct(r['trial_accuracy_majority_ci95']):>11} "
              f"{100 * r['trial_accuracy_fold_mean']:6.1f} +- "
              f"{100 * r['trial_accuracy_fold_std']:4.1f} {r['batch1_ms_median']:6.3f} "
              f"{r['train_wall_s']:7.1f}")
    print(f"wrote {out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
