"""Figures of the height-map and slip-signal chain (paper 002, Figs. 2, 5, 7, 10, 11).

matplotlib is imported inside the functions (``tactile --help`` stays fast).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np


def _pyplot():  # type: ignore[no-untyped-def]
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def height_figure(frame: np.ndarray, height_mm: np.ndarray, px_per_mm: float, out: Path, *,
                  title: str = "", truth_mm: np.ndarray | None = None) -> Path:
    """Fig. 2: the tactile image (left) and its height map as a 3-D surface (right; the
    true surface as a wireframe when ``truth_mm`` is given). Writes ``out`` (PNG)."""
    plt = _pyplot()
    h, w = height_mm.shape
    step = max(1, max(h, w) // 80)  # a surface of ~80 x 60 facets reads well and draws fast
    yy, xx = np.mgrid[0:h:step, 0:w:step]
    fig = plt.figure(figsize=(10, 4.2))
    ax0 = fig.add_subplot(1, 2, 1)
    ax0.imshow(frame)
    ax0.set_title("tactile image")
    ax0.set_axis_off()
    ax1 = fig.add_subplot(1, 2, 2, projection="3d")
    ax1.plot_surface(xx / px_per_mm, yy / px_per_mm, height_mm[::step, ::step], cmap="viridis",
                     linewidth=0, antialiased=False)
    if truth_mm is not None:
        ax1.plot_wireframe(xx / px_per_mm, yy / px_per_mm, truth_mm[::step, ::step],
                           color="k", linewidth=0.3, rstride=3, cstride=3)
    ax1.set_xlabel("x (mm)")
    ax1.set_ylabel("y (mm)")
    ax1.set_zlabel("height (mm)")
    ax1.invert_yaxis()
    ax1.set_title("height map" + (" (truth: wireframe)" if truth_mm is not None else ""))
    if title:
        fig.suptitle(title)
    fig.tight_layout()
    fig.savefig(out, dpi=110)
    plt.close(fig)
    return out


def slip_signal_figure(t_s: np.ndarray, signal: np.ndarray, threshold: float, out: Path, *,
                       title: str = "", onset_s: float | None = None,
                       detected_s: float | None = None, first_judged_s: float | None = None,
                       unit: str = "mm") -> Path:
    """Figs. 5, 7, 10, 11: the slip signal over time with the threshold (dashed), the
    static frames that gave it (shaded), the labelled onset and the first detection."""
    plt = _pyplot()
    fig, ax = plt.subplots(figsize=(6.4, 3.2))
    ax.plot(t_s, signal, lw=1.2, label="slip signal S")
    ax.axhline(threshold, color="tab:red", ls="--", lw=1, label="threshold")
    if first_judged_s is not None:
        ax.axvspan(float(t_s[0]), first_judged_s, color="0.9", label="static (threshold)")
    if onset_s is not None:
        ax.axvline(onset_s, color="k", ls=":", lw=1, label="slip onset (label)")
    if detected_s is not None:
        ax.axvline(detected_s, color="tab:green", lw=1, label="first detection")
    ax.set_xlabel("time (s)")
    ax.set_ylabel(f"S ({unit})")
    ax.legend(fontsize=7, loc="upper left")
    if title:
        ax.set_title(title, fontsize=9)
    fig.tight_layout()
    fig.savefig(out, dpi=110)
    plt.close(fig)
    return out


__all__ = ["height_figure", "slip_signal_figure"]
