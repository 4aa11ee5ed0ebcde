"""Figure of one trial's event counts like paper 000's Fig. 10.

Top: the raw counts per bin (20 ms by default) of each polarity and their net; bottom: the
moving average of the net count. The action regions are shaded: from the trial's
annotations when it has them (the ground truth), else from the segmentation; detected
boundaries are dashed lines with their uncertainty as a band.
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from ..store.atomic import save_figure  # noqa: E402
from ..store.writer import safe_name  # noqa: E402
from ..vocabulary import ACTIONS, action_index  # noqa: E402

if TYPE_CHECKING:  # the recording module imports this figure
    from .recording import TrialAccumulation

REGION_COLOURS = {"approach": "#e8e8e8", "press": "#cfe8ff", "slip": "#ffe0c2",
                  "release": "#d8f5d0"}


def _shade(ax, intervals: list[tuple[float, float, str]]) -> None:
    for start, end, label in intervals:
        if label in REGION_COLOURS:
            ax.axvspan(start, end, color=REGION_COLOURS[label], alpha=0.8, lw=0, zorder=0)


def plot_trial(acc: TrialAccumulation, out_dir: str | Path) -> Path:
    """Write ``out_dir/<trial>.png`` (temporary file, then an atomic rename); returns it."""
    out_dir = Path(out_dir)
    c = acc.counts
    seg = acc.segmentation
    if acc.true_labels is not None:
        shaded = [(s, e, ACTIONS[i]) for s, e, lab in acc.annotations
                  if (i := action_index(lab)) is not None]
        source = "annotated regions"
    elif seg is not None and seg.status != "failed":
        shaded, source = seg.intervals(), "detected regions"
    else:
        shaded, source = [], "no regions"
    fig, (top, bottom) = plt.subplots(2, 1, figsize=(9, 5.5), sharex=True)
    for ax in (top, bottom):
        _shade(ax, shaded)
        ax.axhline(0, color="0.5", lw=0.5)
        ax.grid(alpha=0.3, lw=0.5)
    top.plot(c.t_s, c.positive, color="tab:red", lw=0.7, label="positive")
    top.plot(c.t_s, c.negative, color="tab:blue", lw=0.7, label="negative")
    top.plot(c.t_s, c.net, color="k", lw=1.0, label="net")
    top.set_ylabel(f"events / {c.bin_s * 1e3:g} ms")
    bottom.plot(c.t_s, acc.smoothed, color="k", lw=1.2,
                label=f"net, moving average of {acc.smooth_bins} bins")
    bottom.set_ylabel("smoothed net")
    bottom.set_xlabel("time from trial start (s)")
    title = f"{acc.trial}"
    grade = acc.labels.get("force_grade")
    if grade is not None:
        title += f" ({grade}, level {acc.labels.get('force_level', '?')})"
    if seg is not None:
        title += f": segmentation {seg.status}"
        if acc.score is not None and np.isfinite(acc.score.bin_accuracy):
            title += f", {100 * acc.score.bin_accuracy:.1f} % of bins as annotated"
        for key in ("press_start", "slip_start", "release_start"):
            at, se = getattr(seg, f"{key}_s"), getattr(seg, f"{key}_se_s")
            if np.isfinite(at):
                for ax in (top, bottom):
                    ax.axvline(at, color="tab:purple", ls="--", lw=1.0)
                    if np.isfinite(se):
                        ax.axvspan(at - se, at + se, color="tab:purple", alpha=0.15, lw=0)
        bottom.plot([], [], color="tab:purple", ls="--", label="detected boundaries")
    top.set_title(title, fontsize=10)
    handles = [plt.Rectangle((0, 0), 1, 1, color=REGION_COLOURS[a]) for a in ACTIONS]
    top.legend(loc="upper left", fontsize=7, ncol=3)
    bottom.legend(handles=[*bottom.get_legend_handles_labels()[0], *handles],
                  labels=[*bottom.get_legend_handles_labels()[1],
                          *(f"{a} ({source})" if i == 0 else a for i, a in enumerate(ACTIONS))],
                  loc="upper left", fontsize=7, ncol=2)
    bottom.set_xlim(0, c.end_s)
    fig.tight_layout()
    out = out_dir / f"{safe_name(acc.trial)}.png"
    return save_figure(fig, out, dpi=110, overwrite=True)


__all__ = ["REGION_COLOURS", "plot_trial"]
