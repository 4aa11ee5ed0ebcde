"""Does a texture figure hold on later recordings, beyond the seed? BioTac, by recording order.

The BioTac sliding set (Gao et al., IROS 2020; ../shared/data/biotac_slide20) has 10
recordings per material, numbered in the order they were made. This script splits them
into three sessions by that number, the same for every material: ``early`` (1-5) to train
on, ``middle`` (6-7) to score the spread on, ``late`` (8-10) that nothing was chosen on. For
each config it runs, as a user would:

    tactile ingest SESSION_TREE --mapping configs/biotac_slide20.yaml --out SESSION.h5
    tactile seed-spread CONFIG --data early.h5 --eval-data middle.h5 --seeds 0-4 --out S
    tactile evaluate S --data late.h5 --json

and prints, per config, the seeds' mean and SD of the per-trial (majority) and per-window
accuracy on ``middle`` and on ``late`` and the change. Each session is a folder of links to
the original files, so the three HDF5 files hold disjoint recordings.

    .venv/bin/python benchmarks/texture_later_session.py [--seeds 0-4] [--work DIR]
        [--json] [--record out.json]

Keys of ``--json``: ``sessions`` (name -> recording numbers), ``configs`` (one row each:
``config``, ``middle`` and ``late`` summaries as ``tactile evaluate SPREAD`` writes them,
``against_own``), ``command``. The configs and their settings were chosen at earlier stops
on blocked CV of samples 1-5 against 6-10 of this same set, so ``middle`` overlaps what
they were chosen on; ``late`` (8-10) was part of that CV too, so neither is a held-out
result: the figure this measures is the change from one block of recordings to a later one,
with the seeds' spread beside it.
"""

from __future__ import annotations

import argparse
import json
import re
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
SOURCE = ROOT.parent / "shared" / "data" / "biotac_slide20"
MAPPING = ROOT / "configs" / "biotac_slide20.yaml"
CONFIGS = ("configs/train_cnn2d_biotac_texture_zscore.yaml",
           "configs/train_mlp_biotac_texture_nolevel.yaml")
SESSIONS = {"early": range(1, 6), "middle": range(6, 8), "late": range(8, 11)}
NAME = re.compile(r"^(mat\d+)_(\d+)_(bio|cw|cv)\.csv$")


def session_tree(source: Path, dest: Path, samples: range) -> int:
    """Links to every file of recordings ``samples`` of each material under ``dest``
    (``matM/matM_N_*.csv``); returns the number of recordings linked."""
    n = 0
    for f in sorted(source.glob("mat*/*.csv")):
        m = NAME.match(f.name)
        if m and int(m[2]) in samples:
            (dest / m[1]).mkdir(parents=True, exist_ok=True)
            (dest / m[1] / f.name).symlink_to(f.resolve())
            n += m[3] == "bio"
    return n


def tactile(*args: str) -> str:
    out = subprocess.run([sys.executable, "-m", "tactile_cli", *args], cwd=ROOT,
                         capture_output=True, text=True)
    if out.returncode != 0:
        raise SystemExit(f"tactile {' '.join(args)}: {out.stderr.strip()}")
    return out.stdout


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--source", type=Path, default=SOURCE)
    ap.add_argument("--configs", nargs="+", default=list(CONFIGS))
    ap.add_argument("--seeds", default="0-4")
    ap.add_argument("--workers", default="2", help="seeds side by side (same figures)")
    ap.add_argument("--work", type=Path, default=None, help="keep the files here")
    ap.add_argument("--record", type=Path, default=None, help="write the record here")
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args(argv)
    if not args.source.is_dir():
        print(f"{args.source}: not found (the BioTac recordings)", file=sys.stderr)
        return 2
    work = args.work or Path(tempfile.mkdtemp(prefix="texture_later_"))
    files = {}
    for name, samples in SESSIONS.items():
        h5 = work / f"{name}.h5"
        if not h5.exists():
            n = session_tree(args.source, work / name, samples)
            tactile("ingest", str(work / name), "--mapping", str(MAPPING), "--out", str(h5),
                    "--no-progress")
            print(f"{name}: recordings {samples.start}-{samples.stop - 1}, {n} trials",
                  file=sys.stderr)
        files[name] = h5
    rows = []
    for config in args.configs:
        out = work / f"spread_{Path(config).stem}"
        if not out.exists():
            tactile("seed-spread", config, "--data", str(files["early"]), "--eval-data",
                    str(files["middle"]), "--seeds", args.seeds, "--workers", args.workers,
                    "--out", str(out), "--no-progress", "--no-plot")
        own = json.loads((out / "seed_spread.json").read_text())
        later = json.loads(tactile("evaluate", str(out), "--data", str(files["late"]),
                                   "--overwrite", "--json"))
        rows.append({"config": config, "seeds": own["seeds"], "middle": own["summary"],
                     "late": later["summary"], "against_own": later["against_own"],
                     "n_trials": {"middle": own["by_seed"][0]["n_trials"],
                                  "late": later["by_seed"][0]["n_trials"]}})
    record = {"sessions": {k: [v.start, v.stop - 1] for k, v in SESSIONS.items()},
              "configs": rows, "work": str(work),
              "command": " ".join([Path(sys.argv[0]).name, *sys.argv[1:]])}
    if args.record:
        args.record.write_text(json.dumps(record, indent=2) + "\n")
    if args.json:
        print(json.dumps(record, indent=2))
        return 0
    print("| config | metric | middle (6-7): mean (SD) | late (8-10): mean (SD) | change |")
    print("|---|---|---:|---:|---:|")
    for r in rows:
        for metric in ("trial_majority_accuracy", "window_accuracy"):
            a, b = r["middle"].get(metric), r["late"].get(metric)
            if a is None or b is None:
                continue
            print(f"| {Path(r['config']).stem} | {metric} | {100 * a['mean']:.1f} % "
                  f"({100 * a['sd']:.1f}) | {100 * b['mean']:.1f} % ({100 * b['sd']:.1f}) | "
                  f"{100 * (b['mean'] - a['mean']):+.1f} pp |")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
