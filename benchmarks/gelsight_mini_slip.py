"""Slip or wiggle of real GelSight Mini grasps from their videos (issue 35, item 2).

Data: ../shared/data/gelsight_mini_slip, the incipient-slip set of Parag, Misimi and Adelson
(two GelSight Mini sensors on a Franka gripper grasp, lift and shake everyday objects;
published 99 % "zero-shot" on unseen objects with a video vision transformer): 29 objects,
150 experiments (65 slipped: the folder holds ``slip.txt``; 85 wiggles), two cameras per
experiment, XVID 320 x 240 at 25 fps, 49-450 frames. Every video is one trial, ingested
exactly as a user would::

    tactile ingest ../shared/data/gelsight_mini_slip/*/exp_num_* --trial-labels labels.csv \\
        --out gelsight_mini_slip.h5

(trials ``<object>__exp_num_<k>__camera_<c>``; labels.csv, written here: object,
experiment, camera, slipped 0/1, and slip/slip_onset_s for ``tactile slip-signal``).

Each model variant (configs/train_cnn2d_frames_gelsight_mini_slip.yaml with the changes in
VARIANTS) is cross-validated as ``tactile train CONFIG --data FILE --cv 5`` and ``tactile
evaluate RUN`` do, **grouped by object** (5 folds, every experiment of an object, both
cameras, on one side): each experiment is decided by the mean probability over every
window of both its cameras (``data.decide_by: experiment``). Beside it, on the same
experiments, the analytic intensity slip signal (``tactile slip-signal FILE --source
intensity``: colour change from the first frame, threshold ``scale`` x the mean of the
first ``n_static`` signals; an experiment is called slipped when either camera crosses):
at the default scale (2) and with the scale learned on the other objects (leave one object
out, as ``--scale auto`` does). There is no height source: no normal network was ever
calibrated on these units (no ball presses of them exist).

Beside both, the video's length alone (no touch at all): slip videos of this set mostly end
early (the recording stops), wiggles run their 18 s, so a threshold on the duration,
chosen on the other objects, decides most experiments; a model that sees where a video ends
can lean on the same cue. ``lstm_32x24_motion_2s`` is blind to it: windows of 2 s (the
shortest video) laid from the start, none padded, each experiment decided by the mean
probability over all its windows.

Intervals: 95 % Wilson on the pooled per-experiment decisions, and the bootstrap over
experiments that ``tactile evaluate`` reports. Every variant tried is listed; none was
chosen on data held apart, so the best of them is an optimistic pick.

Writes benchmarks/figures/gelsight_mini_slip.json (gelsight_mini_slip_intensity.json with
no variant); ``--json`` prints it::

    .venv/bin/python benchmarks/gelsight_mini_slip.py --data gelsight_mini_slip.h5
    .venv/bin/python benchmarks/gelsight_mini_slip.py --data gelsight_mini_slip.h5 \
        --no-intensity                      # the models only; --variants alone: the signal
    .venv/bin/python benchmarks/gelsight_mini_slip.py --variants lstm_32x24 --epochs 2 \\
        --out /tmp/mini                                                    # a quick check
"""

from __future__ import annotations

import argparse
import csv
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

import numpy as np
import yaml

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "benchmarks"))

from gelsight_slip_sequence import apply_changes, cache_frame_series, wilson  # noqa: E402

from tactile_cli._version import __version__  # noqa: E402
from tactile_cli.learn import runs  # noqa: E402
from tactile_cli.learn.config import parse_config  # noqa: E402
from tactile_cli.learn.cv import evaluate_cv, train_cv  # noqa: E402
from tactile_cli.store.provenance import sha256_of, utc_now  # noqa: E402

