"""Slip detection per tactile-mesh density and object, height and intensity sources side by
side (paper 002, sec. IV, Figs. 10-11: where a sparse mesh stops seeing small contacts).

Issue 16, item 5. For every trial of the given scene files (``tactile simulate
digit-press --seed N`` trials, ingested with ``--px-per-mm``), the maps are computed once
per source -- ``height``: the normal network ``--model`` (trained on another seed's
calibration presses) + eq. 9 + Poisson; ``intensity``: the frames' mean colour change
from the reference -- then for each mesh of :data:`MESH_SIZES` the slip signal (eq. 10),
the adaptive threshold (``--scale`` x the mean of the first 30 static signals) and the
decision, scored against the trial labels as ``tactile slip-signal`` does (a crossing at
or after ``slip_onset_s`` detects the slip, one before it or on a no_slip trial is a false
alarm). Per scene and source, the sparsest mesh that detects every slip (and the sparsest
with no false alarm as well) is named.

    .venv/bin/python benchmarks/slip_mesh.py --scenes trials1.h5 trials2.h5 --model RUN
        [--scale 2] [--json]

Writes benchmarks/figures/slip_mesh.json and slip_mesh_hex_keys.png (Fig. 10: the hex
keys' slip signals at 32x24 and 8x6, first scene).
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))
FIGURES = Path(__file__).resolve().parent / "figures"


def scene_maps(path: Path, run: Path | None, truth: Path | None = None) -> list[dict]:
    """Per trial: name, object, label, onset, t_s and, per source, the slip signal on every
    mesh (``truth``: the scene's true heights, the upper bound of the height source)."""
    from tactile_cli.store.trials import TactileFile
    from tactile_cli.visuotactile.heightmap import HeightMapper, frames_px_per_mm
    from tactile_cli.visuotactile.normals import NormalModel
    from tactile_cli.visuotactile.slip import trial_label, trial_maps

    out = []
    with TactileFile(path) as tf:
        trials = [t for t in tf.trials() if t.has_frames]
        mapper = None
        if run is not None:
            mapper = HeightMapper(NormalModel.from_run(run), frames_px_per_mm(tf, trials[0],
                                                                              None))
        for t in trials:
            slip, onset = trial_label(t.labels, path=tf.path, trial=t.name)
            rec = {"trial": t.name, "object": str(t.labels.get("object")), "slip": slip,
                   "onset_s": onset, "direction": str(t.labels.get("direction", "")),
                   "maps": {}}
            for src in ("height", "intensity"):
                if src == "height" and mapper is None:
                    continue
                maps, t_s = trial_maps(t, src, mapper)
                rec["maps"][src] = _signals(maps)
                rec["t_s"] = t_s
            if truth is not None:
                from tactile_cli.visuotactile.heightmap import load_truth

                rec["maps"]["truth"] = _signals(load_truth(truth, t.name, maps.shape))
            out.append(rec)
    return out


def _signals(maps: np.ndarray) -> dict[tuple[int, int], np.ndarray]:
    """The slip signal of ``maps`` on every mesh of MESH_SIZES (the maps are dropped)."""
    from tactile_cli.visuotactile.mesh import MESH_SIZES
    from tactile_cli.visuotactile.slip import slip_signal

    return {mesh: slip_signal(maps, mesh) for mesh in MESH_SIZES}


def slip_signal_of(tr: dict, source: str, mesh: tuple[int, int]) -> np.ndarray:
    """The slip signal of one trial's ``source`` on ``mesh`` (computed at load time)."""
    return tr["maps"][source][tuple(mesh)]


def score(trials: list[dict], mesh: tuple[int, int], source: str, scale: float) -> list[dict]:
    from tactile_cli.visuotactile.slip import detect_slip, score_trial

    rows = []
    for tr in trials:
        sig = slip_signal_of(tr, source, mesh)
        det = detect_slip(sig, tr["t_s"], scale=scale)
        sc = score_trial(det, slip=bool(tr["slip"]), onset_s=tr["onset_s"])
        rows.append({"trial": tr["trial"], "object": tr["object"], "slip": tr["slip"],
                     "direction": tr["direction"], "detected": sc.detected,
                     "false_alarm": sc.false_alarm, "delay_s": sc.delay_s,
                     "peak_ratio": det.peak_ratio(), "threshold": det.threshold,
                     "signal": sig, "t_s": tr["t_s"], "onset_s": tr["onset_s"]})
    return rows


def summarise(rows: list[dict]) -> dict:
    n_slip = sum(1 for r in rows if r["slip"])
    return {"n_trials": len(rows), "n_slip": n_slip,
            "detected": sum(1 for r in rows if r["slip"] and r["detected"]),
            "false_alarms": sum(1 for r in rows if r["false_alarm"]),
            "detection_rate": (sum(1 for r in rows if r["slip"] and r["detected"]) / n_slip
                               if n_slip else None)}


def hex_key_figure(rows_by_mesh: dict[str, list[dict]], out: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    keys = ("hex_key_small", "hex_key_medium", "hex_key_large")
    meshes = ("32x24", "8x6")
    fig, axes = plt.subplots(2, 3, figsize=(11, 5.2))
    for i, mesh in enumerate(meshes):
        for j, key in enumerate(keys):
            ax = axes[i, j]
            row = next((r for r in rows_by_mesh[mesh] if r["object"] == key and r["slip"]),
                       None)
            if row is None:
                ax.set_axis_off()
                continue
            ax.plot(row["t_s"], row["signal"], lw=1)
            ax.axhline(row["threshold"], color="tab:red", ls="--", lw=1)
            ax.axvline(row["onset_s"], color="k", ls=":", lw=1)
            verdict = "detected" if row["detected"] else "missed"
            ax.set_title(f"{key.replace('hex_key_', '')} hex key, {mesh} ({row['trial']}): "
                         f"{verdict}", fontsize=8)
            ax.set_xlabel("time (s)", fontsize=8)
            ax.set_ylabel("S (mm)", fontsize=8)
    fig.suptitle("Slip signal of the hex keys (height source): dense 32x24 against sparse "
                 "8x6 mesh; dashed: threshold, dotted: labelled onset", fontsize=9)
    fig.tight_layout()
    fig.savefig(out, dpi=110)
    plt.close(fig)


def main() -> None:
    from tactile_cli.visuotactile.mesh import MESH_SIZES

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scenes", type=Path, nargs="+", required=True)
    ap.add_argument("--model", type=Path, help="normal-network run (height source)")
    ap.add_argument("--truth", type=Path, nargs="*", default=[],
                    help="the scenes' truth/ folders (adds the source 'truth')")
    ap.add_argument("--tune-scene", type=Path, help="scene on which the threshold scale is "
                    "tuned per source and mesh (not one of --scenes)")
    ap.add_argument("--tune-truth", type=Path)
    ap.add_argument("--scale", type=float, default=2.0)
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args()
    load_before = os.getloadavg()
    t0 = time.perf_counter()
    result: dict = {"scale": args.scale, "model": str(args.model), "scenes": {},
                    "tuned_on": None if args.tune_scene is None else str(args.tune_scene),
                    "tuned_scale": {}}
    fig_rows: dict[str, list[dict]] = {}
    if args.tune_scene is not None:
        from tactile_cli.visuotactile.slip import best_scale

        tune = scene_maps(args.tune_scene, args.model, args.tune_truth)
        for src in tune[0]["maps"]:
            for mesh in MESH_SIZES:
                name = f"{mesh[0]}x{mesh[1]}"
                sigs = [(slip_signal_of(tr, src, mesh), tr["t_s"]) for tr in tune]
                choice = best_scale(sigs, [(bool(tr["slip"]), tr["onset_s"]) for tr in tune])
                result["tuned_scale"].setdefault(src, {})[name] = {
                    "scale": choice.scale, "range": [choice.best_from, choice.best_to],
                    "detection_rate": choice.rates.detection_rate,
                    "false_alarms": choice.rates.false_alarms, "n_trials": len(tune)}
        del tune
    truths = list(args.truth) + [None] * (len(args.scenes) - len(args.truth))
    for k, path in enumerate(args.scenes):
        trials = scene_maps(path, args.model, truths[k])
        sources = [s for s in ("height", "truth", "intensity") if s in trials[0]["maps"]]
        per: dict = {"n_trials": len(trials), "per_mesh": {}, "sparsest_detecting_all": {},
                     "sparsest_detecting_all_without_false_alarms": {}}
        for src in sources:
            for label, tuned in (("paper_scale", False), ("tuned_scale", True)):
                if tuned and src not in result["tuned_scale"]:
                    continue
                ok_all, ok_clean = None, None
                for mesh in MESH_SIZES:
                    name = f"{mesh[0]}x{mesh[1]}"
                    scale = (result["tuned_scale"][src][name]["scale"] if tuned
                             else args.scale)
                    rows = score(trials, mesh, src, scale)
                    if k == 0 and src == "height" and not tuned:
                        fig_rows[name] = rows
                    objects = sorted({r["object"] for r in rows})
                    entry = {"scale": scale, "all": summarise(rows),
                             "per_object": {o: summarise([r for r in rows if r["object"] == o])
                                            for o in objects},
                             "missed": [r["trial"] for r in rows
                                        if r["slip"] and not r["detected"]],
                             "false_alarm_trials": [r["trial"] for r in rows
                                                    if r["false_alarm"]]}
                    per["per_mesh"].setdefault(f"{src}/{label}", {})[name] = entry
                    s = entry["all"]
                    if s["detected"] == s["n_slip"]:
                        ok_all = name
                        if s["false_alarms"] == 0:
                            ok_clean = name
                per["sparsest_detecting_all"][f"{src}/{label}"] = ok_all
                per["sparsest_detecting_all_without_false_alarms"][f"{src}/{label}"] = ok_clean
        result["scenes"][str(path)] = per
        del trials
    result["load_before"], result["load_after"] = load_before, os.getloadavg()
    result["seconds"] = time.perf_counter() - t0
    FIGURES.mkdir(exist_ok=True)
    if "32x24" in fig_rows:
        hex_key_figure(fig_rows, FIGURES / "slip_mesh_hex_keys.png")
    (FIGURES / "slip_mesh.json").write_text(json.dumps(result, indent=2))
    if args.json:
        print(json.dumps(result, indent=2))
        return
    for path, per in result["scenes"].items():
        print(f"== {path} ({per['n_trials']} trials)")
        for src, meshes in per["per_mesh"].items():
            print(f"  {src}: sparsest mesh detecting every slip: "
                  f"{per['sparsest_detecting_all'][src]} (also without false alarms: "
                  f"{per['sparsest_detecting_all_without_false_alarms'][src]})")
            for name, e in meshes.items():
                objs = "  ".join(f"{o.replace('hex_key_', 'hex_')} {v['detected']}/{v['n_slip']}"
                                 f" fa{v['false_alarms']}" for o, v in e["per_object"].items())
                a = e["all"]
                print(f"    {name:>7} (scale {e['scale']:g}): detected {a['detected']}/"
                      f"{a['n_slip']}, false alarms {a['false_alarms']}/{a['n_trials']} | "
                      f"{objs}")
    print(f"load average before {result['load_before']}, after {result['load_after']}; "
          f"{result['seconds']:.0f} s")


if __name__ == "__main__":
    main()
