"""Group square coherence speed: tactile's vectorised G2 against a scipy pair loop.

Issue 15, item 6 (paper 004's timing setting): G2 per Welch bin of windows of 20 channels x
1024 samples (Hann segments of 256 samples, 128 overlap: 7 segments, 129 bins), computed

- by ``tactile_cli.spectral``: batched over ``--batch`` windows
  (:func:`group_square_coherence_windows`: chunks of 128 windows whose 128 x 129 largest
  eigenvalues are found in one vectorised call, Householder + Laguerre, one thread; two
  threads beside it), and one window alone as a real-time caller does
  (``group_square_coherence_windows(x[None])``, which solves 129 matrices with LAPACK;
  also :func:`segment_spectra` + :func:`group_square_coherence_bins`), and
- by a straightforward loop in the same run: ``scipy.signal.csd`` for every channel pair
  (the N x N CSD matrix), the coherence matrix, ``numpy.linalg.eigh`` per bin.

Both take the same windows (independent noise plus a common source of random strength per
window); the results must agree to 1e-9 (``max_abs_diff``; ``max_abs_diff_lapack``: the
whole batch against the LAPACK ``eigvalsh`` path). Timings: best and median of
``--repeats`` (and of 6 x ``--repeats`` calls of one 128-window chunk), with the 1-min
load average before and after (shared machine). Also reported: the segment count against
the channel count (rank-deficient here: 7 < 20) and the G2 noise floor that this causes
(mean G2 of independent noise with 7 and with 63 segments).

    .venv/bin/python benchmarks/coherence.py [--batch 256] [--loop-windows 5] [--json [F]]
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import time

import numpy as np

N_CHANNELS, N_SAMPLES, NPERSEG, NOVERLAP, RATE_HZ = 20, 1024, 256, 128, 1000.0
CHUNK = 128


def windows(n: int, seed: int = 0) -> np.ndarray:
    """(n, 1024, 20) noise plus a common source of random strength per window."""
    rng = np.random.default_rng(seed)
    common = rng.standard_normal((n, N_SAMPLES, 1)) * rng.uniform(0, 2, (n, 1, 1))
    return rng.standard_normal((n, N_SAMPLES, N_CHANNELS)) + common


def loop_g2(x: np.ndarray) -> np.ndarray:
    """(1024, 20) -> (129,) G2 per bin: scipy.signal.csd per pair, eigh per bin."""
    from scipy.signal import csd

    n = x.shape[1]
    s = None
    for i in range(n):
        for j in range(i, n):
            f, p = csd(x[:, i], x[:, j], fs=RATE_HZ, nperseg=NPERSEG, noverlap=NOVERLAP)
            if s is None:
                s = np.zeros((len(f), n, n), dtype=np.complex128)
            s[:, i, j] = p
            s[:, j, i] = np.conj(p)
    out = np.empty(s.shape[0])
    for k in range(s.shape[0]):
        d = np.sqrt(np.real(np.diag(s[k])))
        c = s[k] / np.outer(d, d)
        lam1 = np.linalg.eigh(c)[0][-1]
        out[k] = ((lam1 - 1) / (n - 1)) ** 2
    return out


def tactile_g2(x: np.ndarray) -> np.ndarray:
    """One window (1024, 20) -> (129,): the real-time call."""
    from tactile_cli.spectral import group_square_coherence_windows

    return group_square_coherence_windows(x[None], RATE_HZ, nperseg=NPERSEG,
                                          noverlap=NOVERLAP)[1][0]


def tactile_g2_bins(x: np.ndarray) -> np.ndarray:
    """One window (1024, 20) -> (129,): segment spectra + G2 per bin (LAPACK per bin)."""
    from tactile_cli.spectral import group_square_coherence_bins, segment_spectra

    _, spectra = segment_spectra(x, RATE_HZ, nperseg=NPERSEG, noverlap=NOVERLAP)
    return group_square_coherence_bins(spectra)


def tactile_g2_batch(x: np.ndarray, workers: int, method: str = "auto") -> np.ndarray:
    """(n, 1024, 20) -> (n, 129): the library's batched path (chunks of 128 windows)."""
    from tactile_cli.spectral import group_square_coherence_windows

    return group_square_coherence_windows(x, RATE_HZ, nperseg=NPERSEG, noverlap=NOVERLAP,
                                          chunk=CHUNK, workers=workers, method=method)[1]


