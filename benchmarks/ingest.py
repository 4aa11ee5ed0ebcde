"""Event ingest throughput: NPY and CSV into tactile HDF5, against plain baselines.

Measured in one run, on the same N synthetic events (``tactile_cli.samples.events``):

- ceiling: ``numpy.save`` then ``numpy.load`` of the same structured array (13 bytes per
  event), i.e. one raw write and one raw read, the I/O an NPY ingest cannot beat;
- tactile NPY -> HDF5: ``tactile_cli.ingest.ingest`` end to end (checks, compression,
  millisecond index, SHA-256 of the source, schema validation, atomic rename);
- baseline CSV -> HDF5: ``pandas.read_csv`` (C engine, explicit int64 dtypes) of the whole
  file, then h5py writing the same layout (one 1-D dataset per column, same chunks, same
  shuffle + gzip level, ``ms_to_idx``), without checks or validation;
- tactile CSV -> HDF5: ``ingest`` end to end.

Each measurement runs in a fresh child process (its peak RSS is that child's ``VmHWM``,
or ``ru_maxrss`` off Linux), with imports done before the clock starts, and is repeated;
medians are reported. Files sit in the page cache (they were just written) and nothing
is fsync'ed, for the ceiling as for the ingests. Also measured: the
stored size against the raw 13 bytes per event, and a 50 ms window read through
``ms_to_idx`` against a boolean mask over ``t``.

Targets (issue 2): NPY -> HDF5 at >= 50 % of the ceiling; CSV -> HDF5 at least as fast as
the pandas baseline; a 50-million-event ingest well under 24 GB of memory (checked here
as peak RSS < 2 GiB for the tactile ingests).

    .venv/bin/python benchmarks/ingest.py --events 20000000
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

WIDTH, HEIGHT = 640, 480
RAW_BYTES_PER_EVENT = 13  # t int64 + x, y uint16 + p int8
MEMORY_LIMIT_MIB = 2048


# -- the measurements, each run in a child process -------------------------------------------
def _child(kind: str, src: str, out: str, level: int | None) -> dict[str, float]:
    if kind in ("ceiling", "ceiling-fsync"):
        table = np.load(src)
        start = time.perf_counter()
        with open(out, "wb") as f:
            np.save(f, table)
            if kind == "ceiling-fsync":
                f.flush()
                os.fsync(f.fileno())
        back = np.load(out)
        seconds = time.perf_counter() - start
        if back.shape != table.shape:
            raise RuntimeError("numpy round trip changed the array")
    elif kind in ("tactile-npy", "tactile-csv"):
        import pandas  # noqa: F401  (imports off the clock, as for the baseline)

        import tactile_cli.ingest.events_table  # noqa: F401
        from tactile_cli.ingest import ingest
        from tactile_cli.store.writer import Compression

        start = time.perf_counter()
        ingest([src], out, options={"width_px": WIDTH, "height_px": HEIGHT},
               compression=Compression(level), overwrite=True, command="benchmark")
        seconds = time.perf_counter() - start
    elif kind == "pandas-csv":
        seconds = _pandas_baseline(src, out, level)
    else:
        raise ValueError(f"unknown measurement {kind!r}")
    return {"seconds": seconds, "peak_mib": _peak_rss_mib()}


def _peak_rss_mib() -> float:
    """Peak resident memory of this process in MiB.

    Linux carries ``ru_maxrss`` over from the parent through fork and exec, so a child of
    a big parent would report the parent's peak; ``VmHWM`` belongs to this process alone.
    """
    try:
        for line in Path("/proc/self/status").read_text().splitlines():
            if line.startswith("VmHWM:"):
                return int(line.split()[1]) / 1024  # kB
    except OSError:
        pass
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024  # KiB on Linux


def _pandas_baseline(src: str, out: str, level: int | None) -> float:
    import h5py
    import pandas as pd

    from tactile_cli.store.writer import EVENT_CHUNK

    start = time.perf_counter()
    table = pd.read_csv(src, engine="c", dtype=dict.fromkeys("txyp", np.int64))
    comp = {} if level is None else {"compression": "gzip", "compression_opts": level,
                                     "shuffle": True}
    with h5py.File(out, "w", libver="latest") as f:
        g = f.create_group("trials/rec/events")
        for name, dtype in (("x", np.uint16), ("y", np.uint16), ("t", np.int64), ("p", np.int8)):
            g.create_dataset(name, data=table[name].to_numpy().astype(dtype), chunks=(EVENT_CHUNK,),
                             maxshape=(None,), **comp)
        t = table["t"].to_numpy()
        edges = t[0] + 1000 * np.arange((t[-1] - t[0]) // 1000 + 1)
        g.create_dataset("ms_to_idx", data=np.searchsorted(t, edges, side="left"))
        g.attrs["ms_index_origin_us"] = t[0]
    return time.perf_counter() - start


def _measure(kind: str, src: Path, out: Path, level: int | None, repeat: int) -> dict:
    runs = []
    for _ in range(repeat):
        out.unlink(missing_ok=True)
        cmd = [sys.executable, __file__, "--child",
               json.dumps([kind, str(src), str(out), level])]
        done = subprocess.run(cmd, capture_output=True, text=True, check=False)
        if done.returncode != 0:
            raise SystemExit(f"{kind} failed:\n{done.stderr}")
        runs.append(json.loads(done.stdout.strip().splitlines()[-1]))
    seconds = [r["seconds"] for r in runs]
    return {"seconds": statistics.median(seconds), "all_seconds": seconds,
            "peak_mib": max(r["peak_mib"] for r in runs)}


# -- window reads -------------------------------------------------------------------------
def _window_reads(path: Path, n_windows: int = 20, window_ms: int = 50) -> dict[str, float]:
    import h5py

    with h5py.File(path, "r") as f:
        g = f["trials"][next(iter(f["trials"]))]["events"]
        idx = g["ms_to_idx"][()]
        origin = int(g.attrs["ms_index_origin_us"])
        rng = np.random.default_rng(0)
        starts = rng.integers(0, max(1, len(idx) - window_ms), n_windows)
        by_index, by_mask, n_events = [], [], []
        for k in starts.tolist():
            t0 = time.perf_counter()
            lo = int(idx[k])
            hi = int(idx[k + window_ms]) if k + window_ms < len(idx) else g["t"].shape[0]
            fast = {c: g[c][lo:hi] for c in "xytp"}
            by_index.append(time.perf_counter() - t0)
            t0 = time.perf_counter()
            t = g["t"][()]
            mask = (t >= origin + 1000 * k) & (t < origin + 1000 * (k + window_ms))
            hit = np.flatnonzero(mask)
            a, b = (int(hit[0]), int(hit[-1]) + 1) if hit.size else (0, 0)
            slow = {"t": t[mask], **{c: g[c][a:b][mask[a:b]] for c in "xyp"}}
            by_mask.append(time.perf_counter() - t0)
            if any(not np.array_equal(fast[c], slow[c]) for c in "xytp"):
                raise RuntimeError(f"window at {k} ms differs between index and mask")
            n_events.append(hi - lo)
    return {"index_ms": 1e3 * statistics.median(by_index),
            "mask_ms": 1e3 * statistics.median(by_mask),
            "events": statistics.median(n_events)}


def _serial_parts(work: Path) -> dict[str, float]:
    """Seconds of the single-threaded steps every tactile ingest ends or starts with."""
    from tactile_cli.store.provenance import sha256_of
    from tactile_cli.store.validate import validate_file

    out = {}
    for key, step in (("validate_s", lambda: validate_file(work / "npy.h5")),
                      ("sha_npy_s", lambda: sha256_of(work / "rec.npy")),
                      ("sha_csv_s", lambda: sha256_of(work / "rec.csv"))):
        start = time.perf_counter()
        step()
        out[key] = time.perf_counter() - start
    return out


def _same_events(paths: list[Path], truth: dict[str, np.ndarray]) -> bool:
    import h5py

    for path in paths:
        with h5py.File(path, "r") as f:
            g = f["trials"][next(iter(f["trials"]))]["events"]
            for c in "xytp":
                if not np.array_equal(g[c][()], truth[c]):
                    return False
    return True


# -- driver ------------------------------------------------------------------------------------
def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(
        description="Events/s of NPY and CSV ingest into tactile HDF5 against numpy.save/load "
                    "(the disk ceiling) and pandas.read_csv + h5py (the CSV baseline).")
    parser.add_argument("--events", type=int, default=20_000_000,
                        help="events to generate (default 20,000,000; 50,000,000 shows peak "
                             "memory of a long recording)")
    parser.add_argument("--compression", type=int, default=1,
                        help="gzip level 0-9 for tactile and the pandas baseline, -1 for none "
                             "(default 1, the CLI default)")
    parser.add_argument("--repeat", type=int, default=3,
                        help="runs per measurement; medians are reported (default 3)")
    parser.add_argument("--workdir", type=Path, default=None,
                        help="folder for the generated files (default: a temporary folder)")
    parser.add_argument("--keep", action="store_true", help="keep the generated files")
    parser.add_argument("--child", help=argparse.SUPPRESS)
    args = parser.parse_args(argv)
    if args.child:
        kind, src, out, level = json.loads(args.child)
        print(json.dumps(_child(kind, src, out, level)))
        return

    from tactile_cli.samples.events import write_events_csv, write_events_npy

    level = None if args.compression < 0 else args.compression
    n = args.events
    work = args.workdir or Path(tempfile.mkdtemp(prefix="tactile-bench-"))
    work.mkdir(parents=True, exist_ok=True)
    cpus = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count()
    print(f"events {n:,}, gzip level {level}, {args.repeat} runs each, {cpus} CPUs, "
          f"load average {os.getloadavg()[0]:.2f} at start; files in {work}")
    try:
        t0 = time.perf_counter()
        truth = write_events_npy(work / "rec.npy", n, width=WIDTH, height=HEIGHT, seed=0)
        write_events_csv(work / "rec.csv", n, width=WIDTH, height=HEIGHT, seed=0)
        print(f"generated in {time.perf_counter() - t0:.1f} s: NPY "
              f"{(work / 'rec.npy').stat().st_size / 1e6:,.0f} MB, CSV "
              f"{(work / 'rec.csv').stat().st_size / 1e6:,.0f} MB")

        # the ceiling is cheap and the noisiest (page-cache writeback): more runs
        results = {
            "ceiling": _measure("ceiling", work / "rec.npy", work / "copy.npy", level,
                                max(5, args.repeat)),
            "ceiling-fsync": _measure("ceiling-fsync", work / "rec.npy", work / "copy.npy",
                                      level, max(5, args.repeat)),
            "tactile-npy": _measure("tactile-npy", work / "rec.npy", work / "npy.h5", level,
                                    args.repeat),
            "pandas-csv": _measure("pandas-csv", work / "rec.csv", work / "pandas.h5", level,
                                   args.repeat),
            "tactile-csv": _measure("tactile-csv", work / "rec.csv", work / "csv.h5", level,
                                    args.repeat),
        }
        same = _same_events([work / "npy.h5", work / "csv.h5", work / "pandas.h5"], truth)
        window = _window_reads(work / "npy.h5")
        stored = (work / "npy.h5").stat().st_size
        serial = _serial_parts(work)
        load_end = os.getloadavg()[0]
    finally:
        if not args.keep and args.workdir is None:
            shutil.rmtree(work, ignore_errors=True)

    print(f"\n{'measurement':<34}{'median s':>10}{'Mevents/s':>11}{'peak MiB':>10}  runs (s)")
    labels = {"ceiling": "numpy.save + numpy.load (ceiling)",
              "ceiling-fsync": "  the same with fsync (context)",
              "tactile-npy": "tactile NPY -> HDF5",
              "pandas-csv": "pandas.read_csv + h5py (baseline)",
              "tactile-csv": "tactile CSV -> HDF5"}
    rate = {}
    for key, r in results.items():
        rate[key] = n / r["seconds"]
        runs = ", ".join(f"{s:.2f}" for s in r["all_seconds"])
        print(f"{labels[key]:<34}{r['seconds']:>10.2f}{rate[key] / 1e6:>11.2f}"
              f"{r['peak_mib']:>10.0f}  {runs}")
    npy_ratio = rate["tactile-npy"] / rate["ceiling"]
    csv_ratio = rate["tactile-csv"] / rate["pandas-csv"]
    peak = max(results["tactile-npy"]["peak_mib"], results["tactile-csv"]["peak_mib"])
    verdict = {True: "PASS", False: "FAIL"}
    print(f"\nNPY -> HDF5 / ceiling     {100 * npy_ratio:6.1f} %   target >= 50 %   "
          f"{verdict[npy_ratio >= 0.5]}")
    print(f"CSV -> HDF5 / pandas      {100 * csv_ratio:6.1f} %   target >= 100 %  "
          f"{verdict[csv_ratio >= 1.0]}")
    print(f"tactile peak RSS          {peak:6.0f} MiB  target < {MEMORY_LIMIT_MIB} MiB "
          f"{verdict[peak < MEMORY_LIMIT_MIB]}")
    print(f"stored size / raw {RAW_BYTES_PER_EVENT} B per event: "
          f"{stored / (RAW_BYTES_PER_EVENT * n):.3f} ({stored / n:.2f} B per event)")
    print(f"all three HDF5 files hold the generated events exactly: {same}")
    print(f"single-threaded steps: full `tactile validate` of the output "
          f"{serial['validate_s']:.2f} s (the ingest's own commit validates the structure and "
          f"skips re-reading event columns its appender checked), SHA-256 of the source "
          f"{serial['sha_npy_s']:.2f} s (NPY) / {serial['sha_csv_s']:.2f} s (CSV)")
    print(f"50 ms window ({window['events']:,.0f} events): ms_to_idx {window['index_ms']:.2f} ms, "
          f"boolean mask over t {window['mask_ms']:.1f} ms "
          f"({window['mask_ms'] / window['index_ms']:.0f}x slower)")
    print(f"load average at end {load_end:.2f} (other processes on the machine skew timings)")


if __name__ == "__main__":
    main()
