"""Normal MLP of paper 002 (sec. II-B): colour differences against absolute colour, RMSE of
normals on held-out ball presses.

Issue 16, item 3. The paper: average RMSE 0.0262 with colour differences from the
no-contact reference, 0.0349 with absolute colour (36 held-out presses). Here, as the CLI
does it, for each condition:

    tactile simulate digit-press S --seed TRAIN_SEED --trials 0 --calibration-presses 30
    tactile ingest S/calibration --trial-labels S/calibration_labels.csv --px-per-mm 16 ...
    tactile normal-labels calib.h5 --out pixels.h5
    tactile train configs/train_mlp_normals.yaml     --data pixels.h5 --seed M --out d
    tactile train configs/train_mlp_normals_abs.yaml --data pixels.h5 --seed M --out a

and both runs are scored (``calibrate.normal_rmse``, ``NormalModel.from_run(...).predict``)
on the presses of scenes simulated with the held-out seeds, against the true sphere
normals of the scene (per image: RMSE over all pixels and the 3 components; averaged over
images), beside the trivial predictor (0, 0, 1) on the same pixels (the baseline, measured
in the same run). Also reported: the same RMSE inside the contact circles only.

Two conditions, because the scene's seed also draws the sensor's lighting
(``optics.lighting_jitter``):

- ``other_unit``: the default scene, so each held-out seed is another DIGIT unit (LED
  colours and places vary by a few per cent): what a model calibrated on one sensor meets
  on another, or after its LEDs aged;
- ``same_unit``: ``lighting_jitter: 0``: the held-out presses come from the same unit
  (only presses, noise and flicker differ), as in the paper's test.

Seeds: the scene is calibrated on ``--train-seed`` (default 100) and scored on
``--test-seeds`` (default 200-202); the networks are trained with ``--model-seeds``
(default 0-2) and the figures are the mean (and spread) over them. Nothing is tuned on the
held-out seeds.

    .venv/bin/python benchmarks/normals.py [--presses 30] [--test-presses 12] [--json]
        [--work DIR]
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

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
CONFIGS = {"difference": ROOT / "configs" / "train_mlp_normals.yaml",
           "absolute": ROOT / "configs" / "train_mlp_normals_abs.yaml"}
PAPER = {"difference": 0.0262, "absolute": 0.0349}


def parse_seeds(text: str) -> list[int]:
    """``"200-202,210"`` -> [200, 201, 202, 210]."""
    out: list[int] = []
    for part in (p.strip() for p in text.split(",")):
        if part:
            lo, _, hi = part.partition("-")
            out.extend(range(int(lo), int(hi or lo) + 1))
    return out


def _tactile(*args: str) -> str:
    res = subprocess.run([sys.executable, "-m", "tactile_cli", *args], capture_output=True,
                         text=True, cwd=ROOT)
    if res.returncode != 0:
        raise RuntimeError(f"tactile {' '.join(args)} failed ({res.returncode}): "
                           f"{res.stderr.strip()[-1500:]}")
    return res.stdout


def calibration_file(work: Path, condition: str, seed: int, presses: int) -> Path:
    """Simulate and ingest ``presses`` ball presses of scene ``seed`` (cached in work)."""
    h5 = work / f"{condition}_calib{seed}.h5"
    if h5.exists():
        return h5
    scene = work / f"{condition}_scene{seed}"
    args = ["simulate", "digit-press", str(scene), "--seed", str(seed), "--trials", "0",
            "--calibration-presses", str(presses), "--no-progress", "--overwrite"]
    if condition == "same_unit":
        cfg = work / "same_unit.yaml"
        cfg.write_text("optics: {lighting_jitter: 0.0}\n")
        args += ["--config", str(cfg)]
    _tactile(*args)
    _tactile("ingest", str(scene / "calibration"), "--trial-labels",
             str(scene / "calibration_labels.csv"), "--px-per-mm", "16", "--out", str(h5),
             "--no-progress")
    return h5


def run(args: argparse.Namespace, work: Path) -> dict:
    from tactile_cli.visuotactile.calibrate import normal_rmse
    from tactile_cli.visuotactile.normals import NormalModel

    load_start = os.getloadavg()
    started = time.perf_counter()
    out: dict = {"paper": PAPER, "train_seed": args.train_seed, "test_seeds": args.test_seeds,
                 "model_seeds": args.model_seeds, "presses": args.presses,
                 "test_presses": args.test_presses, "conditions": {}}
    for condition in args.conditions:
        calib = calibration_file(work, condition, args.train_seed, args.presses)
        pixels = work / f"{condition}_pixels.h5"
        if not pixels.exists():
            labels = json.loads(_tactile("normal-labels", str(calib), "--out", str(pixels),
                                         "--json", "--no-progress"))
        else:
            labels = None
        tests = [calibration_file(work, condition, s, args.test_presses)
                 for s in args.test_seeds]
        res: dict = {"circle": None if labels is None else
                     {k: labels[k] for k in ("centre_error_px", "radius_error_px",
                                             "n_pixels", "n_flat_left_out", "n_failed")}}
        for kind, config in CONFIGS.items():
            scores, contact, train_s = [], [], []
            for m in args.model_seeds:
                run_dir = work / f"{condition}_{kind}_m{m}"
                if not run_dir.exists():
                    t0 = time.perf_counter()
                    _tactile("train", str(config), "--data", str(pixels), "--seed", str(m),
                             "--out", str(run_dir), "--no-progress")
                    train_s.append(time.perf_counter() - t0)
                model = NormalModel.from_run(run_dir)
                per_seed = [normal_rmse(model.predict, t) for t in tests]
                scores.append(float(np.mean([r.rmse for r in per_seed])))
                contact.append(float(np.mean([r.rmse_contact for r in per_seed])))
                base = per_seed
            res[kind] = {"rmse": round(float(np.mean(scores)), 5),
                         "rmse_per_model_seed": [round(v, 5) for v in scores],
                         "rmse_contact": round(float(np.mean(contact)), 5),
                         "rmse_contact_per_model_seed": [round(v, 5) for v in contact],
                         "train_s": [round(v, 1) for v in train_s]}
        res["baseline_rmse"] = round(float(np.mean([r.baseline_rmse for r in base])), 5)
        res["baseline_rmse_contact"] = round(
            float(np.mean([r.baseline_rmse_contact for r in base])), 5)
        res["ratio_absolute_to_difference"] = round(
            res["absolute"]["rmse"] / res["difference"]["rmse"], 3)
        res["ratio_difference_to_baseline"] = round(
            res["difference"]["rmse"] / res["baseline_rmse"], 3)
        res["ratio_absolute_to_baseline"] = round(
            res["absolute"]["rmse"] / res["baseline_rmse"], 3)
        out["conditions"][condition] = res
    out["elapsed_s"] = round(time.perf_counter() - started, 1)
    out["load_avg_start"] = list(load_start)
    out["load_avg_end"] = list(os.getloadavg())
    out["command"] = " ".join(sys.argv)
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--train-seed", type=int, default=100)
    parser.add_argument("--test-seeds", type=parse_seeds, default=parse_seeds("200-202"))
    parser.add_argument("--model-seeds", type=parse_seeds, default=parse_seeds("0-2"))
    parser.add_argument("--presses", type=int, default=30, help="calibration presses (paper: 30)")
    parser.add_argument("--test-presses", type=int, default=12, help="presses per held-out seed")
    parser.add_argument("--conditions", nargs="+", default=["other_unit", "same_unit"],
                        choices=["other_unit", "same_unit"])
    parser.add_argument("--work", type=Path, default=None,
                        help="keep scenes, tables and runs here (reused by a second call)")
    parser.add_argument("--json", action="store_true")
    args = parser.parse_args()
    if args.work is not None:
        args.work.mkdir(parents=True, exist_ok=True)
        result = run(args, args.work)
    else:
        with tempfile.TemporaryDirectory(prefix="normals-bench-") as tmp:
            result = run(args, Path(tmp))
    if args.json:
        print(json.dumps(result, indent=2))
        return
    print(f"normal MLP, RMSE of normals on held-out presses (train seed {args.train_seed}, "
          f"test seeds {args.test_seeds}, model seeds {args.model_seeds}); paper: "
          f"difference {PAPER['difference']}, absolute {PAPER['absolute']}")
    for cond, res in result["conditions"].items():
        print(f"  {cond}: difference {res['difference']['rmse']:.4f}  absolute "
              f"{res['absolute']['rmse']:.4f}  (0,0,1) baseline {res['baseline_rmse']:.4f}  "
              f"ratio abs/diff {res['ratio_absolute_to_difference']:.2f}; inside circles: "
              f"{res['difference']['rmse_contact']:.4f} / {res['absolute']['rmse_contact']:.4f}"
              f" / {res['baseline_rmse_contact']:.4f}")
    print(f"  {result['elapsed_s']:.0f} s, load {result['load_avg_start'][0]:.2f} -> "
          f"{result['load_avg_end'][0]:.2f}")


if __name__ == "__main__":
    main()