def timings(fn, repeats: int) -> tuple[float, float]:
    """Best and median wall time (s) of ``repeats`` calls."""
    t = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        fn()
        t.append(time.perf_counter() - t0)
    return min(t), float(np.median(t))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--batch", type=int, default=256, help="windows per batched call")
    ap.add_argument("--loop-windows", type=int, default=5, help="windows timed in the loop")
    ap.add_argument("--repeats", type=int, default=7)
    ap.add_argument("--json", nargs="?", const="-", default=None, metavar="F",
                    help="print JSON (and write it to F when given)")
    args = ap.parse_args()

    from tactile_cli.spectral import g2_noise_floor, welch_segment_count

    x = windows(args.batch)
    load_before = os.getloadavg()[0]
    tactile_g2_batch(x[:2], 1)                                   # warm caches
    batched_s, batched_med = timings(lambda: tactile_g2_batch(x, 1), args.repeats)
    threaded_s, threaded_med = timings(lambda: tactile_g2_batch(x, 2), args.repeats)
    lapack_s, _ = timings(lambda: tactile_g2_batch(x, 1, "eigvalsh"), args.repeats)
    # one chunk of 128 windows per call, many calls: the best catches a quiet core on a
    # shared machine (a 256-window call of ~0.15 s rarely does)
    part = x[:CHUNK]
    chunk_s, chunk_med = timings(lambda: tactile_g2_batch(part, 1), 6 * args.repeats)
    chunk_lapack_s, _ = timings(lambda: tactile_g2_batch(part, 1, "eigvalsh"),
                                6 * args.repeats)
    single_s, single_med = timings(lambda: tactile_g2(x[0]), 20 * args.repeats)
    bins_s, _ = timings(lambda: tactile_g2_bins(x[0]), 20 * args.repeats)
    load_after = os.getloadavg()[0]
    ours = tactile_g2_batch(x, 1)
    assert np.array_equal(ours, tactile_g2_batch(x, 2))
    lapack = tactile_g2_batch(x, 1, "eigvalsh")
    t0 = time.perf_counter()
    ref = np.stack([loop_g2(w) for w in x[:args.loop_windows]])
    loop_s = (time.perf_counter() - t0) / args.loop_windows
    diff = float(np.abs(ours[:args.loop_windows] - ref).max())
    single_diff = float(np.abs(tactile_g2(x[0]) - ref[0]).max())
    n_seg = welch_segment_count(N_SAMPLES, NPERSEG, NOVERLAP)
    per_window = batched_s / args.batch
    result = {
        "tactile_ms_per_window": round(1e3 * per_window, 4),
        "tactile_ms_per_window_median": round(1e3 * batched_med / args.batch, 4),
        "loop_ms_per_window": round(1e3 * loop_s, 3),
        "ratio": round(loop_s / per_window, 1),
        "max_abs_diff": max(diff, single_diff),
        "agree_1e-9": max(diff, single_diff) <= 1e-9,
        "max_abs_diff_lapack": float(np.abs(ours - lapack).max()),
        "batch_windows": args.batch, "batch_chunk": CHUNK, "threads": 1,
        "repeats": args.repeats,
        "tactile_ms_per_window_2_threads": round(1e3 * threaded_s / args.batch, 4),
        "tactile_ms_per_window_2_threads_median": round(1e3 * threaded_med / args.batch, 4),
        "lapack_path_ms_per_window": round(1e3 * lapack_s / args.batch, 4),
        "chunk_calls": {"windows_per_call": len(part), "calls": 6 * args.repeats,
                        "tactile_ms_per_window_best": round(1e3 * chunk_s / len(part), 4),
                        "tactile_ms_per_window_median": round(1e3 * chunk_med / len(part), 4),
                        "lapack_path_ms_per_window_best":
                            round(1e3 * chunk_lapack_s / len(part), 4)},
        "single_window_ms": round(1e3 * single_s, 4),
        "single_window_ms_median": round(1e3 * single_med, 4),
        "single_window_ratio": round(loop_s / single_s, 1),
        "single_window_bins_path_ms": round(1e3 * bins_s, 4),
        "load_1min_before_after": [round(load_before, 2), round(load_after, 2)],
        "channels": N_CHANNELS, "samples": N_SAMPLES, "nperseg": NPERSEG,
        "noverlap": NOVERLAP, "segments": n_seg, "rank_deficient": n_seg < N_CHANNELS,
        "g2_noise_floor_7_segments": round(g2_noise_floor(N_CHANNELS, n_seg), 4),
        "g2_noise_floor_63_segments": round(g2_noise_floor(N_CHANNELS, 63), 4),
        "target_ms_per_window": 0.5, "target_ratio": 100,
        "machine": f"{platform.machine()}, {platform.python_version()}, numpy "
                   f"{np.__version__}",
    }
    if args.json is not None:
        text = json.dumps(result, indent=2)
        if args.json != "-":
            with open(args.json, "w") as fh:
                fh.write(text + "\n")
        print(text)
        return
    for k, v in result.items():
        print(f"{k:28s} {v}")


if __name__ == "__main__":
    main()
