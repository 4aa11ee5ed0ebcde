"""Where a network trains and predicts: ``--device auto|cpu|cuda`` (issue 35, item 7).

``auto`` is the first CUDA GPU when torch sees one, else the CPU; ``cuda`` where torch
sees none is one :class:`InputError` line (the pinned torch of this project is the CPU
build, so CI runs on the CPU). On the CPU training and prediction are exactly what they
were before the option existed (same operations, same threads, same bits); on a GPU the
same seed gives a run of the same design, not the same bits (cuDNN kernels differ), so
every run records its device (``run.json`` ``training.device``, and the metrics'
``device``). Classic families (scikit-learn) always run on the CPU.
"""

from __future__ import annotations

import os

import torch

from ..errors import InputError

#: The values ``device`` accepts.
DEVICES: tuple[str, ...] = ("auto", "cpu", "cuda")


def resolve_device(device: str = "auto") -> torch.device:
    """``auto`` -> ``cuda`` when ``torch.cuda.is_available()``, else ``cpu``; ``cpu``;
    ``cuda`` (InputError when torch sees no CUDA GPU). Anything else is an InputError."""
    if device not in DEVICES:
        raise InputError(f"`device` (={device!r}) must be one of {', '.join(DEVICES)}")
    available = torch.cuda.is_available()
    if device == "cuda" and not available:
        build = "a CPU build" if torch.version.cuda is None else f"built for CUDA " \
            f"{torch.version.cuda}"
        raise InputError(f"`device` (=cuda): torch {torch.__version__} ({build}) sees no CUDA "
                         "GPU; use `device='cpu'` or `device='auto'`")
    if device == "cpu" or not available:
        return torch.device("cpu")
    # deterministic algorithms on CUDA need a fixed cuBLAS workspace (set before first use)
    os.environ.setdefault("CUBLAS_WORKSPACE_CONFIG", ":4096:8")
    return torch.device("cuda")


def device_name(device: torch.device) -> str:
    """``cpu``, or ``cuda (NVIDIA H100 80GB HBM3)``: what a run records."""
    if device.type == "cuda":
        return f"cuda ({torch.cuda.get_device_name(device)})"
    return device.type


__all__ = ["DEVICES", "device_name", "resolve_device"]
