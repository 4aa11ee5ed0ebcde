"""Scaling of ``tactile ingest INPUT... --out-dir DIR`` over Dask workers (issue 18).

Generates ``--inputs`` (64) image-sequence recordings (``tactile_cli.samples``: PNG frames
and a reference frame; ``--distinct`` (4) different seeds are generated and copied to the
other folders, since writing PNGs costs several times their ingest) and ingests them with
``--out-dir`` three ways, each a fresh ``tactile`` process timed end to end (start-up,
cluster start and shut-down included):

- ``--workers 0``: one input after another in the command's process (the reference
  output);
- ``--workers 1`` and ``--workers 2``: a local Dask cluster of that many processes.

Known cost (measured on 12 inputs): a task on a Dask worker takes ~18 % longer than the
same ingest in-process because distributed's nanny starts workers with
``MALLOC_TRIM_THRESHOLD_=65536`` (config ``distributed.nanny.pre-spawn-environ``); the
same variable slows the serial run alike, and leaving it out of that config (after
``import distributed``) brings worker tasks back to the serial time.

Image folders are used because their ingest (PNG decoding, about 0.4 s per folder of 60
frames of 320x240) is CPU-bound and long enough that Dask's per-task overhead does not
dominate.

Reported, as lists aligned with ``workers`` (``[0, 1, 2]``; 0 is the serial run):
``seconds`` (wall time of the command), ``speedup`` (seconds of 1 worker / seconds) and
``efficiency`` (speedup / workers; ``null`` for the serial run), each the fastest of
``--repeats`` (2) runs taken in turn (``all_seconds``: every run, by workers), and
``task_seconds`` (the sum of the tasks' own times in that run: the work, without start-up
and scheduling). Also: ``load_before`` and
``load_after`` (``/proc/loadavg``: 1, 5, 15 minutes), ``cores`` (usable by this process),
``identical`` (every output of every Dask run equals the serial one) and
``excluded_attributes`` (the provenance attributes left out of that check). Target (issue
18): 2 workers at >= 1.7x of 1 worker.

The identity check compares every group and dataset (dtype, shape, values) and every
attribute, except the root attributes ``created_utc`` (when the file was written) and
``command`` (the command line, which names ``--workers`` and the output folder). Outputs
are written under temporary names and renamed, so no temporary name reaches a file.

    .venv/bin/python benchmarks/scale.py [--inputs 64] [--json]
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import h5py
import numpy as np

ROOT = Path(__file__).resolve().parent.parent
TACTILE = str(ROOT / ".venv" / "bin" / "tactile")
EXCLUDED = ["/@created_utc", "/@command"]


def load() -> list[float]:
    return [float(x) for x in Path("/proc/loadavg").read_text().split()[:3]]


def h5_differences(a: Path, b: Path) -> list[str]:
    """Where two HDF5 files differ, apart from the attributes in ``EXCLUDED``."""
    out: list[str] = []
    with h5py.File(a, "r") as fa, h5py.File(b, "r") as fb:
        def walk(ga, gb, path: str) -> None:
            for k in sorted(set(ga.attrs) | set(gb.attrs)):
                if f"{path}@{k}" in EXCLUDED:
                    continue
                if k not in ga.attrs or k not in gb.attrs:
                    out.append(f"{path}@{k} missing")
                elif not np.array_equal(np.asarray(ga.attrs[k]), np.asarray(gb.attrs[k])):
                    out.append(f"{path}@{k}")
            if isinstance(ga, h5py.Dataset):
                if ((ga.dtype, ga.shape) != (gb.dtype, gb.shape)
                        or not np.array_equal(ga[()], gb[()])):
                    out.append(f"{path} data")
                return
            for k in sorted(set(ga) | set(gb)):
                if k not in ga or k not in gb:
                    out.append(f"{path}/{k} missing")
                else:
                    walk(ga[k], gb[k], f"{path.rstrip('/')}/{k}")

        walk(fa, fb, "/")
    return out


def generate(folder: Path, n: int, distinct: int, frames: int) -> list[Path]:
    from tactile_cli.samples import write_image_sequence

    templates = []
    for seed in range(distinct):
        t = folder / "templates" / f"t{seed}"
        write_image_sequence(t, n_frames=frames, width=320, height=240, seed=seed)
        templates.append(t)
    inputs = []
    for i in range(n):
        dst = folder / "raw" / f"rec_{i:02d}"
        shutil.copytree(templates[i % distinct], dst)
        inputs.append(dst)
    return inputs


def run(inputs: list[Path], out: Path, workers: int) -> tuple[float, float]:
    """(wall seconds of the command, sum of the tasks' own seconds) of one fresh run."""
    shutil.rmtree(out, ignore_errors=True)
    cmd = [TACTILE, "ingest", *map(str, inputs), "--out-dir", str(out), "--workers",
           str(workers), "--no-progress", "--json"]
    start = time.perf_counter()
    proc = subprocess.run(cmd, capture_output=True, text=True)
    seconds = time.perf_counter() - start
    if proc.returncode != 0:
        sys.exit(f"workers={workers} failed ({proc.returncode}):\n{proc.stderr[-2000:]}")
    items = json.loads(proc.stdout)["items"]
    return seconds, sum(item["seconds"] or 0.0 for item in items)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--inputs", type=int, default=64)
    ap.add_argument("--distinct", type=int, default=4)
    ap.add_argument("--frames", type=int, default=60)
    ap.add_argument("--repeats", type=int, default=2, help="runs of each; the fastest counts")
    ap.add_argument("--json", action="store_true", help="print the results as JSON")
    args = ap.parse_args()

    with tempfile.TemporaryDirectory(prefix="tactile-scale-") as tmp:
        folder = Path(tmp)
        inputs = generate(folder, args.inputs, args.distinct, args.frames)
        before = load()
        workers = [0, 1, 2]
        runs: dict[int, list[tuple[float, float]]] = {w: [] for w in workers}
        for _ in range(args.repeats):  # interleaved, so a burst of load hits all alike
            for w in workers:
                runs[w].append(run(inputs, folder / f"out_w{w}", w))
        best = {w: min(runs[w]) for w in workers}
        seconds = [best[w][0] for w in workers]
        task_seconds = [best[w][1] for w in workers]
        after = load()
        diffs: list[str] = []
        for w in workers[1:]:
            for src in inputs:
                name = f"{src.name}.h5"
                diffs += [f"w{w}/{name}: {d}" for d in
                          h5_differences(folder / "out_w0" / name, folder / f"out_w{w}" / name)]
    one = seconds[workers.index(1)]
    speedup = [one / s for s in seconds]
    efficiency = [None if w == 0 else sp / w for w, sp in zip(workers, speedup, strict=True)]
    result = {
        "inputs": args.inputs, "format": f"images ({args.frames} PNG frames 320x240)",
        "cores": len(os.sched_getaffinity(0)), "workers": workers, "seconds": seconds,
        "speedup": speedup, "efficiency": efficiency, "task_seconds": task_seconds,
        "all_seconds": {str(w): [r[0] for r in runs[w]] for w in workers}, "load_before": before,
        "load_after": after, "identical": not diffs, "differences": diffs[:20],
        "excluded_attributes": EXCLUDED, "target_speedup_2_workers": 1.7,
    }
    figures = ROOT / "benchmarks" / "figures"
    figures.mkdir(exist_ok=True)
    (figures / "scale.json").write_text(json.dumps(result, indent=2) + "\n")
    if args.json:
        print(json.dumps(result, indent=2))
        return
    print(f"{args.inputs} image folders, {result['cores']} cores; load before "
          f"{before}, after {after}")
    print(f"{'workers':>10} {'seconds':>9} {'speedup':>8} {'efficiency':>10} "
          f"{'task s (sum)':>12}")
    for w, s, sp, e, ts in zip(workers, seconds, speedup, efficiency, task_seconds,
                               strict=True):
        label = "0 (serial)" if w == 0 else str(w)
        print(f"{label:>10} {s:9.2f} {sp:8.2f} {'-' if e is None else f'{e:.2f}':>10} "
              f"{ts:12.2f}")
    print(f"outputs identical to the serial run: {result['identical']} "
          f"(excluded: {', '.join(EXCLUDED)})")
    for d in diffs[:20]:
        print(f"  differs: {d}")


if __name__ == "__main__":
    main()
