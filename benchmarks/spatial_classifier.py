"""The spatial-temporal classifier (paper 000, sec. 5.2, Table II) against the temporal one.

Three LSTMs, trained only on model-based trajectories (`tactile synth --centroids`, default
config): the temporal LSTM (configs/train_lstm_actions.yaml) on their event counts, the
spatial LSTM (configs/train_lstm_spatial.yaml) on their ROI centroid trajectories (eqs.
19-20), and the same spatial LSTM on a synth whose background spans 15-3000 events per bin
and polarity instead of 15-25 ("spatial_bg": what covering a noisier sensor in training
costs). All are evaluated on the same simulated scene recordings (`tactile simulate
marker-events`, default config, 48 trials): the temporal one on the events, the spatial
ones on `tactile centroids` of the same file. Reported side by side: accuracy (Table II:
99.41 % for the spatial LSTM), accuracy without the bins next to an action change, batch-1
latency, parameters and training time.

Then all are pushed until they break, one scene factor at a time (12-trial scenes, the
clean scene's ROIs, the same trained models):

- background: uniform background events over the sensor (events/s; scene default 2000);
- slip_speed: the object's slip speed (m/s; the synth trained on 0.001-0.006). The event
  counts do not depend on it (eq. 17), the centroids' motion does (eq. 15).

The breaking point of an axis is the first setting, walking away from the default, where a
model's accuracy falls below 0.9x its clean accuracy (as `tactile perturb`). Writes
OUT/spatial_classifier.json and benchmarks/figures/spatial_classifier.{png,json}.

    .venv/bin/python benchmarks/spatial_classifier.py                # ~16 min on 2 cores
    .venv/bin/python benchmarks/spatial_classifier.py --n-synth 120 --epochs 5 --no-figures  # smoke
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import time
from pathlib import Path

import yaml

ROOT = Path(__file__).resolve().parents[1]
TACTILE = str(Path(sys.executable).with_name("tactile"))
FIGURES = ROOT / "benchmarks" / "figures"

AXES = {
    "background": ("noise", "background_rate_hz",
                   [2_000.0, 5_000.0, 10_000.0, 20_000.0, 100_000.0, 300_000.0, 1_000_000.0,
                    3_000_000.0]),
    "slip_speed": ("slip", "speeds_m_s",
                   [0.004, 0.002, 0.001, 0.0005, 0.00025, 0.000125]),
}
LABELS = {"background": "background events/s over the sensor",
          "slip_speed": "slip speed (mm/s)"}
#: model -> (train config, synth variant); the variants are written by main().
MODELS = {"temporal": (ROOT / "configs" / "train_lstm_actions.yaml", "default"),
          "spatial": (ROOT / "configs" / "train_lstm_spatial.yaml", "default"),
          "spatial_bg": (ROOT / "configs" / "train_lstm_spatial.yaml", "wide_background")}
WIDE_BACKGROUND_PER_BIN = [15.0, 3000.0]
TABLE_II = 0.9941


def tactile(*args: str, json_out: bool = False) -> dict | None:
    """Run one `tactile` command; its parsed --json output when asked."""
    cmd = [TACTILE, *args]
    r = subprocess.run(cmd, capture_output=True, text=True, check=False)
    if r.returncode != 0:
        raise SystemExit(f"failed ({r.returncode}): {' '.join(cmd)}\n{r.stderr.strip()}")
    if json_out:
        return json.loads(r.stdout[r.stdout.index("{"):])
    return None


def make_scene(out: Path, name: str, *, seed: int, config: dict | None, groups: int | None,
               rois: Path | None) -> tuple[Path, Path, Path]:
    """Simulate, ingest and turn into centroids; returns (scene.h5, centroids.h5, scene.json).
    ``rois``: the ROI file of the centroids (default: the scene's own)."""
    folder = out / name
    args = ["simulate", "marker-events", "--out", str(folder), "--seed", str(seed),
            "--no-progress"]
    if config is not None:
        cfg_path = out / f"{name}.yaml"
        cfg_path.write_text(yaml.safe_dump(config))
        args += ["--config", str(cfg_path)]
    if groups is not None:
        args += ["--groups", str(groups)]
    tactile(*args)
    h5 = out / f"{name}.h5"
    tactile("ingest", *sorted(str(p) for p in folder.glob("*.npy")), "--width", "640",
            "--height", "480", "--annotations", str(folder / "annotations.csv"),
            "--trial-labels", str(folder / "trials.csv"), "--out", str(h5), "--overwrite",
            "--no-progress")
    centroids = out / f"{name}_centroids.h5"
    tactile("centroids", str(h5), "--rois", str(rois or folder / "scene.json"), "--out",
            str(centroids), "--overwrite", "--no-progress")
    return h5, centroids, folder / "scene.json"


def train_all(out: Path, synth: dict[str, Path], epochs: int | None,
              parallel: int = 2) -> dict[str, dict]:
    """Train every model of :data:`MODELS`, ``parallel`` at a time (one thread each)."""
    pending = list(MODELS)
    running: dict[str, subprocess.Popen] = {}
    result = {}
    while pending or running:
        while pending and len(running) < parallel:
            kind = pending.pop(0)
            cfg, variant = MODELS[kind]
            cmd = [TACTILE, "train", str(cfg), "--data", str(synth[variant]), "--out",
                   str(out / kind), "--overwrite", "--no-progress", "--json"]
            if epochs is not None:
                cmd += ["--epochs", str(epochs)]
            running[kind] = subprocess.Popen(cmd, stdout=subprocess.PIPE,
                                             stderr=subprocess.PIPE, text=True)
        kind = next(iter(running))
        p = running.pop(kind)
        stdout, stderr = p.communicate()
        if p.returncode != 0:
            raise SystemExit(f"training {kind} failed:\n{stderr.strip()}")
        result[kind] = json.loads(stdout[stdout.index("{"):])
        print(f"  trained {kind} in {result[kind]['train_time_s']:.0f} s", flush=True)
    return result


def evaluate(run: Path, data: Path, name: str, latency: bool) -> dict:
    args = ["evaluate", str(run), "--data", str(data), "--name", name, "--json"]
    if not latency:
        args.append("--no-latency")
    m = tactile(*args, json_out=True)
    assert m is not None
    return m


def breaking(rows: list[dict], kind: str, clean: float, factor: float = 0.9):
    for row in rows:
        if row[kind] < factor * clean:
            return row["value"]
    return None


def _si(x: float) -> str:
    """2000 -> '2k', 3e6 -> '3M'."""
    for factor, suffix in ((1e6, "M"), (1e3, "k")):
        if x >= factor:
            return f"{x / factor:g}{suffix}"
    return f"{x:g}"


def plot(result: dict, path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, len(AXES), figsize=(5.2 * len(AXES), 3.8))
    for ax, axis in zip(axes, AXES, strict=True):
        rows = result["stress"][axis]
        xs = [r["value"] for r in rows]
        for kind, style in (("temporal", "o-"), ("spatial", "s-"), ("spatial_bg", "^--")):
            label = {"spatial_bg": "spatial LSTM, synth background x1-150"}.get(
                kind, f"{kind} LSTM")
            ax.plot(xs, [100 * r[kind] for r in rows], style, label=label)
            b = result["breaking"][axis][kind]
            if b is not None:
                ax.axvline(b, ls=":", color=ax.lines[-1].get_color())
        ax.set_xscale("log")
        ax.set_xticks(xs, [f"{1e3 * x:g}" if axis == "slip_speed" else _si(x) for x in xs],
                      fontsize=8)
        ax.minorticks_off()
        if axis == "slip_speed":
            ax.invert_xaxis()
        ax.set_xlabel(LABELS[axis])
        ax.set_ylabel("accuracy (%)")
        ax.set_ylim(0, 101)
        ax.grid(alpha=0.3)
        ax.legend(loc="lower left")
    fig.suptitle("Actions from event counts (temporal) and from ROI centroids (spatial), "
                 "trained on synth only: where each breaks (dotted: < 0.9x clean)",
                 fontsize=9)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", type=Path, default=Path("/tmp/tactile_spatial_bench"))
    ap.add_argument("--n-synth", type=int, default=500, help="synth training trials")
    ap.add_argument("--seed", type=int, default=0, help="synth seed")
    ap.add_argument("--scene-seed", type=int, default=5, help="evaluation scene seed")
    ap.add_argument("--epochs", type=int, default=None, help="override the configs' epochs")
    ap.add_argument("--no-figures", action="store_true",
                    help="do not write benchmarks/figures (smoke runs)")
    args = ap.parse_args()
    out: Path = args.out
    out.mkdir(parents=True, exist_ok=True)
    os.environ.setdefault("OMP_NUM_THREADS", "1")

    t0 = time.perf_counter()
    scene_h5, scene_c, rois = make_scene(out, "clean", seed=args.scene_seed, config=None,
                                         groups=None, rois=None)
    synth_cfg = yaml.safe_load((ROOT / "configs" / "synth_fos.yaml").read_text())
    synth_cfg["noise"]["background_per_bin"] = WIDE_BACKGROUND_PER_BIN
    (out / "synth_wide_background.yaml").write_text(yaml.safe_dump(synth_cfg))
    synth = {"default": out / "synth.h5", "wide_background": out / "synth_wide_background.h5"}
    for variant, path in synth.items():
        extra = [] if variant == "default" else ["--config",
                                                 str(out / "synth_wide_background.yaml")]
        tactile("synth", "--n", str(args.n_synth), "--seed", str(args.seed), "--centroids",
                str(rois), "--out", str(path), "--overwrite", *extra)
    print(f"data ready in {time.perf_counter() - t0:.0f} s; training {len(MODELS)} LSTMs ...",
          flush=True)
    trained = train_all(out, synth, args.epochs)
    data = {k: scene_h5 if k == "temporal" else scene_c for k in MODELS}
    clean = {k: evaluate(out / k, data[k], "clean", latency=True) for k in MODELS}

    print(f"\n{'model':<11}{'accuracy':>10}{'w/o +-1 bin':>13}{'latency ms':>12}"
          f"{'params':>9}{'train s':>9}")
    for k, m in clean.items():
        inner = 100 * m["accuracy_excluding_boundaries"]
        print(f"{k:<11}{100 * m['accuracy']:>9.2f}%{inner:>12.2f}%"
              f"{m['latency']['batch1_ms_median']:>12.3f}{m['model']['n_params']:>9,}"
              f"{trained[k]['train_time_s']:>9.0f}")
    print(f"Table II (spatial LSTM): {100 * TABLE_II:.2f} %; spatial here: "
          f"{100 * clean['spatial']['accuracy']:.2f} % "
          f"({'met' if clean['spatial']['accuracy'] >= TABLE_II else 'NOT met'})", flush=True)

    default = yaml.safe_load((ROOT / "configs" / "scene_marker_events.yaml").read_text())
    stress: dict[str, list[dict]] = {}
    for axis, (section, key, values) in AXES.items():
        stress[axis] = []
        for v in values:
            cfg = json.loads(json.dumps(default))
            cfg[section][key] = [v] if key == "speeds_m_s" else v
            name = f"{axis}_{v:g}"
            h5, c5, _ = make_scene(out, name, seed=args.scene_seed + 1, config=cfg, groups=1,
                                   rois=rois)
            row = {"value": v}
            for k in MODELS:
                row[k] = evaluate(out / k, h5 if k == "temporal" else c5, name,
                                  latency=False)["accuracy"]
            stress[axis].append(row)
            print(f"{axis:>11} {v:>10g}: " + "  ".join(
                f"{k} {100 * row[k]:6.2f} %" for k in MODELS), flush=True)
    brk = {axis: {k: breaking(rows, k, clean[k]["accuracy"]) for k in MODELS}
           for axis, rows in stress.items()}
    for axis, b in brk.items():
        print(f"breaking point, {axis}: " + ", ".join(f"{k} {b[k]}" for k in MODELS))

    result = {
        "n_synth": args.n_synth, "seed": args.seed, "scene_seed": args.scene_seed,
        "epochs": args.epochs, "table_ii": TABLE_II,
        "wide_background_per_bin": WIDE_BACKGROUND_PER_BIN,
        "clean": {k: {"accuracy": m["accuracy"],
                      "accuracy_excluding_boundaries": m["accuracy_excluding_boundaries"],
                      "n_windows": m["n_windows"], "n_trials": m["n_trials"],
                      "latency_ms": m["latency"]["batch1_ms_median"],
                      "n_params": m["model"]["n_params"],
                      "train_s": trained[k]["train_time_s"]} for k, m in clean.items()},
        "stress": stress, "breaking": brk, "seconds": time.perf_counter() - t0,
    }
    text = json.dumps(result, indent=2) + "\n"
    (out / "spatial_classifier.json").write_text(text)
    if not args.no_figures:
        FIGURES.mkdir(exist_ok=True)
        (FIGURES / "spatial_classifier.json").write_text(text)
        plot(result, FIGURES / "spatial_classifier.png")
        print(f"wrote {FIGURES / 'spatial_classifier.png'}")
    print(f"total {result['seconds'] / 60:.1f} min")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
