"""Bandwidth study of paper 001, sec. 6.4 (issue 14, item 5): motion/texture accuracy of one
model as the accelerations' cut-off is halved from 4 kHz to 31.25 Hz.

For every cut-off: ``tactile_cli.accel.prepare.prepare_file(cutoff_hz=...)`` on the training
scene and on a held-out scene (another seed), train the config on the first, evaluate on
the held-out scene's test split. Prints a table and the cut-off below which motion accuracy
drops under 80 %, writes the rows (--out-json) and a chart like the paper's Fig. 10
(--plot: accuracy of motion and texture and the speed error against the cut-off, the 80 %
line and the named cut-off), and with --json prints the rows.

    .venv/bin/python benchmarks/vibro_bandwidth.py --train scene0.h5 scene3.h5 \
        --test scene7.h5 --config configs/train_cnn2d_vibro.yaml --work /tmp/bw

Replot from a saved JSON without training: ``--replot benchmarks/figures/vibro_bandwidth.json``.

(scene*.h5: `tactile ingest <tree> --format accel-tree` of `tactile simulate vibro-slip`.)
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from tactile_cli._version import __version__  # noqa: E402
from tactile_cli.accel.prepare import prepare_file  # noqa: E402
from tactile_cli.learn import load_config  # noqa: E402
from tactile_cli.learn.evaluate import evaluate  # noqa: E402
from tactile_cli.learn.train import train  # noqa: E402
from tactile_cli.spectral import bandwidth_steps  # noqa: E402


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--train", type=Path, nargs="+", help="training scene(s), ingested")
    ap.add_argument("--test", type=Path, help="held-out scene (another seed), ingested")
    ap.add_argument("--config", type=Path, default=Path("configs/train_cnn2d_vibro.yaml"))
    ap.add_argument("--epochs", type=int, default=None)
    ap.add_argument("--work", type=Path)
    ap.add_argument("--threshold", type=float, default=0.80)
    ap.add_argument("--json", action="store_true")
    ap.add_argument("--out-json", type=Path,
                    default=ROOT / "benchmarks" / "figures" / "vibro_bandwidth.json")
    ap.add_argument("--plot", type=Path,
                    default=ROOT / "benchmarks" / "figures" / "vibro_bandwidth.png")
    ap.add_argument("--replot", type=Path, help="chart a saved --out-json; no training")
    args = ap.parse_args()
    if args.replot:
        record = json.loads(args.replot.read_text())
        plot(record["rows"], args.plot, record["threshold"], record["lowest_cutoff_ok_hz"])
        print(f"wrote {args.plot}")
        return
    if not (args.train and args.test and args.work):
        ap.error("--train, --test and --work are needed (or --replot JSON)")
    args.work.mkdir(parents=True, exist_ok=True)
    cfg = load_config(args.config).with_overrides(epochs=args.epochs)
    rows = []
    for cutoff in bandwidth_steps(8000.0):
        started = time.perf_counter()
        tag = f"{cutoff:g}Hz"
        cut = None if cutoff >= 4000 else cutoff
        trs = [prepare_file(path, args.work / f"train{i}_{tag}.h5", cutoff_hz=cut,
                            overwrite=True).out for i, path in enumerate(args.train)]
        te = prepare_file(args.test, args.work / f"test_{tag}.h5", cutoff_hz=cut,
                          overwrite=True).out
        run = args.work / f"run_{tag}"
        train(cfg, trs, run, overwrite=True)
        res = evaluate(run, [te], split="test", latency=False, overwrite=True)
        heads = res.as_dict()["heads"]
        rows.append({"cutoff_hz": cutoff, "motion": heads["motion"]["accuracy"],
                     "texture": heads["object"]["accuracy"],
                     "texture_by_motion": {k: v["accuracy"] for k, v in
                                           heads["object"]["accuracy_by"]["motion"].items()},
                     "n_test_windows": res.n_windows,
                     "speed_mae_cm_s": heads["speed_cm_s"]["mae"],
                     "seconds": round(time.perf_counter() - started, 1)})
        print(f"{cutoff:8g} Hz  motion {100 * rows[-1]['motion']:5.1f} %  texture "
              f"{100 * rows[-1]['texture']:5.1f} %  speed MAE {rows[-1]['speed_mae_cm_s']:.2f} "
              f"cm/s  ({rows[-1]['seconds']} s)", flush=True)
    above = [r["cutoff_hz"] for r in rows if r["motion"] >= args.threshold]
    lowest_ok = min(above) if above else None
    print(f"motion accuracy drops under {100 * args.threshold:.0f} % below {lowest_ok:g} Hz"
          if lowest_ok else "motion accuracy is under the threshold at every cut-off")
    record = {"tool_version": __version__, "command": " ".join(sys.argv),
              "config": str(args.config), "epochs": args.epochs,
              "train": [str(p) for p in args.train], "test": str(args.test),
              "threshold": args.threshold, "rows": rows, "lowest_cutoff_ok_hz": lowest_ok}
    args.out_json.parent.mkdir(parents=True, exist_ok=True)
    args.out_json.write_text(json.dumps(record, indent=2) + "\n")
    plot(rows, args.plot, args.threshold, lowest_ok)
    if args.json:
        print(json.dumps(record, indent=2))


def plot(rows: list[dict], path: Path, threshold: float, lowest_ok: float | None) -> None:
    """Fig. 10 of paper 001: accuracy (motion, texture) and speed error against the cut-off
    frequency on a log axis, the threshold line and the lowest cut-off that keeps motion."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    f = [r["cutoff_hz"] for r in rows]
    fig, ax = plt.subplots(figsize=(7, 4.2))
    ax.plot(f, [100 * r["motion"] for r in rows], "o-", label="motion accuracy")
    ax.plot(f, [100 * r["texture"] for r in rows], "s-", label="texture accuracy")
    ax.axhline(100 * threshold, color="grey", ls=":", lw=1)
    if lowest_ok is not None:
        ax.axvline(lowest_ok, color="tab:red", ls="--", lw=1,
                   label=f"motion >= {100 * threshold:.0f} % down to {lowest_ok:g} Hz")
    ax.set_xscale("log", base=2)
    ax.set_xticks(f, [f"{x:g}" for x in f])
    ax.set_xlabel("cut-off frequency (Hz; anti-alias low-pass, then resampled)")
    ax.set_ylabel("accuracy on held-out test segments (%)")
    ax.set_ylim(0, 100)
    right = ax.twinx()
    right.plot(f, [r["speed_mae_cm_s"] for r in rows], "^--", color="tab:green",
               label="speed MAE (cm/s)")
    right.set_ylabel("speed MAE (cm/s)")
    right.set_ylim(bottom=0)
    lines = ax.get_legend_handles_labels()
    more = right.get_legend_handles_labels()
    ax.legend(lines[0] + more[0], lines[1] + more[1], loc="lower right", fontsize=8)
    n = rows[0].get("n_test_windows") if rows else None
    ax.set_title("bandwidth study (paper 001, Fig. 10)" + (f"; {n:,} test windows" if n else ""),
                 fontsize=10)
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=120)
    plt.close(fig)


if __name__ == "__main__":
    main()