CONFIG = ROOT / "configs" / "train_cnn2d_frames_gelsight_mini_slip.yaml"
SOURCE = ROOT.parent / "shared" / "data" / "gelsight_mini_slip"
TARGET = 0.95
K = 5
#: name -> changes to the shipped config (section -> keys), smallest first. The shipped
#: config is ``lstm_32x24_motion`` (frame-to-frame change); the others difference every
#: frame against the video's first frame (``change: reference``), as the first five did.
_REF = {"change": "reference"}
#: Windows of 2 s (10 samples at 5 fps; the shortest video has 10), every 1 s from the start,
#: none padded: blind to where a video ends.
_BLIND = {"window": 10, "stride": 5, "align": "start", "pad": "none"}
_FLOW = {"width": 8, "height": 6, "change": "flow"}
VARIANTS: dict[str, dict[str, dict[str, Any]]] = {
    "lstm_16x12": {"data": {"frames": {"width": 16, "height": 12, **_REF}},
                   "model": {"channels": [8], "embed": 16, "hidden": 16}},
    "lstm_32x24": {"data": {"frames": _REF}},
    "lstm_32x24_levels": {"data": {"window_norm": "none", "frames": _REF}},
    "lstm_32x24_colour": {"data": {"frames": {"colour": True, **_REF}}},
    "lstm_32x24_motion": {},
    "tconv_32x24": {"data": {"frames": _REF},
                    "model": {"temporal": "conv", "temporal_layers": 2, "temporal_kernel": 5}},
    # blind to the video's length; an experiment is decided by the mean probability over
    # all the windows of its two videos
    "lstm_32x24_motion_2s": {"data": _BLIND},
    # only each video's first 2 s (one window, the same phase of every experiment: grasp and
    # lift): blind to the length and to which phases a video's windows show
    "lstm_32x24_motion_first2s": {"data": {**_BLIND, "stride": 1000}},
    "lstm_flow_8x6_first2s": {"data": {**_BLIND, "stride": 1000, "window_norm": "none",
                                       "frames": {"width": 8, "height": 6, "change": "flow"}}},
    # the gel's motion (data.frames.change: flow): 8 x 6 blocks of 40 x 40 px, dy and dx
    # since the kept frame before, in px; the same length-blind windows
    "lstm_flow_8x6_2s": {"data": {**_BLIND, "window_norm": "none", "frames": _FLOW}},
    "hgb_flow_8x6_2s": {"data": {**_BLIND, "window_norm": "none", "frames": _FLOW},
                        "model": {"family": "hist_gb", "max_iter": 200, "learning_rate": 0.05,
                                  "max_leaf_nodes": 8}},
}
#: ``--n-static`` of the intensity signal: the first 0.4 s (10 frames at 25 fps) set the
#: threshold; the shortest video has 49 frames.
N_STATIC = 10


def write_labels(source: Path, out: Path) -> list[dict[str, Any]]:
    """The trial-labels CSV of every video (trial = ``<object>__<exp>__<camera>``)."""
    rows = []
    for obj in sorted(p for p in source.iterdir() if p.is_dir()):
        for exp in sorted((p for p in obj.iterdir() if p.is_dir()),
                          key=lambda p: int(p.name.rsplit("_", 1)[-1])):
            slipped = (exp / "slip.txt").exists()
            for cam in sorted(exp.glob("camera_*.avi")):
                rows.append({"trial": f"{obj.name}__{exp.name}__{cam.stem}", "object": obj.name,
                             "experiment": f"{obj.name}__{exp.name}", "camera": cam.stem,
                             "slipped": int(slipped), "slip": "slip" if slipped else "no_slip",
                             "slip_onset_s": 0.0 if slipped else ""})
    with open(out, "w", newline="", encoding="utf-8") as f:
        writer = csv.DictWriter(f, fieldnames=list(rows[0]))
        writer.writeheader()
        writer.writerows(rows)
    return rows


def ingest(source: Path, labels: Path, out: Path) -> list[str]:
    """Ingest every experiment folder's two videos; returns the command line."""
    exe = Path(sys.executable).with_name("tactile")
    folders = sorted(str(p) for p in source.glob("*/exp_num_*") if p.is_dir())
    cmd = [str(exe) if exe.exists() else "tactile", "ingest", *folders, "--trial-labels",
           str(labels), "--label", "origin=recorded", "--label", "dataset=gelsight_mini_slip",
           "--out", str(out), "--no-progress"]
    subprocess.run(cmd, check=True, stdout=subprocess.DEVNULL)
    return cmd


