"""How much of a cross-validated figure is the seed? One config, one split, several seeds.

The same as ``tactile seed-spread CONFIG --data FILE... --cv K --seeds ... --out FOLDER``
(:func:`tactile_cli.learn.seed_spread.seed_spread`), kept for the records of RESULTS.md:
run folders in a temporary folder unless ``--work``, the record written with ``--record``.

A figure on a small real set can move more with the seed (initial weights, batch order,
a forest's bootstraps) than between the models it is meant to rank: on the 20 GelSight
lifts the shipped CNN-LSTM decides 85 % of an unseen object's lifts at seed 0 and 65-70 % at
seeds 1-4 (benchmarks/RESULTS.md, "Seeds"). This script trains and evaluates a config as
``tactile train CONFIG --data FILE... --cv K --seed S`` and ``tactile evaluate RUN`` do
(:func:`tactile_cli.learn.pipeline.train_run`, :func:`tactile_cli.learn.cv.evaluate_cv`),
once per seed, same folds (the split does not depend on the seed when ``data.split`` is
grouped or blocked; a stratified or random split is drawn from the seed too, and the record
says which), and prints each seed's figures beside their mean, sample SD, min and max:

    .venv/bin/python benchmarks/seed_spread.py configs/train_cnn2d_biotac_texture_zscore.yaml \\
        --data biotac_slide20.h5 --cv 2 --seeds 0 1 2 [--json] [--record out.json]

Figures per seed (the primary head): per-window accuracy and macro F1 of the pooled held-out
folds, and, where the evaluation has them, per-trial majority and mean-probability accuracy.
Keys of ``--json``: ``seeds``, ``by_seed`` (one row per seed), ``summary`` (metric ->
``{"mean", "sd", "min", "max", "spread"}``; ``spread`` = max - min, ``sd`` with ddof 1),
``split_depends_on_seed``. Results do not depend on the thread count: every fold trains on
the config's ``optim.threads`` in this process (``--jobs 1``).
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from tactile_cli.errors import InputError  # noqa: E402
from tactile_cli.learn.seed_spread import METRICS, parse_seeds, seed_spread  # noqa: E402
from tactile_cli.store.atomic import write_json  # noqa: E402


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("config", type=Path, help="a training config (configs/train_*.yaml)")
    ap.add_argument("--data", type=Path, nargs="+", required=True, help="tactile HDF5 files")
    ap.add_argument("--cv", default="5", help="folds (an integer >= 2) or loto")
    ap.add_argument("--seeds", type=int, nargs="+", default=[0, 1, 2])
    ap.add_argument("--work", type=Path, default=None,
                    help="keep the run folders here (default: a temporary folder)")
    ap.add_argument("--record", type=Path, default=None, help="write the record here")
    ap.add_argument("--json", action="store_true", help="print the record as JSON")
    ap.add_argument("--workers", type=int, default=0,
                    help="seeds side by side in local processes (default 0: one after "
                    "another here; the figures are the same)")
    args = ap.parse_args(argv)
    command = (" ".join([Path(sys.argv[0]).name, *sys.argv[1:]]) if argv is None
               else "main(" + " ".join(argv) + ")")
    try:  # bad config, data, --cv or --seeds: one line naming it
        seeds = parse_seeds(args.seeds)
        with tempfile.TemporaryDirectory(prefix="seed_spread_") as tmp:
            work = args.work if args.work is not None else Path(tmp) / "spread"
            result = seed_spread(args.config, args.data, out=work, seeds=seeds, cv=args.cv,
                                 overwrite=True, device="cpu", command=command, plot=False,
                                 latency=False, workers=args.workers, on_seed=lambda r: print(
                                     f"seed {r.seed} done", file=sys.stderr, flush=True))
    except InputError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    record = result.as_dict()
    if args.record is not None:
        write_json(args.record, record, indent=1, overwrite=True)
    if args.json:
        print(json.dumps(record, indent=1))
        return 0
    print(result.table())
    for note in result.notes:
        print(f"note: {note}", file=sys.stderr)
    return 0


__all__ = ["METRICS", "main"]

if __name__ == "__main__":
    raise SystemExit(main())
