"""A trained one-sample MLP run as plain numpy arrays, for inference without torch.

Paper 002 (sec. II-B) maps each pixel's (x, y, dR, dG, dB) to its surface normal with a
5-32-32-32-3 MLP and runs it on every pixel of every frame; a chain that does this
(``visuotactile/normals.py``) wants the weights as float32 arrays it can fold and tile,
not a torch module. :func:`dense_arrays` reads a run of ``family: mlp`` with ``window: 1``
(the summary features of a one-sample window are the sample itself, or zero for ``std``
and ``slope``) and returns every affine step the network applies, in order.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..errors import InputError

#: Summary features that equal the sample itself on a one-sample window (``std`` and
#: ``slope`` are zero there).
_IDENTITY_FEATURES = ("mean", "min", "max", "last")


@dataclass(frozen=True)
class DenseArrays:
    """A one-sample MLP run as float64 arrays (callers cast to the dtype they compute in).

    channels: input channel names in model order. in_mean, in_std: (c,) standardisation of
    the raw inputs (zeros and ones when the run did not normalise). feature_rows: (f,)
    index of the input channel each summary feature copies, -1 for a feature that is zero
    on one sample. feature_mean, feature_std: (f,). trunk: [(W (in, out), b (out,))] with
    ReLU after each. heads: name -> [(W, b)] with ReLU after all but the last layer;
    target_scale: name -> (mean, std) that turns a regression head's standardised output
    into target units.
    """

    channels: tuple[str, ...]
    in_mean: np.ndarray
    in_std: np.ndarray
    feature_rows: np.ndarray
    feature_mean: np.ndarray
    feature_std: np.ndarray
    trunk: tuple[tuple[np.ndarray, np.ndarray], ...]
    heads: dict[str, tuple[tuple[np.ndarray, np.ndarray], ...]]
    target_scale: dict[str, tuple[float, float]]
    path: Path

    def forward(self, x: np.ndarray) -> dict[str, np.ndarray]:
        """(n, c) raw inputs -> head name -> (n,) outputs in target units (float64; the
        reference implementation the folded float32 inference is tested against)."""
        z = (np.asarray(x, dtype=np.float64) - self.in_mean) / self.in_std
        f = np.where(self.feature_rows >= 0, z[:, np.maximum(self.feature_rows, 0)], 0.0)
        h = (f - self.feature_mean) / self.feature_std
        for w, b in self.trunk:
            h = np.maximum(h @ w + b, 0.0)
        out = {}
        for name, layers in self.heads.items():
            y = h
            for i, (w, b) in enumerate(layers):
                y = y @ w + b
                if i < len(layers) - 1:
                    y = np.maximum(y, 0.0)
            m, s = self.target_scale.get(name, (0.0, 1.0))
            out[name] = y[:, 0] * s + m
        return out


def _linears(module: object) -> list[tuple[np.ndarray, np.ndarray]]:
    import torch.nn as nn

    return [(m.weight.detach().double().numpy().T.copy(), m.bias.detach().double().numpy().copy())
            for m in module.modules() if isinstance(m, nn.Linear)]  # type: ignore[attr-defined]


def dense_arrays(run_dir: str | Path) -> DenseArrays:
    """The run at ``run_dir`` (written by ``tactile train``) as :class:`DenseArrays`.

    Refuses, with one InputError naming the run folder, a family other than ``mlp``, a
    window other than 1, an input transform, and classification heads.
    """
    from .runs import load_run

    run = load_run(run_dir)
    cfg = run.config
    path = Path(run_dir)
    if cfg.model.family != "mlp":
        raise InputError(f"run has family {cfg.model.family!r}; a per-pixel normal model needs "
                         "`family: mlp`", path=path)
    if cfg.data.window != 1:
        raise InputError(f"run has window {cfg.data.window}; a per-pixel normal model needs "
                         "`window: 1`", path=path)
    norm = run.normalisation
    if norm.transform != "none":
        raise InputError(f"run has input transform {norm.transform!r}; a per-pixel normal "
                         "model needs `transform: none`", path=path)
    bad = [h.name for h in run.heads if h.kind != "regression"]
    if bad:
        raise InputError(f"run has classification heads {bad}; a normal model needs "
                         "regression heads", path=path)
    model = run.load_model()
    channels = tuple(cfg.data.channels)
    c = len(channels)
    summary = model.trunk.summary
    rows = []
    for name in summary.features:
        rows += list(range(c)) if name in _IDENTITY_FEATURES else [-1] * c
    if norm.enabled:
        in_mean, in_std = norm.mean.astype(np.float64), norm.std.astype(np.float64)
    else:
        in_mean, in_std = np.zeros(c), np.ones(c)
    heads = {spec.name: tuple(_linears(block))
             for spec, block in zip(model.head_specs, model.heads, strict=True)}
    return DenseArrays(
        channels=channels, in_mean=in_mean, in_std=in_std,
        feature_rows=np.asarray(rows, dtype=np.int64),
        feature_mean=summary.feature_mean.detach().double().numpy().copy(),
        feature_std=summary.feature_std.detach().double().numpy().copy(),
        trunk=tuple(_linears(model.trunk.dense)), heads=heads,
        target_scale=dict(norm.targets), path=path,
    )


__all__ = ["DenseArrays", "dense_arrays"]
