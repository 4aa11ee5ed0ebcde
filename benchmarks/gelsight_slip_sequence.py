"""Slip or hold of real GelSight lifts from their frames (issue 35, item 2).

Data: ../shared/data/gelsight_slip, two objects of the lift set of Li et al. (ICRA 2018,
arXiv 1802.10153; published 88.0 % per lift with a CNN-LSTM on GelSight and camera images,
whole set): 20 lifts (11 slipped, 9 held), 21 JPEG frames of 640 x 480 each. The labels
(``objectNNN_result.dat``: column 2 ``fail``/``slip`` = slipped, ``ok``/``success`` = held,
column 7 the lift folder's key, column 4 a position in the object's session taken as the
recording order) are written into a trial-labels CSV and the folders ingested exactly as::

    tactile ingest ../shared/data/gelsight_slip/object001 ../shared/data/gelsight_slip/object002 \\
        --reference first --trial-labels labels.csv --out gelsight_slip.h5

Each model variant (configs/train_cnn2d_frames_gelsight_slip.yaml with the changes listed
in VARIANTS) is cross-validated as ``tactile train CONFIG --data gelsight_slip.h5 --cv K``
and ``tactile evaluate RUN`` do (:func:`tactile_cli.learn.cv.train_cv`,
:func:`tactile_cli.learn.cv.evaluate_cv`), twice:

- **grouped by object** (``split: {mode: group, by: object}``, K = 2): train on one
  object's lifts, decide on the other's; objects the model never saw, as the issue asks,
  but only two folds of 9 and 11 lifts (the other objects of the set are not here);
- **blocked by lift** (``split: {mode: blocked, by: lift_order, within: object}``, K = 5):
  each fold holds out a contiguous stretch of each object's session, the objects seen in
  training.

Beside it, the analytic intensity slip signal (``tactile slip-signal FILE --source
intensity --n-static 3``: colour change from the reference, adaptive threshold of its
first frames, no training) on the same lifts, scored per fold of each scheme. Intervals:
95 % Wilson on the per-lift decisions pooled over folds (lifts, not frames, are the unit).
No setting was chosen on a separate set: every variant tried is listed with its figures,
so the best of them is an optimistic pick on 20 lifts.

Writes benchmarks/figures/gelsight_slip_sequence.json; ``--json`` prints it::

    .venv/bin/python benchmarks/gelsight_slip_sequence.py                 # all (~20 min)
    .venv/bin/python benchmarks/gelsight_slip_sequence.py --variants lstm_32x24 \\
        --schemes object --epochs 2 --out /tmp/gs                          # a quick check
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

import yaml

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from tactile_cli._version import __version__  # noqa: E402
from tactile_cli.learn import runs  # noqa: E402
from tactile_cli.learn.config import parse_config  # noqa: E402
from tactile_cli.learn.cv import evaluate_cv, train_cv  # noqa: E402
from tactile_cli.store.provenance import sha256_of, utc_now  # noqa: E402

CONFIG = ROOT / "configs" / "train_cnn2d_frames_gelsight_slip.yaml"
SOURCE = ROOT.parent / "shared" / "data" / "gelsight_slip"
PUBLISHED = 0.880
Z95 = 1.959963984540054
_FLOW = {"width": 8, "height": 6, "change": "flow"}
#: name -> changes to the shipped config (section -> keys), smallest first by design; a
#: model section with a ``family`` replaces the config's model section.
VARIANTS: dict[str, dict[str, dict[str, Any]]] = {
    "lstm_16x12": {"data": {"frames": {"width": 16, "height": 12}},
                   "model": {"channels": [8], "embed": 16, "hidden": 16}},
    "lstm_32x24": {},
    "lstm_32x24_levels": {"data": {"window_norm": "none"}},
    "tconv_32x24": {"model": {"temporal": "conv", "temporal_layers": 2,
                              "temporal_kernel": 5}},
    # the gel's motion (data.frames.change: flow): 8 x 6 blocks (80 x 80 px of a 640 x 480
    # frame), dy and dx since the frame before, in px. Both variants are the GelSight Mini
    # study's flow variants (benchmarks/gelsight_mini_slip.py) carried over unchanged, fixed
    # before they were run on these lifts; nothing in them was chosen on these 20 lifts.
    "lstm_flow_8x6": {"data": {"window_norm": "none", "frames": _FLOW}},
    "hgb_flow_8x6": {"data": {"window_norm": "none", "frames": _FLOW},
                     "model": {"family": "hist_gb", "max_iter": 200, "learning_rate": 0.05,
                               "max_leaf_nodes": 8}},
    # the same with leaves of 2 lifts: boosting's default leaf of 20 windows cannot split 9
    # or 11 training lifts at all (the variant above is a constant; `tactile train` now
    # says so). Added after that run, so it is a choice made on these lifts.
    "hgb_flow_8x6_leaf2": {"data": {"window_norm": "none", "frames": _FLOW},
                           "model": {"family": "hist_gb", "max_iter": 200,
                                     "learning_rate": 0.05, "max_leaf_nodes": 8,
                                     "min_samples_leaf": 2}},
}
SCHEMES: dict[str, tuple[dict[str, Any], int]] = {
    "object": ({"mode": "group", "by": "object", "val_fraction": 0.0}, 2),
    "lift_blocked": ({"mode": "blocked", "by": "lift_order", "within": "object",
                      "val_fraction": 0.0}, 5),
}


def wilson(k: int, n: int, z: float = Z95) -> list[float]:
    """95 % Wilson score interval [lo, hi] of k/n; [nan, nan] for n = 0."""
    if n <= 0:
        return [math.nan, math.nan]
    p = k / n
    den = 1 + z * z / n
    centre = (p + z * z / (2 * n)) / den
    half = z * math.sqrt(p * (1 - p) / n + z * z / (4 * n * n)) / den
    return [max(0.0, centre - half), min(1.0, centre + half)]


def write_labels(source: Path, out: Path) -> list[dict[str, Any]]:
    """The trial-labels CSV of the lifts (trial = lift folder, named as ``tactile ingest``
    names it: ``066_60_mm``, or ``object001__066_60_mm`` when objects share a folder name);
    returns its rows. A line of a result file whose folder is not there is left out and
    named on stderr."""
    from tactile_cli.ingest.image_sequence import folder_trial_names, image_sequence_folders

    folders = [f for obj in sorted(source.glob("object*")) if obj.is_dir()
               for f in image_sequence_folders(obj)]
    name_of = {f.resolve(): n for f, n in zip(folders, folder_trial_names(folders),
                                              strict=True)}
    rows = []
    for dat in sorted(source.glob("object*_result.dat")):
        obj = dat.name.split("_")[0]
        for line in dat.read_text().splitlines():
            cells = line.split()
            if len(cells) < 7:
                continue
            folder = (source / obj / f"{cells[6]}_mm").resolve()
            if folder not in name_of:
                print(f"note: {dat.name}: lift {cells[6]} has no folder {obj}/{cells[6]}_mm; "
                      "left out", file=sys.stderr)
                continue
            rows.append({"trial": name_of[folder], "slipped": int(cells[1] in ("fail", "slip")),
                         "outcome": cells[1], "object": obj, "position_mm": float(cells[0]),
                         "lift_order": int(cells[3])})
    with open(out, "w", newline="", encoding="utf-8") as f:
        writer = csv.DictWriter(f, fieldnames=list(rows[0]))
        writer.writeheader()
        writer.writerows(rows)
    return rows


def ingest(source: Path, labels: Path, out: Path) -> list[str]:
    """Ingest both objects' lift folders; returns the command line."""
    exe = Path(sys.executable).with_name("tactile")
    cmd = [str(exe) if exe.exists() else "tactile", "ingest",
           *[str(p) for p in sorted(source.glob("object*")) if p.is_dir()],
           "--reference", "first", "--trial-labels", str(labels), "--label", "origin=recorded",
           "--label", "dataset=gelsight_slip", "--out", str(out), "--no-progress"]
    subprocess.run(cmd, check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    return cmd


def apply_changes(raw: dict[str, Any], changes: dict[str, dict[str, Any]]) -> dict[str, Any]:
    """``raw`` (a parsed config) with a variant's changes (section -> key -> value; a dict
    value is merged into a dict it replaces) applied in place; returns ``raw``."""
    for section, keys in changes.items():
        for key, value in keys.items():
            if isinstance(value, dict) and isinstance(raw[section].get(key), dict):
                raw[section][key] = {**raw[section][key], **value}
            else:
                raw[section][key] = value
    return raw


def variant_config(name: str, scheme: str, epochs: int | None, seed: int | None = None
                   ) -> Any:
    changes = dict(VARIANTS[name])
    raw = yaml.safe_load(CONFIG.read_text())
    if "family" in changes.get("model", {}):  # another family: its own model section
        raw["model"] = dict(changes.pop("model"))
    raw = apply_changes(raw, changes)
    raw["data"]["split"] = SCHEMES[scheme][0]
    if seed is not None:
        raw["seed"] = seed
    if epochs is not None:
        raw["optim"]["epochs"] = epochs
    return parse_config(raw)


def cache_frame_series() -> None:
    """Read each lift's frames once per frame size in this process: the variants and folds
    read the same 420 frames of 640 x 480 again and again (the values are the same; only
    the reading is skipped)."""
    from tactile_cli.learn import frames as frames_module

    original = frames_module.frame_series
    cache: dict[tuple[str, str, str], Any] = {}

    def cached(frames: Any, cfg: Any) -> Any:
        key = (str(frames.path), frames.where, cfg.model_dump_json())
        if key not in cache:
            cache[key] = original(frames, cfg)
        return cache[key].copy()

    frames_module.frame_series = cached  # type: ignore[assignment]


#: ``--n-static`` of the intensity slip signal: a lift has 21 frames (20 signals), fewer
#: than the default 30 static signals; 3 as in the issue's own measurement.
N_STATIC = 3


def intensity_decisions(data: Path) -> dict[str, bool]:
    """trial -> slip detected by ``tactile slip-signal FILE --source intensity --n-static
    3`` (its default threshold scale)."""
    from tactile_cli.visuotactile.slip import slip_signal_file

    result = slip_signal_file(data, source="intensity", n_static=N_STATIC)
    return {t.trial: bool(t.detection.detected) for t in result.trials}


def run_one(name: str, scheme: str, data: Path, tmp: Path, *, epochs: int | None,
            truth: dict[str, int], intensity: dict[str, bool], seed: int | None = None
            ) -> dict[str, Any]:
    cfg = variant_config(name, scheme, epochs, seed)
    k = SCHEMES[scheme][1]
    out = tmp / f"{name}_{scheme}"
    started = time.perf_counter()
    trained = train_cv(cfg, [data], out, k=k, jobs=1, command="gelsight_slip_sequence")
    train_s = time.perf_counter() - started
    ev = evaluate_cv(out, None, latency=True, command="gelsight_slip_sequence")
    info = json.loads((out / runs.RUN_JSON).read_text())
    preds = {}
    with open(ev.out_dir / "predictions.csv", newline="", encoding="utf-8") as f:
        for row in csv.DictReader(f):
            preds[row["trial"].split("/")[-1]] = row
    folds = []
    n_model = n_int = n_all = 0
    for fold, scores in zip(info["cv"]["folds"], ev.cv["folds"], strict=True):
        test = [key.split("/")[-1] for key in fold["test"]]
        model_ok = round(scores["accuracy"] * len(test))
        int_ok = sum(intensity[t] == bool(truth[t]) for t in test)
        folds.append({"fold": fold["fold"], "held_out": test, "model_accuracy":
                      scores["accuracy"], "intensity_accuracy": int_ok / len(test)})
        n_model += model_ok
        n_int += int_ok
        n_all += len(test)
    head = ev.heads[0]
    lat = ev.latency.as_dict() if ev.latency is not None else {}
    return {
        "variant": name, "scheme": scheme, "k": k, "changes": VARIANTS[name],
        "n_params": ev.n_params, "n_lifts": n_all,
        "model": {"accuracy": head.accuracy, "wilson95": wilson(n_model, n_all),
                  "bootstrap95_over_lifts": head.accuracy_ci95},
        "intensity": {"accuracy": n_int / n_all, "wilson95": wilson(n_int, n_all)},
        "folds": folds, "train_time_s": train_s, "train_time_s_folds": trained.wall_time_s,
        "latency_batch1_ms_median": lat.get("batch1_ms_median"),
    }


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--source", type=Path, default=SOURCE)
    ap.add_argument("--data", type=Path, default=None,
                    help="an ingested gelsight_slip.h5 (default: ingest --source first)")
    ap.add_argument("--variants", nargs="+", default=list(VARIANTS), choices=list(VARIANTS))
    ap.add_argument("--schemes", nargs="+", default=list(SCHEMES), choices=list(SCHEMES))
    ap.add_argument("--epochs", type=int, default=None, help="override optim.epochs")
    ap.add_argument("--seed", type=int, default=None, help="override the config's seed")
    ap.add_argument("--out", type=Path, default=ROOT / "benchmarks" / "figures")
    ap.add_argument("--json", action="store_true", help="print the result as JSON")
    args = ap.parse_args(argv)
    if not args.source.is_dir():
        print(f"error: {args.source}: folder not found (the lifts of ../shared/data/"
              "gelsight_slip)", file=sys.stderr)
        return 2
    started = time.perf_counter()
    args.out.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory(prefix="gelsight_slip_") as tmp_s:
        tmp = Path(tmp_s)
        rows = write_labels(args.source, tmp / "labels.csv")
        truth = {r["trial"]: r["slipped"] for r in rows}
        if args.data is not None:
            data, ingest_cmd = args.data, None
        else:
            data = tmp / "gelsight_slip.h5"
            ingest_cmd = ingest(args.source, tmp / "labels.csv", data)
        intensity = intensity_decisions(data)
        cache_frame_series()
        results = []
        for name in args.variants:
            for scheme in args.schemes:
                print(f"{name}: {scheme} ({SCHEMES[scheme][1]} folds)", file=sys.stderr,
                      flush=True)
                results.append(run_one(name, scheme, data, tmp, epochs=args.epochs,
                                       truth=truth, intensity=intensity, seed=args.seed))
        data_sha = sha256_of(data)
    by_object = [r for r in results if r["scheme"] == "object"]
    reached = sorted((r for r in by_object if r["model"]["accuracy"] >= PUBLISHED),
                     key=lambda r: r["n_params"])
    best = max(by_object, key=lambda r: r["model"]["accuracy"], default=None)
    record = {
        "format": "tactile-gelsight-slip-sequence", "format_version": 1,
        "tool_version": __version__, "created_utc": utc_now(),
        "command": " ".join([Path(sys.argv[0]).name, *sys.argv[1:]]) if argv is None
        else "main(" + " ".join(argv) + ")",
        "data": {"source": str(args.source), "ingest": ingest_cmd,
                 "path": str(args.data) if args.data else None, "sha256": data_sha,
                 "lifts": len(rows), "slipped": sum(r["slipped"] for r in rows),
                 "objects": sorted({r["object"] for r in rows})},
        "config": str(CONFIG.relative_to(ROOT)), "epochs_override": args.epochs,
        "seed_override": args.seed,
        "target": {"per_lift_accuracy": PUBLISHED, "published": "Li et al., ICRA 2018, "
                   "88.03 % (CNN-LSTM on GelSight and camera images, whole set)"},
        "smallest_reaching_target_by_object": reached[0]["variant"] if reached else None,
        "best_by_object": None if best is None else best["variant"],
        "intensity_signal": {"command": "tactile slip-signal FILE --source intensity "
                             f"--n-static {N_STATIC}",
                             "detected": intensity},
        "results": results, "wall_time_s": time.perf_counter() - started,
    }
    out_json = args.out / "gelsight_slip_sequence.json"
    tmp_json = out_json.with_name(out_json.name + ".tmp")
    tmp_json.write_text(runs.dumps(record) + "\n", encoding="utf-8")
    os.replace(tmp_json, out_json)
    if args.json:
        print(runs.dumps(record))
        return 0
    print("| variant | params | CV | lifts | model per lift (95 % Wilson) | intensity signal "
          "(95 % Wilson) | per fold model / intensity | train s |")
    print("|---|---:|---|---:|---|---|---|---:|")
    for r in results:
        m, i = r["model"], r["intensity"]
        per_fold = ", ".join(f"{f['model_accuracy']:.2f}/{f['intensity_accuracy']:.2f}"
                             for f in r["folds"])
        print(f"| {r['variant']} | {r['n_params']:,} | {r['scheme']} ({r['k']} folds) | "
              f"{r['n_lifts']} | {m['accuracy']:.1%} [{m['wilson95'][0]:.1%}, "
              f"{m['wilson95'][1]:.1%}] | {i['accuracy']:.1%} [{i['wilson95'][0]:.1%}, "
              f"{i['wilson95'][1]:.1%}] | {per_fold} | {r['train_time_s']:.0f} |")
    print(f"wrote {out_json} ({record['wall_time_s']:.0f} s)")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
