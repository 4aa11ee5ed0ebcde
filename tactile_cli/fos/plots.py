"""Figures of FOS fits like paper 000's Figs. 11 (press, eq. 16) and 12 (slip, eq. 17).

One small panel per trial: the counts that were fitted (points; for the slip, after the
press tail was subtracted) and the fitted first-order curve, with R in the title. Pages are
grids of at most :data:`PANELS_PER_PAGE` panels: one page (or more) per force grade when the
trials carry ``force_grade`` labels, else pages in trial order. Failed fits are drawn too,
their data without a curve and their status in the title. Curves from CSV files get one
figure each, named after their input and labelled in their own unit
(:func:`plot_curve_fits`).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from ..store.writer import safe_name  # noqa: E402
from .protocol import RegionFits  # noqa: E402

PANELS_PER_PAGE = 24
_COLUMNS = 6
_TITLES = {"press": "press: pulse response (eq. 16)", "slip": "slip: ramp response (eq. 17), "
           "press tail subtracted", "curve": "response"}


def _pages(labels: Sequence[Mapping[str, Any]] | None, n: int) -> list[tuple[str, list[int]]]:
    """(page tag, trial rows) pairs: by force grade (ordered by force level) when labelled."""
    if labels is not None and n and all("force_grade" in lab for lab in labels):
        groups: dict[str, list[int]] = {}
        for i, lab in enumerate(labels):
            groups.setdefault(str(lab["force_grade"]), []).append(i)

        def level(rows: list[int]) -> float:
            values = [labels[i].get("force_level") for i in rows]
            try:
                return float(np.nanmin([float(v) for v in values if v is not None]))
            except ValueError:
                return np.inf

        ordered = sorted(groups.items(), key=lambda kv: (level(kv[1]), kv[0]))
    else:
        ordered = [("", list(range(n)))]
    pages = []
    for tag, rows in ordered:
        for k in range(0, len(rows), PANELS_PER_PAGE):
            suffix = f"_{k // PANELS_PER_PAGE + 1}" if len(rows) > PANELS_PER_PAGE else ""
            pages.append((f"{tag}{suffix}", rows[k:k + PANELS_PER_PAGE]))
    return pages


def plot_region_fits(
    rf: RegionFits,
    out_dir: str | Path,
    *,
    labels: Sequence[Mapping[str, Any]] | None = None,
    prefix: str | None = None,
) -> list[Path]:
    """Write the PNG pages of one region's fits into ``out_dir``; returns their paths.

    ``labels``: per-trial labels (``force_level``, ``force_grade``) for titles and pages.
    Files are named ``{prefix}.png`` or ``{prefix}_{grade}.png`` (prefix default
    ``fos_{region}``).
    """
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    prefix = prefix or f"fos_{rf.region}"
    written = []
    for tag, rows in _pages(labels, len(rf)):
        n_cols = min(_COLUMNS, len(rows))
        n_rows = -(-len(rows) // n_cols)
        fig, axes = plt.subplots(n_rows, n_cols, figsize=(2.6 * n_cols, 2.1 * n_rows),
                                 squeeze=False, constrained_layout=True)
        for ax in axes.ravel()[len(rows):]:
            ax.set_visible(False)
        for ax, i in zip(axes.ravel(), rows, strict=False):
            m = rf.mask[i]
            t, y = rf.t_s[i][m], rf.y[i][m]
            ax.plot(t, y, ".", ms=2.5, color="0.35", label="data")
            if rf.ok[i] and len(t):
                fine = np.linspace(0.0, t.max(), 300)
                ax.plot(fine, rf.curve(i, fine), "-", color="tab:red", lw=1.2, label="FOS fit")
                title = f"R = {rf.fit.pearson_r[i]:.4f}"
            else:
                title = str(rf.status[i])
            name = rf.trials[i]
            lab = labels[i] if labels is not None else {}
            if "force_level" in lab:
                name += f" (level {lab['force_level']})"
            ax.set_title(f"{name}\n{title}", fontsize=7)
            ax.tick_params(labelsize=6)
        for ax in axes[-1]:
            ax.set_xlabel("t from region start (s)", fontsize=7)
        for ax in axes[:, 0]:
            ax.set_ylabel("net events / bin", fontsize=7)
        heading = _TITLES.get(rf.region, rf.region)
        fig.suptitle(f"{heading}{f' - {tag}' if tag else ''}", fontsize=9)
        path = out_dir / (f"{prefix}_{safe_name(tag)}.png" if tag else f"{prefix}.png")
        fig.savefig(path, dpi=110)
        plt.close(fig)
        written.append(path)
    return written


def plot_curve_fits(
    rf: RegionFits,
    out_dir: str | Path,
    *,
    quantities: Sequence[str] | None = None,
) -> list[Path]:
    """One PNG per fitted curve (from :func:`tactile_cli.fos.protocol.fit_curves`), named
    after its row, ``{name}.png`` (the CSV file's stem): data, fitted curve, R or the
    status. ``quantities``: the response's name per row for the y label (default
    ``"response"``), the unit from ``rf``."""
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    written = []
    for i, name in enumerate(rf.trials):
        m = rf.mask[i]
        t, y = rf.t_s[i][m], rf.y[i][m]
        fig, ax = plt.subplots(figsize=(4.8, 3.4), constrained_layout=True)
        ax.plot(t, y, ".", ms=3, color="0.35", label="data")
        if rf.ok[i] and len(t):
            fine = np.linspace(0.0, t.max(), 400)
            ax.plot(fine, rf.curve(i, fine), "-", color="tab:red", lw=1.4,
                    label=f"{rf.model} fit")
            note = (f"R = {rf.fit.pearson_r[i]:.4f}, alpha = {rf.fit.alpha[i]:.4g} "
                    f"{rf.unit(i)}, tau = {rf.fit.tau_s[i]:.4g} s")
        else:
            note = str(rf.status[i])
        quantity = quantities[i] if quantities is not None else "response"
        ax.set_title(f"{name}\n{note}", fontsize=8)
        ax.set_xlabel("t from the start (s)", fontsize=8)
        ax.set_ylabel(f"{quantity} ({rf.unit(i)})", fontsize=8)
        ax.tick_params(labelsize=7)
        ax.legend(fontsize=7, frameon=False)
        path = out_dir / f"{safe_name(name)}.png"
        fig.savefig(path, dpi=110)
        plt.close(fig)
        written.append(path)
    return written


__all__ = ["PANELS_PER_PAGE", "plot_curve_fits", "plot_region_fits"]
