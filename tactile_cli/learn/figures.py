"""Figures of a run: training curves and confusion matrices (PNG, matplotlib Agg)."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402


def plot_curves(history: Sequence[dict[str, float]], out: Path, *, title: str = "",
                best_epoch: int | None = None) -> Path:
    """Loss (train, val) and validation accuracy against epoch."""
    epochs = [h["epoch"] for h in history]
    fig, (ax_loss, ax_acc) = plt.subplots(1, 2, figsize=(10, 3.8))
    ax_loss.plot(epochs, [h["train_loss"] for h in history], marker=".", label="train")
    val = [h["val_loss"] for h in history]
    if np.isfinite(val).any():
        ax_loss.plot(epochs, val, marker=".", label="val")
    ax_loss.set_xlabel("epoch")
    ax_loss.set_ylabel("loss (sum over heads)")
    ax_loss.set_yscale("log")
    ax_loss.legend()
    acc = [h["val_accuracy"] for h in history]
    if np.isfinite(acc).any():
        ax_acc.plot(epochs, 100 * np.asarray(acc), marker=".", color="C1")
    else:
        ax_acc.text(0.5, 0.5, "no validation accuracy", ha="center", transform=ax_acc.transAxes)
    ax_acc.set_xlabel("epoch")
    ax_acc.set_ylabel("val accuracy (%)")
    for ax in (ax_loss, ax_acc):
        ax.grid(alpha=0.3)
        if best_epoch is not None:
            ax.axvline(best_epoch, color="grey", ls="--", lw=1)
    if title:
        fig.suptitle(title)
    fig.tight_layout()
    fig.savefig(out, dpi=110)
    plt.close(fig)
    return out


def plot_confusion(matrix: np.ndarray, classes: Sequence[str], out: Path, *,
                   title: str = "") -> Path:
    """Counts (rows: true class, columns: predicted), coloured by row fraction."""
    m = np.asarray(matrix, dtype=np.int64)
    rows = m.sum(axis=1, keepdims=True)
    frac = np.divide(m, rows, out=np.zeros(m.shape), where=rows > 0)
    k = len(classes)
    size = max(3.5, 0.9 * k + 1.5)
    fig, ax = plt.subplots(figsize=(size + 1, size))
    im = ax.imshow(frac, cmap="Blues", vmin=0, vmax=1)
    for i in range(k):
        for j in range(k):
            ax.text(j, i, f"{m[i, j]:,}", ha="center", va="center", fontsize=8,
                    color="white" if frac[i, j] > 0.5 else "black")
    ax.set_xticks(range(k), classes, rotation=45, ha="right")
    ax.set_yticks(range(k), classes)
    ax.set_xlabel("predicted")
    ax.set_ylabel("true")
    fig.colorbar(im, ax=ax, label="fraction of the true class")
    if title:
        ax.set_title(title)
    fig.tight_layout()
    fig.savefig(out, dpi=110)
    plt.close(fig)
    return out


__all__ = ["plot_confusion", "plot_curves"]