def variant_config(name: str, epochs: int | None) -> Any:
    changes = dict(VARIANTS[name])
    raw = yaml.safe_load(CONFIG.read_text())
    if "family" in changes.get("model", {}):  # another family: its own model section
        raw["model"] = dict(changes.pop("model"))
    raw = apply_changes(raw, changes)
    if epochs is not None:
        raw["optim"]["epochs"] = epochs
    return parse_config(raw)


def _experiment_rate(decisions: dict[str, bool], truth: dict[str, bool]) -> dict[str, Any]:
    n = len(truth)
    ok = sum(decisions[e] == truth[e] for e in truth)
    slips = [e for e in truth if truth[e]]
    holds = [e for e in truth if not truth[e]]
    return {"accuracy": ok / n, "wilson95": wilson(ok, n), "n_experiments": n,
            "detected": sum(decisions[e] for e in slips) / max(len(slips), 1),
            "false_alarms": sum(decisions[e] for e in holds) / max(len(holds), 1)}


def intensity_study(data: Path, rows: list[dict[str, Any]]) -> dict[str, Any]:
    """The intensity slip signal per experiment (either camera crosses), at the default
    scale and with the scale chosen on the other objects (leave one object out)."""
    from tactile_cli.visuotactile.slip import (
        DEFAULT_SCALE,
        best_scale,
        detect_slip,
        slip_signal_file,
    )

    result = slip_signal_file(data, source="intensity", n_static=N_STATIC)
    exp_of = {r["trial"]: r["experiment"] for r in rows}
    obj_of = {r["experiment"]: r["object"] for r in rows}
    truth = {r["experiment"]: bool(r["slipped"]) for r in rows}
    signals = {t.trial: (t.detection.signal, t.detection.t_s) for t in result.trials}

    def decide(scale_of: dict[str, float]) -> dict[str, bool]:
        out = dict.fromkeys(truth, False)
        for trial, (s, t) in signals.items():
            e = exp_of[trial]
            out[e] |= detect_slip(s, t, n_static=N_STATIC, scale=scale_of[obj_of[e]]).detected
        return out

    objects = sorted(set(obj_of.values()))
    default = decide(dict.fromkeys(objects, DEFAULT_SCALE))
    chosen: dict[str, float] = {}
    for obj in objects:
        inner = [tr for tr in signals if obj_of[exp_of[tr]] != obj]
        choice = best_scale([signals[tr] for tr in inner],
                            [(truth[exp_of[tr]], 0.0 if truth[exp_of[tr]] else None)
                             for tr in inner], n_static=N_STATIC, middle=True)
        chosen[obj] = choice.scale
    learned = decide(chosen)
    static = sum(bool(t.detection.static is not None and t.detection.static.static)
                 for t in result.trials)
    return {"command": f"tactile slip-signal FILE --source intensity --n-static {N_STATIC}",
            "default_scale": {"scale": DEFAULT_SCALE, **_experiment_rate(default, truth)},
            "scale_by_object_cv": {"scales": chosen, **_experiment_rate(learned, truth)},
            "videos_with_static_start": static, "n_videos": len(result.trials)}


