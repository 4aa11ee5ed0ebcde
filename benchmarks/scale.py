"""Scaling of the batch commands over Dask workers (issue 18): ``--job ingest`` (default),
``--job sweep`` or ``--job all``.

**ingest** (``tactile ingest INPUT... --out-dir DIR``): generates ``--inputs`` (64)
image-sequence recordings (``tactile_cli.samples``: PNG frames and a reference frame;
``--distinct`` (4) different seeds are generated and copied to the other folders, since
writing PNGs costs several times their ingest) and ingests them with ``--out-dir`` three
ways, each a fresh ``tactile`` process timed end to end (start-up, cluster start and
shut-down included):

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

**sweep** (``tactile sweep``): a 16-run grid (spectrogram CNN and FNN x windows 400 and
100 x channel sets L3R3, L3, LxRx, Lx; ``--epochs`` (5) each with early-stopping patience
3, the settings of the full grid in configs/sweep_vibro.yaml) trained on one simulated
vibro-slip scene (seed 0, 2 s per recording, 0.5 s segments) and evaluated on the held-out
segments of another (seed 1), timed the same three ways. ``identical``: every run's weights
(``model.pt``, every tensor) and held-out metrics (every head) equal the serial run's.

With ``--job all`` the JSON holds ``{"ingest": {...}, "sweep": {...}}``, each with the
keys above; figures/scale.json (ingest) and figures/scale_sweep.json (sweep) keep them.

    .venv/bin/python benchmarks/scale.py [--job ingest|sweep|all] [--inputs 64] [--json]
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


def run_ingest(inputs: list[Path], out: Path, workers: int) -> tuple[float, float]:
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


SWEEP_YAML = """version: 1
name: scale16
train_data: [{train}]
eval: {{data: [{test}], split: test}}
models:
  cnn2d:
    config: {root}/configs/train_cnn2d_vibro.yaml
    by_window:
      400: {{model.n_fft: 40, model.hop: 20}}
      100: {{model.n_fft: 20, model.hop: 10}}
  fnn: {{config: {root}/configs/train_fnn_vibro.yaml}}
windows:
  - {{window: 400, stride: 200}}
  - {{window: 100, stride: 50}}
