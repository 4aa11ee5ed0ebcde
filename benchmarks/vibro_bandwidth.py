"""Bandwidth study of paper 001, sec. 6.4 (issue 14, item 5): motion/texture accuracy of one
model as the accelerations' cut-off is halved from 4 kHz to 31.25 Hz.

For every cut-off: ``tactile_cli.accel.prepare.prepare_file(cutoff_hz=...)`` on the training
scene and on a held-out scene (another seed), train the config on the first, evaluate on
the held-out scene's test split. Prints a table, the cut-off below which motion accuracy
drops under 80 %, and with --json the rows.

    .venv/bin/python benchmarks/vibro_bandwidth.py --train scene0.h5 --test scene1.h5 \
        --config configs/train_cnn2d_vibro.yaml --epochs 20 --work /tmp/bw

(scene*.h5: `tactile ingest <tree> --format accel-tree` of `tactile simulate vibro-slip`.)
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

from tactile_cli.accel.prepare import prepare_file
from tactile_cli.learn import evaluate, load_config, train
from tactile_cli.spectral import bandwidth_steps


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--train", type=Path, required=True)
    ap.add_argument("--test", type=Path, required=True)
    ap.add_argument("--config", type=Path, default=Path("configs/train_cnn2d_vibro.yaml"))
    ap.add_argument("--epochs", type=int, default=None)
    ap.add_argument("--work", type=Path, required=True)
    ap.add_argument("--threshold", type=float, default=0.80)
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args()
    args.work.mkdir(parents=True, exist_ok=True)
    cfg = load_config(args.config).with_overrides(epochs=args.epochs)
    rows = []
    for cutoff in bandwidth_steps(8000.0):
        started = time.perf_counter()
        tag = f"{cutoff:g}Hz"
        cut = None if cutoff >= 4000 else cutoff
        tr = prepare_file(args.train, args.work / f"train_{tag}.h5", cutoff_hz=cut,
                          overwrite=True).out
        te = prepare_file(args.test, args.work / f"test_{tag}.h5", cutoff_hz=cut,
                          overwrite=True).out
        run = args.work / f"run_{tag}"
        train(cfg, [tr], run, overwrite=True)
        res = evaluate(run, [te], split="test", latency=False, overwrite=True)
        heads = res.as_dict()["heads"]
        rows.append({"cutoff_hz": cutoff, "motion": heads["motion"]["accuracy"],
                     "texture": heads["object"]["accuracy"],
                     "speed_mae_cm_s": heads["speed_cm_s"]["mae"],
                     "seconds": round(time.perf_counter() - started, 1)})
        print(f"{cutoff:8g} Hz  motion {100 * rows[-1]['motion']:5.1f} %  texture "
              f"{100 * rows[-1]['texture']:5.1f} %  speed MAE {rows[-1]['speed_mae_cm_s']:.2f} "
              f"cm/s  ({rows[-1]['seconds']} s)", flush=True)
    above = [r["cutoff_hz"] for r in rows if r["motion"] >= args.threshold]
    lowest_ok = min(above) if above else None
    print(f"motion accuracy drops under {100 * args.threshold:.0f} % below {lowest_ok:g} Hz"
          if lowest_ok else "motion accuracy is under the threshold at every cut-off")
    if args.json:
        print(json.dumps({"rows": rows, "lowest_cutoff_ok_hz": lowest_ok}, indent=2))


if __name__ == "__main__":
    main()