def length_study(data: Path, rows: list[dict[str, Any]]) -> dict[str, Any]:
    """How far the video's length alone decides: an experiment is called slipped when the
    mean duration of its two videos is below a threshold chosen on the other objects (leave
    one object out; the middle of the best range of thresholds). A model whose windows
    show where a video ends (zero padding before a short video's first frame, a window laid
    back from its last one) can read the same cue."""
    import h5py

    exp_of = {r["trial"]: r["experiment"] for r in rows}
    obj_of = {r["experiment"]: r["object"] for r in rows}
    truth = {r["experiment"]: bool(r["slipped"]) for r in rows}
    durations: dict[str, list[float]] = {}
    with h5py.File(data, "r") as h5:
        for trial, group in h5["trials"].items():
            t_s = group["frames/t_s"]
            durations.setdefault(exp_of[trial], []).append(float(t_s[-1] - t_s[0]))
    mean_s = {e: float(np.mean(d)) for e, d in durations.items()}
    cuts = sorted(set(mean_s.values()))
    candidates = [0.0] + [(a + b) / 2 for a, b in zip(cuts, cuts[1:], strict=False)] + [1e9]
    chosen: dict[str, float] = {}
    for obj in sorted(set(obj_of.values())):
        inner = [e for e in truth if obj_of[e] != obj]
        scores = [sum((mean_s[e] < c) == truth[e] for e in inner) for c in candidates]
        best = [c for c, n in zip(candidates, scores, strict=True) if n == max(scores)]
        chosen[obj] = best[len(best) // 2]
    decisions = {e: mean_s[e] < chosen[obj_of[e]] for e in truth}
    slips = sorted(mean_s[e] for e in truth if truth[e])
    holds = sorted(mean_s[e] for e in truth if not truth[e])
    return {"rule": "slipped when the experiment's mean video duration < threshold chosen "
                    "on the other objects", "thresholds_s": chosen,
            "duration_s_median": {"slipped": float(np.median(slips)),
                                  "wiggle": float(np.median(holds))},
            "full_length_share": {"slipped": float(np.mean(np.array(slips) > 17.0)),
                                  "wiggle": float(np.mean(np.array(holds) > 17.0))},
            **_experiment_rate(decisions, truth)}


def run_one(name: str, data: Path, tmp: Path, *, epochs: int | None) -> dict[str, Any]:
    cfg = variant_config(name, epochs)
    out = tmp / name
    started = time.perf_counter()
    trained = train_cv(cfg, [data], out, k=K, jobs=1, command="gelsight_mini_slip")
    train_s = time.perf_counter() - started
    ev = evaluate_cv(out, None, latency=True, command="gelsight_mini_slip")
    head = ev.heads[0]
    group, per_video = head.per_group or {}, head.per_trial or {}
    n = int(group.get("n_trials", 0))
    ok = round(group.get("mean_probability_accuracy", float("nan")) * n) if n else 0
    lat = ev.latency.as_dict() if ev.latency is not None else {}
    return {
        "variant": name, "changes": VARIANTS[name], "k": K, "n_params": ev.n_params,
        "per_experiment": {"accuracy": ok / n if n else None, "wilson95": wilson(ok, n),
                           "bootstrap95": group.get("mean_probability_accuracy_ci95"),
                           "majority_vote_accuracy": group.get("majority_accuracy"),
                           "confusion_majority": group.get("confusion_matrix"),
                           "n_experiments": n},
        "per_video": {"mean_probability_accuracy": per_video.get("mean_probability_accuracy"),
                      "bootstrap95": per_video.get("mean_probability_accuracy_ci95"),
                      "n_videos": per_video.get("n_trials")},
        "per_window": {"accuracy": head.accuracy, "bootstrap95": head.accuracy_ci95,
                       "n_windows": ev.n_windows},
        "folds": ev.cv["folds"], "notes": ev.notes, "train_time_s": train_s,
        "train_time_s_folds": trained.wall_time_s,
        "latency_batch1_ms_median": lat.get("batch1_ms_median"),
    }


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--source", type=Path, default=SOURCE)
    ap.add_argument("--data", type=Path, default=None,
                    help="an ingested gelsight_mini_slip.h5 (default: ingest --source first, "
                         "about 11 GB and 13 min)")
    ap.add_argument("--variants", nargs="*", default=list(VARIANTS), choices=list(VARIANTS),
                    help="model variants (none: only the intensity signal)")
    ap.add_argument("--epochs", type=int, default=None, help="override optim.epochs")
    ap.add_argument("--no-intensity", action="store_true", help="skip the intensity signal")
    ap.add_argument("--out", type=Path, default=ROOT / "benchmarks" / "figures")
    ap.add_argument("--name", default=None, help="file stem of the record (default "
                    "gelsight_mini_slip, or gelsight_mini_slip_intensity with no variant)")
    ap.add_argument("--json", action="store_true", help="print the result as JSON")
    args = ap.parse_args(argv)
    if not args.source.is_dir():
        print(f"error: {args.source}: folder not found (the videos of ../shared/data/"
              "gelsight_mini_slip)", file=sys.stderr)
        return 2
    started = time.perf_counter()
    args.out.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory(prefix="gelsight_mini_") as tmp_s:
        tmp = Path(tmp_s)
        rows = write_labels(args.source, tmp / "labels.csv")
        if args.data is not None:
            data, ingest_cmd = args.data, None
        else:
            data = tmp / "gelsight_mini_slip.h5"
            ingest_cmd = ingest(args.source, tmp / "labels.csv", data)
        intensity = None if args.no_intensity else intensity_study(data, rows)
        length = length_study(data, rows)
        cache_frame_series()
        results = []
        for name in args.variants:
            print(f"{name}: {K} folds by object", file=sys.stderr, flush=True)
            results.append(run_one(name, data, tmp, epochs=args.epochs))
        data_sha = sha256_of(data)
    experiments = {r["experiment"]: r["slipped"] for r in rows}
    reached = sorted((r for r in results if (r["per_experiment"]["accuracy"] or 0) >= TARGET),
                     key=lambda r: r["n_params"])
    record = {
        "format": "tactile-gelsight-mini-slip", "format_version": 1,
        "tool_version": __version__, "created_utc": utc_now(),
        "command": " ".join([Path(sys.argv[0]).name, *sys.argv[1:]]) if argv is None
        else "main(" + " ".join(argv) + ")",
        "data": {"source": str(args.source), "ingest": ingest_cmd,
                 "path": str(args.data) if args.data else None, "sha256": data_sha,
                 "videos": len(rows), "experiments": len(experiments),
                 "slipped": int(sum(experiments.values())),
                 "objects": sorted({r["object"] for r in rows})},
        "config": str(CONFIG.relative_to(ROOT)), "epochs_override": args.epochs,
        "target": {"per_experiment_accuracy": TARGET, "published": "Parag, Misimi and "
                   "Adelson: 99 % on unseen objects (video vision transformer)"},
        "smallest_reaching_target": reached[0]["variant"] if reached else None,
        "intensity_signal": intensity, "video_length_alone": length, "results": results,
        "wall_time_s": time.perf_counter() - started,
    }
    out_json = args.out / (f"{args.name}.json" if args.name else "gelsight_mini_slip.json"
                           if args.variants else "gelsight_mini_slip_intensity.json")
    tmp_json = out_json.with_name(out_json.name + ".tmp")
    tmp_json.write_text(runs.dumps(record) + "\n", encoding="utf-8")
    os.replace(tmp_json, out_json)
    if args.json:
        print(runs.dumps(record))
        return 0
    print("| method | params | per experiment (95 % Wilson) | per video | per window | "
          "train s |")
    print("|---|---:|---|---|---|---:|")
    for r in results:
        e = r["per_experiment"]
        acc = np.nan if e["accuracy"] is None else e["accuracy"]
        print(f"| {r['variant']} | {r['n_params']:,} | {acc:.1%} [{e['wilson95'][0]:.1%}, "
              f"{e['wilson95'][1]:.1%}] | {r['per_video']['mean_probability_accuracy']:.1%} | "
              f"{r['per_window']['accuracy']:.1%} | {r['train_time_s']:.0f} |")
    if intensity is not None:
        for key, label in (("default_scale", "intensity signal, scale 2"),
                           ("scale_by_object_cv", "intensity signal, scale learned")):
            i = intensity[key]
            print(f"| {label} | 0 | {i['accuracy']:.1%} [{i['wilson95'][0]:.1%}, "
                  f"{i['wilson95'][1]:.1%}] (detected {i['detected']:.0%}, false alarms "
                  f"{i['false_alarms']:.0%}) | | | 0 |")
    print(f"| video length alone (no touch) | 0 | {length['accuracy']:.1%} "
          f"[{length['wilson95'][0]:.1%}, {length['wilson95'][1]:.1%}] | | | 0 |")
    print(f"wrote {out_json} ({record['wall_time_s']:.0f} s)")
    print(json.dumps({"smallest_reaching_target": record["smallest_reaching_target"]}))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
