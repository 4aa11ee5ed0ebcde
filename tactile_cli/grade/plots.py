"""Figures of the grader: membership functions (paper 000, Figs. 20-21), one inference
(Fig. 22) and the area against the force level (Fig. 15). PNG files via matplotlib's Agg
backend."""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from ..store.atomic import save_figure  # noqa: E402
from .config import GraderConfig  # noqa: E402
from .fuzzy import infer  # noqa: E402
from .grading import GradeReport  # noqa: E402


def _grid(lo: float, hi: float, knots: list[float], n: int = 1201) -> np.ndarray:
    return np.union1d(np.linspace(lo, hi, n), [k for k in knots if lo <= k <= hi])


def _knots(mfs) -> list[float]:
    return [v for m in mfs if m.piecewise_linear for v in m.trapezoid]


def _save(fig, path: Path) -> Path:
    """``fig`` as a PNG through the store's atomic writer (closed afterwards)."""
    Path(path).parent.mkdir(parents=True, exist_ok=True)
    return save_figure(fig, path, dpi=110, overwrite=True)


def plot_membership(config: GraderConfig, path: Path) -> Path:
    """Input terms over the area (Fig. 20) and output terms over the force (Fig. 21)."""
    system = config.system()
    fig, axes = plt.subplots(2, 1, figsize=(8, 6))
    for ax, side in zip(axes, ("input", "output"), strict=True):
        var = getattr(config, side)
        mfs = getattr(system, f"{side}_mfs")
        names = getattr(system, f"{side}_terms")
        y = _grid(*var.range, _knots(mfs))
        for name, mf in zip(names, mfs, strict=True):
            ax.plot(y, mf(y), label=name)
        unit = f" ({var.units})" if var.units else ""
        ax.set_xlabel(f"{var.name}{unit}")
        ax.set_ylabel("membership")
        ax.set_ylim(-0.02, 1.08)
        ax.legend(fontsize=7, ncol=3, loc="upper center")
    axes[0].set_title("Input fuzzification (cf. paper Fig. 20)")
    axes[1].set_title("Output fuzzification (cf. paper Fig. 21)")
    fig.tight_layout()
    return _save(fig, path)


def plot_inference(config: GraderConfig, area: float, path: Path, *, title: str = "") -> Path:
    """One inference like Fig. 22: the input terms with the input line and the firing
    strengths; the output terms clipped at them, the aggregate (max) and its centroid."""
    system = config.system()
    res = infer(system, np.array([area]))
    fig, (ax_in, ax_out) = plt.subplots(1, 2, figsize=(11, 4))
    x = _grid(*config.input.range, _knots(system.input_mfs))
    colours = plt.rcParams["axes.prop_cycle"].by_key()["color"]
    for k, (name, mf) in enumerate(zip(system.input_terms, system.input_mfs, strict=True)):
        ax_in.plot(x, mf(x), color=colours[k % len(colours)], label=name)
    xc = float(np.clip(area, *config.input.range))
    ax_in.axvline(xc, color="k", lw=1.5, label=f"area = {area:.6g}")
    for r, (i, _) in enumerate(system.rules):
        w = res.firing[0, r]
        if w > 0:
            ax_in.plot([xc], [w], "o", color=colours[i % len(colours)])
            ax_in.annotate(f"{w:.2f}", (xc, w), textcoords="offset points", xytext=(5, 4))
    ax_in.set_xlabel(f"{config.input.name} ({config.input.units})" if config.input.units
                     else config.input.name)
    ax_in.set_ylabel("membership")
    ax_in.set_ylim(-0.02, 1.1)
    ax_in.legend(fontsize=7, loc="upper right")
    ax_in.set_title("Fuzzification and rule firing")
    y = _grid(*config.output.range, _knots(system.output_mfs), n=2001)
    agg = np.zeros_like(y)
    for k, (name, mf) in enumerate(zip(system.output_terms, system.output_mfs, strict=True)):
        colour = colours[k % len(colours)]
        mu = mf(y)
        ax_out.plot(y, mu, color=colour, lw=0.8, alpha=0.5)
        clipped = np.minimum(res.cut[0, k], mu)
        if res.cut[0, k] > 0:
            ax_out.fill_between(y, clipped, color=colour, alpha=0.35, label=f"{name} (clipped)")
        agg = np.maximum(agg, clipped)
    ax_out.plot(y, agg, color="k", lw=1.5, label="aggregate (max)")
    crisp = float(res.crisp[0])
    grade = system.output_terms[res.grade[0]] if res.grade[0] >= 0 else "none"
    ax_out.axvline(crisp, color="r", lw=1.5, ls="--", label=f"centroid {crisp:.4f}: {grade}")
    ax_out.set_xlabel(config.output.name)
    ax_out.set_ylim(-0.02, 1.1)
    ax_out.legend(fontsize=7, loc="upper right")
    ax_out.set_title("Implication (min), aggregation (max), centroid")
    if title:
        fig.suptitle(title)
    fig.tight_layout()
    return _save(fig, path)


def plot_area_vs_level(report: GradeReport, path: Path) -> Path:
    """Area against the force level of every labelled trial (Fig. 15), graded right in
    one colour and wrong in another, with the Pearson r."""
    by_level = report.summary.correlation_with == "force_level"
    pts = [(t.true_level if by_level else report.grades.index(t.true_grade), t.area,
            t.error) for t in report.trials
           if np.isfinite(t.area) and (t.true_level if by_level else t.true_grade) is not None]
    fig, ax = plt.subplots(figsize=(7, 4.5))
    if pts:
        lv, ar, err = (np.array(v, dtype=np.float64) for v in zip(
            *[(p[0], p[1], np.nan if p[2] is None else p[2]) for p in pts], strict=True))
        right = err == 0
        ax.scatter(lv[right], ar[right], s=18, label="graded right")
        ax.scatter(lv[~right], ar[~right], s=30, marker="x", color="r",
                   label="graded wrong / ungraded")
        ax.legend(fontsize=8)
    r = report.summary.pearson_r
    ax.set_title("Area against force " + ("level" if by_level else "grade")
                 + (f", Pearson r = {r:.4f}" if r is not None else "") + " (cf. paper Fig. 15)")
    ax.set_xlabel("force level" if by_level else "true grade index")
    ax.set_ylabel("area of net pressing events (events)")
    fig.tight_layout()
    return _save(fig, path)


__all__ = ["plot_area_vs_level", "plot_inference", "plot_membership"]
