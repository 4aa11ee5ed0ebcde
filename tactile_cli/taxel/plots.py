"""Figures of the taxel-array chain (matplotlib imported inside the functions)."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

if TYPE_CHECKING:  # the pipeline imports these figures
    from .pipeline import PresetFeatures

#: the rows of the feature figure: pipeline.FEATURES, with their axis labels
_LABELS = {"gamma": "power ratio Γ", "g2_single": "single-finger G²",
           "g2_multi": "multi-finger G²"}
FEATURES = tuple(_LABELS)


def plot_feature_spectra(features: dict[str, PresetFeatures], out: str | Path) -> Path:
    """Like the paper's Fig. 12b: each feature against frequency (one-bin bands) for every
    preset, the mean of each slip type (line) and its one-standard-deviation region
    (shaded); trials below the noise floor left out. Writes a PNG to ``out``."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    presets = list(features)
    fig, axes = plt.subplots(len(FEATURES), len(presets), figsize=(4.2 * len(presets), 8.5),
                             squeeze=False)
    for col, preset in enumerate(presets):
        pf = features[preset]
        for row, feat in enumerate(FEATURES):
            ax = axes[row][col]
            fv = pf.features[feat]
            narrow = np.isclose(fv.w_hz, fv.w_hz.min())           # one-bin bands
            order = np.argsort(fv.f_hz[narrow])
            f = fv.f_hz[narrow][order]
            for slip, colour in (("hand", "tab:orange"), ("world", "tab:blue")):
                sel = (pf.slip_type == slip) & pf.decided
                v = fv.values[sel][:, narrow][:, order]
                mean, std = np.nanmean(v, axis=0), np.nanstd(v, axis=0)
                ax.plot(f, mean, color=colour, label=f"object/{slip} slip")
                ax.fill_between(f, mean - std, mean + std, color=colour, alpha=0.25)
            ax.set_ylim(-0.02, 1.02)
            ax.set_title(f"{preset}: {_LABELS[feat]}", fontsize=9)
            if row == len(FEATURES) - 1:
                ax.set_xlabel("band centre f (Hz)")
            if col == 0:
                ax.set_ylabel(_LABELS[feat])
    axes[0][0].legend(fontsize=8)
    fig.suptitle("slip-interface features against frequency: mean ± 1 s.d. per slip type")
    fig.tight_layout()
    out = Path(out)
    fig.savefig(out, dpi=110)
    plt.close(fig)
    return out


def plot_stability(rows: Sequence[dict[str, Any]], out: str | Path, *,
                   threshold: float = 0.85) -> Path:
    """Nested accuracy against each perturbation (``rows``: dicts with ``study``,
    ``level``, ``preset``, ``feature``, ``accuracy``), one panel per study, a line per
    preset x feature, the ``threshold`` dashed and each line's breaking point (first level
    below it) marked."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    studies = list(dict.fromkeys(r["study"] for r in rows))
    fig, axes = plt.subplots(1, len(studies), figsize=(5 * len(studies), 4), squeeze=False)
    for ax, study in zip(axes[0], studies, strict=True):
        sub = [r for r in rows if r["study"] == study]
        for key in dict.fromkeys((r["preset"], r["feature"]) for r in sub):
            pts = sorted((r["level"], r["accuracy"]) for r in sub
                         if (r["preset"], r["feature"]) == key)
            x, y = zip(*pts, strict=True)
            line, = ax.plot(x, y, marker="o", ms=3, label=f"{key[0]} {key[1]}")
            broken = [(a, b) for a, b in pts if b < threshold]
            if broken:
                ax.plot(*broken[0], marker="x", ms=10, color=line.get_color())
        ax.axhline(threshold, ls="--", color="grey")
        ax.set_xlabel(study)
        ax.set_ylabel("nested best-band accuracy")
        ax.set_ylim(0.3, 1.02)
    axes[0][-1].legend(fontsize=6, ncol=2)
    fig.suptitle("slip-interface accuracy against perturbations (x: first level below "
                 f"{threshold:.0%})")
    fig.tight_layout()
    out = Path(out)
    fig.savefig(out, dpi=110)
    plt.close(fig)
    return out
