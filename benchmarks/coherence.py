"""Group square coherence speed: tactile's vectorised G2 against a scipy pair loop.

Issue 15, item 6 (paper 004's timing setting): G2 per Welch bin of windows of 20 channels x
1024 samples (Hann segments of 256 samples, 128 overlap: 7 segments, 129 bins), computed

- by ``tactile_cli.spectral``: batched over ``--batch`` windows
  (:func:`group_square_coherence_windows`, chunks of 16, one thread; two threads beside
  it), and one window alone as a real-time caller does (:func:`segment_spectra` +
  :func:`group_square_coherence_bins`), and
- by a straightforward loop in the same run: ``scipy.signal.csd`` for every channel pair
  (the N x N CSD matrix), the coherence matrix, ``numpy.linalg.eigh`` per bin.

Both take the same windows (independent noise plus a common source of random strength per
window); the results must agree to 1e-9 (``max_abs_diff``). Also reported: the segment
count against the channel count (rank-deficient here: 7 < 20) and the G2 noise floor that
this causes (mean G2 of independent noise with 7 and with 63 segments).

    .venv/bin/python benchmarks/coherence.py [--batch 256] [--loop-windows 5] [--json]
"""

from __future__ import annotations

import argparse
import json
import platform
import time

import numpy as np

N_CHANNELS, N_SAMPLES, NPERSEG, NOVERLAP, RATE_HZ = 20, 1024, 256, 128, 1000.0


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
    """One window (1024, 20) -> (129,): the library's per-window path."""
    from tactile_cli.spectral import group_square_coherence_bins, segment_spectra

    _, spectra = segment_spectra(x, RATE_HZ, nperseg=NPERSEG, noverlap=NOVERLAP)
    return group_square_coherence_bins(spectra)


def tactile_g2_batch(x: np.ndarray, workers: int) -> np.ndarray:
    """(n, 1024, 20) -> (n, 129): the library's batched path (chunks of 16 windows)."""
    from tactile_cli.spectral import group_square_coherence_windows

    return group_square_coherence_windows(x, RATE_HZ, nperseg=NPERSEG, noverlap=NOVERLAP,
                                          workers=workers)[1]


def best_of(fn, repeats: int) -> float:
    best = float("inf")
    for _ in range(repeats):
        t0 = time.perf_counter()
        fn()
        best = min(best, time.perf_counter() - t0)
    return best


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--batch", type=int, default=256, help="windows per batched call")
    ap.add_argument("--loop-windows", type=int, default=5, help="windows timed in the loop")
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args()

    from tactile_cli.spectral import g2_noise_floor, welch_segment_count

    x = windows(args.batch)
    tactile_g2_batch(x[:2], 1)                                   # warm caches
    batched_s = best_of(lambda: tactile_g2_batch(x, 1), args.repeats)
    threaded_s = best_of(lambda: tactile_g2_batch(x, 2), args.repeats)
    single_s = best_of(lambda: tactile_g2(x[0]), 20 * args.repeats)
    ours = tactile_g2_batch(x, 1)
    assert np.array_equal(ours, tactile_g2_batch(x, 2))
    t0 = time.perf_counter()
    ref = np.stack([loop_g2(w) for w in x[:args.loop_windows]])
    loop_s = (time.perf_counter() - t0) / args.loop_windows
    diff = float(np.abs(ours[:args.loop_windows] - ref).max())
    n_seg = welch_segment_count(N_SAMPLES, NPERSEG, NOVERLAP)
    result = {
        "tactile_ms_per_window": round(1e3 * batched_s / args.batch, 4),
        "loop_ms_per_window": round(1e3 * loop_s, 3),
        "ratio": round(loop_s / (batched_s / args.batch), 1),
        "max_abs_diff": diff,
        "agree_1e-9": diff <= 1e-9,
        "batch_windows": args.batch, "batch_chunk": 16, "threads": 1,
        "tactile_ms_per_window_2_threads": round(1e3 * threaded_s / args.batch, 4),
        "single_window_ms": round(1e3 * single_s, 4),
        "single_window_ratio": round(loop_s / single_s, 1),
        "channels": N_CHANNELS, "samples": N_SAMPLES, "nperseg": NPERSEG,
        "noverlap": NOVERLAP, "segments": n_seg, "rank_deficient": n_seg < N_CHANNELS,
        "g2_noise_floor_7_segments": round(g2_noise_floor(N_CHANNELS, n_seg), 4),
        "g2_noise_floor_63_segments": round(g2_noise_floor(N_CHANNELS, 63), 4),
        "target_ms_per_window": 0.5, "target_ratio": 100,
        "machine": f"{platform.machine()}, {platform.python_version()}, numpy "
                   f"{np.__version__}",
    }
    if args.json:
        print(json.dumps(result, indent=2))
        return
    for k, v in result.items():
        print(f"{k:28s} {v}")


if __name__ == "__main__":
    main()
