"""Imprint retention on the real GelSight lifts (issue 35, items 2-3): ``tactile
slip-imprint`` against the intensity slip signal on the same lifts and folds, its cost per
frame, and how much its two settings matter.

Data: ../shared/data/gelsight_slip (Li et al., ICRA 2018; objects 1 and 2 only: 20 lifts
of 21 frames, 640x480), ingested as ``benchmarks/slip_gelsight.py`` does (``tactile
ingest ... --reference first --trial-labels LABELS.csv``; label ``slip``: slip | no_slip).

- ``imprint``: ``tactile slip-imprint FILE`` at its defaults (mesh 32x24, grasp part 2/3,
  ``--threshold auto``): the threshold is chosen on one object's lifts and scored on the
  other's (leave one object out); ``cv_accuracy`` pooled over both folds with its 95 %
  Wilson interval over lifts; ``ms_per_frame``: the command's wall time (frames read,
  intensity maps, imprint) over the frames it read, one process, this machine.
- ``slip_signal``: ``tactile slip-signal FILE --source intensity --n-static 3 --scale
  auto`` on the same file and folds (the analytic baseline of item 3), timed the same way.
- ``stress``: the defaults on worse recordings (seeded): camera noise added to every frame
  and the reference (SD 0-40 levels), every k-th frame kept (a slower camera), and each
  lift's reference frame taken from another lift of its object (with ``--baseline first``,
  the default, and ``reference``); ``breaking_noise_sd`` and
  ``breaking_frame_step``: the first level below 88 % (None: none of the levels).
- ``grid``: the leave-one-object-out accuracy at every mesh x grasp part of the grid, from
  the same intensity maps. The defaults were chosen after looking at these 20 lifts, so
  the grid shows how far that choice carries, and no figure here is held out for the
  settings: only for the threshold. The set's other objects are held out by the lead.

    .venv/bin/python benchmarks/slip_imprint_gelsight.py [--data lifts.h5] [--json]

Writes benchmarks/figures/slip_imprint_gelsight.json.
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "benchmarks"))

from slip_gelsight import ingest_lifts  # noqa: E402

from tactile_cli._version import __version__  # noqa: E402
from tactile_cli.store.trials import TactileFile  # noqa: E402
from tactile_cli.store.writer import sha256_of, utc_now  # noqa: E402
from tactile_cli.visuotactile.imprint import (  # noqa: E402
    imprint_change,
    read_slipped,
    slip_imprint_file,
    threshold_by_cv,
)
from tactile_cli.visuotactile.signals import intensity_maps  # noqa: E402
from tactile_cli.visuotactile.slip import slip_signal_file, trial_maps  # noqa: E402

MESHES = ((16, 12), (32, 24), (64, 48))
GRASP_PARTS = (0.5, 0.55, 0.6, 0.67, 0.75, 0.8, 0.9)


def _frames(data: Path) -> int:
    with TactileFile(data) as tf:
        return sum(t.frames().t_s.size for t in tf.trials())


def grid(data: Path) -> list[dict[str, Any]]:
    """Leave-one-object-out accuracy per mesh x grasp part, maps computed once."""
    with TactileFile(data) as tf:
        lifts = []
        for t in tf.trials():
            slipped = read_slipped(t.labels, "slip", path=tf.path, trial=t.name)
            if slipped is not None:
                lifts.append((str(t.labels["object"]), slipped,
                              trial_maps(t, "intensity", None)[0]))
    rows = []
    for mesh in MESHES:
        for part in GRASP_PARTS:
            changes = [imprint_change(m, mesh=mesh, grasp_part=part).change
                       for _, _, m in lifts]
            cv = threshold_by_cv(changes, [s for _, s, _ in lifts], [o for o, _, _ in lifts])
            rows.append({"mesh": f"{mesh[0]}x{mesh[1]}", "grasp_part": part,
                         "cv_correct": cv.correct, "cv_trials": cv.n_trials,
                         "cv_accuracy": round(cv.accuracy, 4),
                         "fold_thresholds": {f.group: round(f.threshold, 4)
                                             for f in cv.folds}})
    return rows


#: camera noise added to every frame and the reference (standard deviation, 0-255 levels)
NOISE_LEVELS = (0.0, 2.0, 5.0, 10.0, 20.0, 40.0)
#: keep every k-th frame (the first and the last kept): a slower camera
FRAME_STEPS = (1, 2, 3, 5)
#: the target of issue 35 item 2 (per lift)
TARGET = 0.88


def _read_lifts(data: Path) -> list[tuple[str, str, bool, np.ndarray, np.ndarray]]:
    """(trial, object, slipped, frames (n, H, W, 3) uint8, reference) per labelled lift."""
    out = []
    with TactileFile(data) as tf:
        for t in tf.trials():
            slipped = read_slipped(t.labels, "slip", path=tf.path, trial=t.name)
            if slipped is None:
                continue
            fr = t.frames()
            out.append((t.name, str(t.labels["object"]), slipped,
                        np.stack([img for _, img in fr]), fr.reference))
    return out


def _loo(lifts: list, frames_of, reference_of, baseline: str = "first") -> dict[str, Any]:
    changes = []
    for i, lift in enumerate(lifts):
        maps = intensity_maps(frames_of(i, lift), reference_of(i, lift))
        changes.append(imprint_change(maps, baseline=baseline).change)
    cv = threshold_by_cv(changes, [s for _, _, s, _, _ in lifts], [o for _, o, _, _, _ in lifts])
    return {"cv_correct": cv.correct, "cv_trials": cv.n_trials,
            "cv_accuracy": round(cv.accuracy, 4),
            "fold_thresholds": {f.group: round(f.threshold, 4) for f in cv.folds}}


def stress(data: Path, seed: int = 0) -> dict[str, Any]:
    """Leave-one-object-out accuracy at the defaults when the recording is worse: camera
    noise on every frame and the reference, fewer frames, and a reference frame from
    another lift of the same object (taken at another time). Breaking point: the first
    level below :data:`TARGET`."""
    lifts = _read_lifts(data)

    def noisy(sd: float):
        def add(i: int, img: np.ndarray) -> np.ndarray:
            if sd == 0:
                return img
            rng = np.random.default_rng([seed, i, int(sd * 10), img.ndim])
            return np.clip(np.rint(img + rng.normal(0, sd, img.shape)), 0, 255).astype(
                np.uint8)
        return add

    noise = []
    for sd in NOISE_LEVELS:
        add = noisy(sd)
        noise.append({"noise_sd": sd, **_loo(lifts, lambda i, lift, a=add: a(i, lift[3]),
                                             lambda i, lift, a=add: a(i, lift[4]))})
    steps = []
    for k in FRAME_STEPS:
        def keep(i: int, lift: tuple, k: int = k) -> np.ndarray:
            idx = np.unique(np.r_[np.arange(0, len(lift[3]), k), len(lift[3]) - 1])
            return lift[3][idx]
        r = _loo(lifts, keep, lambda i, lift: lift[4])
        steps.append({"frame_step": k, "frames": int(np.unique(np.r_[np.arange(0, 21, k),
                                                                       20]).size), **r})
    # the reference of the next lift of the same object (in trial order)
    by_obj: dict[str, list[int]] = {}
    for i, lift in enumerate(lifts):
        by_obj.setdefault(lift[1], []).append(i)
    other = {i: idx[(idx.index(i) + 1) % len(idx)] for idx in by_obj.values() for i in idx}
    swapped = {b: _loo(lifts, lambda i, lift: lift[3], lambda i, lift: lifts[other[i]][4],
                       baseline=b) for b in ("first", "reference")}

    def breaking(rows: list[dict[str, Any]], key: str) -> Any:
        return next((r[key] for r in rows if r["cv_accuracy"] < TARGET), None)

    return {"seed": seed, "target": TARGET, "noise": noise, "frame_steps": steps,
            "reference_of_another_lift": swapped,
            "breaking_noise_sd": breaking(noise, "noise_sd"),
            "breaking_frame_step": breaking(steps, "frame_step")}


def measure(data: Path) -> dict[str, Any]:
    n_frames = _frames(data)
    t0 = time.perf_counter()
    res = slip_imprint_file(data)
    imprint_s = time.perf_counter() - t0
    cv = res.threshold_cv
    assert cv is not None
    t0 = time.perf_counter()
    sig = slip_signal_file(data, source="intensity", n_static=3, scale="auto")
    signal_s = time.perf_counter() - t0
    scv = sig.scale_cv["intensity"]
    return {
        "frames": n_frames,
        "imprint": {
            "command": "tactile slip-imprint FILE", "mesh": "32x24",
            "grasp_part": round(res.grasp_part, 4), "threshold": cv.threshold,
            "fold_thresholds": {f.group: f.threshold for f in cv.folds},
            "cv_correct": cv.correct, "cv_trials": cv.n_trials,
            "cv_accuracy": round(cv.accuracy, 4),
            "cv_accuracy_interval": [round(v, 4) for v in cv.interval],
            "cv_detection_rate": round(cv.detection_rate, 4),
            "cv_false_alarm_rate": round(cv.false_alarm_rate, 4),
            "changes": {t.trial: round(t.imprint.change, 5) for t in res.trials},
            "seconds": round(imprint_s, 2),
            "ms_per_frame": round(1000 * imprint_s / n_frames, 2)},
        "slip_signal": {
            "command": "tactile slip-signal FILE --source intensity --n-static 3 --scale auto",
            "scale": scv.scale, "fold_scales": {f.group: f.scale for f in scv.folds},
            "cv_correct": scv.rates.correct,
            "cv_trials": scv.rates.n_slip + scv.rates.n_no_slip,
            "cv_accuracy": round(scv.rates.accuracy, 4),
            "cv_accuracy_interval": [round(v, 4) for v in scv.accuracy_interval],
            "seconds": round(signal_s, 2),
            "ms_per_frame": round(1000 * signal_s / n_frames, 2)},
        "grid": grid(data),
        "stress": stress(data),
    }


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--data", type=Path, help="lifts.h5 ingested as above; default: ingest "
                    "--source into a temporary file")
    ap.add_argument("--source", type=Path, default=ROOT.parent / "shared/data/gelsight_slip")
    ap.add_argument("--json", action="store_true")
    ap.add_argument("--figures", type=Path, default=ROOT / "benchmarks/figures")
    args = ap.parse_args()
    if args.data is not None and not args.data.is_file():
        sys.exit(f"slip_imprint_gelsight.py: error: --data {args.data} is not a file")
    with tempfile.TemporaryDirectory() as tmp:
        data = args.data or ingest_lifts(args.source, Path(tmp) / "lifts.h5")
        record = {"benchmark": "slip_imprint_gelsight", "tool_version": __version__,
                  "created_utc": utc_now(),
                  "data": {"path": str(data), "sha256": sha256_of(data),
                           "source": str(args.source)},
                  "source": "intensity", **measure(data)}
    args.figures.mkdir(parents=True, exist_ok=True)
    (args.figures / "slip_imprint_gelsight.json").write_text(json.dumps(record, indent=2)
                                                             + "\n")
    if args.json:
        print(json.dumps(record, indent=2))
        return
    for key in ("imprint", "slip_signal"):
        r = record[key]
        lo, hi = r["cv_accuracy_interval"]
        print(f"{key:11s} leave one object out: {r['cv_correct']}/{r['cv_trials']} lifts "
              f"= {100 * r['cv_accuracy']:.1f} % [{100 * lo:.1f}, {100 * hi:.1f}], "
              f"{r['ms_per_frame']:.1f} ms a frame ({r['command']})")
    st = record["stress"]
    print("stress (leave one object out, lifts right of 20): noise SD "
          + ", ".join(f"{r['noise_sd']:g}: {r['cv_correct']}" for r in st["noise"])
          + "; every k-th frame " + ", ".join(f"{r['frame_step']} ({r['frames']} frames): "
                                             f"{r['cv_correct']}" for r in st["frame_steps"])
          + "; reference of another lift: " + ", ".join(
              f"baseline {b} {r['cv_correct']}"
              for b, r in st["reference_of_another_lift"].items())
          + f"; below {100 * st['target']:.0f} % from noise SD {st['breaking_noise_sd']}, "
          f"frame step {st['breaking_frame_step']}")
    print("grid (leave one object out, lifts right of 20):")
    for mesh in dict.fromkeys(g["mesh"] for g in record["grid"]):
        cells = [g for g in record["grid"] if g["mesh"] == mesh]
        print(f"  mesh {mesh:6s} " + "  ".join(f"part {g['grasp_part']:.2f}: "
                                              f"{g['cv_correct']:2d}" for g in cells))


if __name__ == "__main__":
    main()
