"""Inference cost of a network on this machine: latency per window and throughput.

What a real-time user pays is the time from a window being complete to its prediction:
one forward pass at batch 1. :func:`measure_latency` times that (median and 95th
percentile over many single-window calls, after a warm-up) and the throughput at a large
batch, under ``torch.inference_mode`` on the CPU with the thread count set once for both.
The windows are real evaluation windows, so data-dependent paths are exercised.
"""

from __future__ import annotations

import os
import platform
import time
from dataclasses import asdict, dataclass
from typing import Any

import numpy as np
import torch
from torch import nn

from ..threads import check_threads


@dataclass(frozen=True)
class LatencyStats:
    """Per-window latency at batch 1 (ms) and throughput at ``large_batch`` (windows/s)."""

    threads: int
    batch1_ms_median: float
    batch1_ms_p95: float
    batch1_ms_min: float
    batch1_repeats: int
    warmup: int
    large_batch: int
    large_batch_ms_median: float
    windows_per_s: float
    device: str
    cpu: str
    torch_version: str

    def as_dict(self) -> dict[str, Any]:
        return asdict(self)


def cpu_name() -> str:
    """The CPU model (from /proc/cpuinfo on Linux), else what ``platform`` knows."""
    try:
        with open("/proc/cpuinfo", encoding="utf-8") as f:
            for line in f:
                if line.startswith("model name"):
                    return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or platform.machine()


def available_cpus() -> int:
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except AttributeError:  # not on Linux
        return max(1, os.cpu_count() or 1)


def measure_latency(model: nn.Module, windows: np.ndarray, *, threads: int | None = None,
                    repeats: int = 300, warmup: int = 30, large_batch: int = 1024,
                    large_repeats: int = 5) -> LatencyStats:
    """Time ``model`` on windows (n, window, channels) float32 from the evaluation data.

    Batch 1: ``repeats`` calls, each on the next window (cycling), after ``warmup`` calls;
    median, 95th percentile and minimum in milliseconds. Large batch: ``large_batch``
    windows (repeated when there are fewer), median of ``large_repeats`` calls after one
    warm-up, as windows per second. ``threads`` (default 1) is set once for both and the
    previous setting restored afterwards.
    """
    if windows.ndim != 3 or windows.shape[0] == 0:
        raise ValueError(f"`windows` must be (n >= 1, window, channels), got {windows.shape}")
    threads = 1 if threads is None else check_threads(threads, "threads")
    previous = torch.get_num_threads()
    was_training = model.training
    model.eval()
    torch.set_num_threads(threads)
    try:
        data = torch.from_numpy(np.ascontiguousarray(windows, dtype=np.float32))
        n = data.shape[0]
        singles = [data[i % n: i % n + 1] for i in range(warmup + repeats)]
        times_ns = np.empty(repeats, dtype=np.int64)
        with torch.inference_mode():
            for i in range(warmup):
                model(singles[i])
            for i in range(repeats):
                x = singles[warmup + i]
                t0 = time.perf_counter_ns()
                model(x)
                times_ns[i] = time.perf_counter_ns() - t0
            reps = -(-large_batch // n)
            big = data.repeat(reps, 1, 1)[:large_batch] if reps > 1 else data[:large_batch]
            model(big)
            big_ns = np.empty(large_repeats, dtype=np.int64)
            for i in range(large_repeats):
                t0 = time.perf_counter_ns()
                model(big)
                big_ns[i] = time.perf_counter_ns() - t0
    finally:
        torch.set_num_threads(previous)
        model.train(was_training)
    ms = times_ns / 1e6
    big_ms = float(np.median(big_ns) / 1e6)
    return LatencyStats(
        threads=threads,
        batch1_ms_median=float(np.median(ms)),
        batch1_ms_p95=float(np.percentile(ms, 95)),
        batch1_ms_min=float(ms.min()),
        batch1_repeats=repeats,
        warmup=warmup,
        large_batch=int(big.shape[0]),
        large_batch_ms_median=big_ms,
        windows_per_s=float(big.shape[0] / (big_ms / 1e3)),
        device="cpu",
        cpu=cpu_name(),
        torch_version=torch.__version__,
    )


__all__ = ["LatencyStats", "available_cpus", "cpu_name", "measure_latency"]
