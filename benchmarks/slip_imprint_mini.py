"""Imprint retention on the GelSight Mini videos (issue 35, item 2): does the rule that
decides the GelSight lifts (``tactile slip-imprint``) tell a slip from a wiggle?

Data: the ingested ``gelsight_mini_slip`` file (``benchmarks/gelsight_mini_slip.py`` and
RESULTS.md, "Real data: GelSight Mini videos": 150 experiments of 29 objects, two cameras
each, label ``slip``: slip | no_slip (a wiggle), ``experiment``, ``object``).

Per video, every 5th frame (5 fps, as the learned models read them) and the last: the
brightness change from the reference frame as area means on a 32 x 24 mesh, then
:func:`tactile_cli.visuotactile.imprint.imprint_change` at each grasp part and three
read-outs: ``last`` (the command's: 1 - retention at the last frame), ``min`` (the lowest
retention after the grasp) and ``fixed`` (2 s after the grasp frame: videos differ in
length, a slip ends the recording early). An experiment's change is the larger of its two
cameras'. The threshold is chosen leaving one object out
(:func:`~tactile_cli.visuotactile.imprint.threshold_by_cv`), against the same rule on the
video's length alone (longer: wiggle). Accuracy per experiment, 95 % Wilson.

    .venv/bin/python benchmarks/slip_imprint_mini.py --data gelsight_mini_slip.h5 [--json]

Writes benchmarks/figures/slip_imprint_mini.json. About 2 min (reading).
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from tactile_cli._version import __version__  # noqa: E402
from tactile_cli.store.trials import TactileFile  # noqa: E402
from tactile_cli.store.writer import sha256_of, utc_now  # noqa: E402
from tactile_cli.visuotactile.imprint import (  # noqa: E402
    imprint_change,
    mesh_means,
    threshold_by_cv,
)
from tactile_cli.visuotactile.signals import _channel_mean  # noqa: E402

STEP = 5
GRASP_PARTS = (0.2, 0.3, 0.5, 2 / 3)
READOUTS = ("last", "min", "fixed")
FIXED_S = 2.0


def read_videos(data: Path) -> list[dict[str, Any]]:
    """Per video: experiment, object, slipped, stored frames and the mesh maps of every
    STEP-th frame and the last (n_kept, 24, 32) with their frame times."""
    out = []
    with TactileFile(data) as tf:
        for t in tf.trials():
            lab = t.labels
            fr = t.frames()
            n = len(fr)
            ref = _channel_mean(fr.reference)
            idx = sorted(set(range(0, n, STEP)) | {n - 1})
            maps = np.stack([_channel_mean(fr[k]) - ref for k in idx])
            out.append({"experiment": str(lab["experiment"]), "object": str(lab["object"]),
                        "slipped": str(lab["slip"]) == "slip", "frames": n,
                        "t_s": np.asarray(fr.t_s)[idx], "cells": mesh_means(maps, (32, 24))})
    return out


def change_of(video: dict[str, Any], part: float, readout: str) -> float:
    cells = video["cells"]
    if readout == "last":
        return imprint_change(cells, mesh=(32, 24), grasp_part=part).change
    im = imprint_change(cells, mesh=(32, 24), grasp_part=part)
    after = im.retention[im.grasp_index + 1:]
    if readout == "min":
        return float(1 - np.nanmin(after))
    t = video["t_s"]
    j = int(np.searchsorted(t, t[im.grasp_index] + FIXED_S))
    return float(1 - im.retention[min(j, len(t) - 1)]) if j > im.grasp_index else float(
        1 - after[-1])


def measure(data: Path) -> dict[str, Any]:
    t0 = time.perf_counter()
    videos = read_videos(data)
    read_s = time.perf_counter() - t0
    exps: dict[str, list[dict[str, Any]]] = {}
    for v in videos:
        exps.setdefault(v["experiment"], []).append(v)
    names = sorted(exps)
    slipped = [exps[e][0]["slipped"] for e in names]
    objects = [exps[e][0]["object"] for e in names]

    def scored(values: list[float]) -> dict[str, Any]:
        cv = threshold_by_cv(values, slipped, objects)
        return {"cv_correct": cv.correct, "cv_trials": cv.n_trials,
                "cv_accuracy": round(cv.accuracy, 4),
                "cv_accuracy_interval": [round(v, 4) for v in cv.interval],
                "detection_rate": round(cv.detection_rate, 4),
                "false_alarm_rate": round(cv.false_alarm_rate, 4)}

    length = scored([-float(max(v["frames"] for v in exps[e])) for e in names])
    rows = []
    for part in GRASP_PARTS:
        for readout in READOUTS:
            vals = [max(change_of(v, part, readout) for v in exps[e]) for e in names]
            rows.append({"grasp_part": round(part, 4), "readout": readout, **scored(vals)})
    return {"experiments": len(names), "slipped": int(sum(slipped)), "videos": len(videos),
            "read_seconds": round(read_s, 1), "video_length_alone": length, "imprint": rows}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--data", type=Path, required=True, help="the ingested Mini file")
    ap.add_argument("--json", action="store_true")
    ap.add_argument("--figures", type=Path, default=ROOT / "benchmarks/figures")
    args = ap.parse_args()
    if not args.data.is_file():
        sys.exit(f"slip_imprint_mini.py: error: --data {args.data} is not a file")
    record = {"benchmark": "slip_imprint_mini", "tool_version": __version__,
              "created_utc": utc_now(),
              "data": {"path": str(args.data), "sha256": sha256_of(args.data)},
              "mesh": "32x24", "frame_step": STEP, **measure(args.data)}
    args.figures.mkdir(parents=True, exist_ok=True)
    (args.figures / "slip_imprint_mini.json").write_text(json.dumps(record, indent=2) + "\n")
    if args.json:
        print(json.dumps(record, indent=2))
        return
    r = record["video_length_alone"]
    print(f"video length alone: {r['cv_correct']}/{r['cv_trials']} = "
          f"{100 * r['cv_accuracy']:.1f} % {r['cv_accuracy_interval']}")
    for r in record["imprint"]:
        print(f"imprint part {r['grasp_part']:.2f} {r['readout']:5s}: {r['cv_correct']}/"
              f"{r['cv_trials']} = {100 * r['cv_accuracy']:.1f} % {r['cv_accuracy_interval']}"
              f" (detected {r['detection_rate']:.2f}, false alarms {r['false_alarm_rate']:.2f})")


if __name__ == "__main__":
    main()