channel_sets: [L3R3, L3, LxRx, Lx]
overrides: {{optim.epochs: {epochs}, optim.patience: 3}}
"""


def sweep_data(folder: Path) -> tuple[Path, Path]:
    """Prepared vibro-slip scenes of seeds 0 (train) and 1 (test), as `make demo-accel`."""
    from tactile_cli.accel import VibroSceneConfig, simulate_vibro_slip
    from tactile_cli.accel.prepare import prepare_file
    from tactile_cli.ingest import ingest

    out = []
    for seed in (0, 1):
        scene = folder / f"scene{seed}"
        simulate_vibro_slip(VibroSceneConfig.model_validate({"duration_s": 2.0}), scene,
                            seed=seed)
        raw = ingest([scene], folder / f"scene{seed}.h5",
                     format="accel-tree",
                     labels={"origin": "simulated", "dataset": f"vibro-slip seed {seed}"})
        out.append(prepare_file(raw, folder / f"prepared{seed}.h5", segment_s=0.5).out)
    return out[0], out[1]


def run_sweep(sweep: Path, out: Path, workers: int) -> tuple[float, float]:
    """(wall seconds of the command, sum of the runs' training seconds) of one fresh sweep."""
    shutil.rmtree(out, ignore_errors=True)
    cmd = [TACTILE, "sweep", str(sweep), "--out", str(out), "--workers", str(workers),
           "--no-progress", "--json"]
    start = time.perf_counter()
    proc = subprocess.run(cmd, capture_output=True, text=True)
    seconds = time.perf_counter() - start
    if proc.returncode != 0:
        sys.exit(f"sweep workers={workers} failed ({proc.returncode}):\n{proc.stderr[-2000:]}")
    rows = json.loads(proc.stdout)["rows"]
    if any(r["status"] != "ok" for r in rows):
        sys.exit(f"sweep workers={workers}: a run did not finish: {rows}")
    return seconds, sum(r.get("train_s") or 0.0 for r in rows)


def run_differences(a: Path, b: Path) -> list[str]:
    """Where two sweeps' run folders differ: weights (every tensor) and metrics (heads)."""
    import torch

    out = []
    for run in sorted(p for p in (a / "runs").iterdir() if p.is_dir()):
        other = b / "runs" / run.name
        wa = torch.load(run / "model.pt", weights_only=True)
        wb = torch.load(other / "model.pt", weights_only=True)
        if wa.keys() != wb.keys() or any(not torch.equal(wa[k], wb[k]) for k in wa):
            out.append(f"{run.name}: weights")
        ma = [json.loads(m.read_text())["heads"] for m in sorted(run.glob("eval/*/metrics.json"))]
        mb = [json.loads(m.read_text())["heads"]
              for m in sorted(other.glob("eval/*/metrics.json"))]
        if ma != mb:
            out.append(f"{run.name}: metrics")
    return out


def measure(job: str, args: argparse.Namespace, folder: Path) -> dict:
    workers = [0, 1, 2]
    runs: dict[int, list[tuple[float, float]]] = {w: [] for w in workers}
    if job == "ingest":
        inputs = generate(folder, args.inputs, args.distinct, args.frames)
        one_run = lambda w: run_ingest(inputs, folder / f"out_w{w}", w)  # noqa: E731
    else:
        train, test = sweep_data(folder)
        sweep = folder / "scale16.yaml"
        sweep.write_text(SWEEP_YAML.format(train=train, test=test, root=ROOT,
                                           epochs=args.epochs))
        one_run = lambda w: run_sweep(sweep, folder / f"sweep_w{w}", w)  # noqa: E731
    before = load()
    for _ in range(args.repeats):  # interleaved, so a burst of load hits all alike
        for w in workers:
            runs[w].append(one_run(w))
    best = {w: min(runs[w]) for w in workers}
    seconds = [best[w][0] for w in workers]
    task_seconds = [best[w][1] for w in workers]
    after = load()
    diffs: list[str] = []
    for w in workers[1:]:
        if job == "ingest":
            for src in inputs:
                name = f"{src.name}.h5"
                diffs += [f"w{w}/{name}: {d}" for d in
                          h5_differences(folder / "out_w0" / name, folder / f"out_w{w}" / name)]
        else:
            diffs += [f"w{w}/{d}" for d in
                      run_differences(folder / "sweep_w0", folder / f"sweep_w{w}")]
    one = seconds[workers.index(1)]
    speedup = [one / s for s in seconds]
    efficiency = [None if w == 0 else sp / w for w, sp in zip(workers, speedup, strict=True)]
    what = ({"inputs": args.inputs, "format": f"images ({args.frames} PNG frames 320x240)"}
            if job == "ingest" else
            {"runs": 16, "grid": "cnn2d, fnn x windows 400, 100 x L3R3, L3, LxRx, Lx",
             "epochs": args.epochs})
    return {
        "job": job, **what,
        "cores": len(os.sched_getaffinity(0)), "workers": workers, "seconds": seconds,
        "speedup": speedup, "efficiency": efficiency, "task_seconds": task_seconds,
        "all_seconds": {str(w): [r[0] for r in runs[w]] for w in workers}, "load_before": before,
        "load_after": after, "identical": not diffs, "differences": diffs[:20],
        "excluded_attributes": EXCLUDED if job == "ingest" else [],
        "target_speedup_2_workers": 1.7,
    }


def show(result: dict) -> None:
    if result["job"] == "ingest":
        print(f"ingest: {result['inputs']} image folders, {result['cores']} cores; load before "
              f"{result['load_before']}, after {result['load_after']}")
    else:
        print(f"sweep: {result['runs']} runs ({result['grid']}, {result['epochs']} epochs), "
              f"{result['cores']} cores; load before {result['load_before']}, after "
              f"{result['load_after']}")
    print(f"{'workers':>10} {'seconds':>9} {'speedup':>8} {'efficiency':>10} "
          f"{'task s (sum)':>12}")
    for w, s, sp, e, ts in zip(result["workers"], result["seconds"], result["speedup"],
                               result["efficiency"], result["task_seconds"], strict=True):
        label = "0 (serial)" if w == 0 else str(w)
        print(f"{label:>10} {s:9.2f} {sp:8.2f} {'-' if e is None else f'{e:.2f}':>10} "
              f"{ts:12.2f}")
    excluded = ", ".join(result["excluded_attributes"]) or "nothing"
    print(f"outputs identical to the serial run: {result['identical']} (excluded: {excluded})")
    for d in result["differences"]:
        print(f"  differs: {d}")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--job", choices=["ingest", "sweep", "all"], default="ingest")
    ap.add_argument("--inputs", type=int, default=64, help="ingest: recordings")
    ap.add_argument("--distinct", type=int, default=4)
    ap.add_argument("--frames", type=int, default=60)
    ap.add_argument("--epochs", type=int, default=5,
                    help="sweep: epochs per run (patience 3, as configs/sweep_vibro.yaml)")
    ap.add_argument("--repeats", type=int, default=2, help="runs of each; the fastest counts")
    ap.add_argument("--json", action="store_true", help="print the results as JSON")
    args = ap.parse_args()

    jobs = ["ingest", "sweep"] if args.job == "all" else [args.job]
    results = {}
    figures = ROOT / "benchmarks" / "figures"
    figures.mkdir(exist_ok=True)
    for job in jobs:
        with tempfile.TemporaryDirectory(prefix=f"tactile-scale-{job}-") as tmp:
            results[job] = measure(job, args, Path(tmp))
        name = "scale.json" if job == "ingest" else "scale_sweep.json"
        (figures / name).write_text(json.dumps(results[job], indent=2) + "\n")
    if args.json:
        print(json.dumps(results if len(jobs) > 1 else results[jobs[0]], indent=2))
        return
    for job in jobs:
        show(results[job])


if __name__ == "__main__":
    main()
