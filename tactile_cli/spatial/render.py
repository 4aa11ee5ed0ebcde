"""Pictures of the spatial chain: event frames as PNGs, a contact sheet with the ROIs drawn
(paper 000, Fig. 13) and the centroid / velocity / displacement curves of a slip (Fig. 23).

Every file goes through the store's atomic writer (a temporary name, then a rename), so an
interrupted run never leaves a truncated PNG; each PNG carries the command and tool version
in its text chunks.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from matplotlib.patches import Rectangle  # noqa: E402
from PIL import Image, PngImagePlugin  # noqa: E402

from ..interrupt import raise_if_requested  # noqa: E402
from ..store.atomic import atomic_file, save_figure  # noqa: E402
from ..store.trials import Trial  # noqa: E402
from .roi import Roi  # noqa: E402
from .slip_rate import SlipRateEstimate  # noqa: E402

KINDS: tuple[str, ...] = ("polarity", "net", "positive", "negative")


def _scale(counts: np.ndarray) -> np.ndarray:
    """Counts -> [0, 1], saturating at the 99th percentile of the non-zero counts (at
    least 1), so a few hot pixels do not black out the rest."""
    nz = counts[counts > 0]
    sat = max(1.0, float(np.percentile(nz, 99))) if nz.size else 1.0
    return np.clip(counts / sat, 0.0, 1.0)


def frame_rgb(positive: np.ndarray, negative: np.ndarray, *, kind: str = "polarity") -> np.ndarray:
    """(H, W, 3) uint8 picture of one frame's (H, W) counts.

    polarity: positive events green, negative red, both yellow, on black; net: positive
    net blue and negative net red on white; positive / negative: that polarity in white on
    black.
    """
    if kind not in KINDS:
        raise ValueError(f"`kind` (={kind!r}) must be one of {', '.join(KINDS)}")
    h, w = positive.shape
    rgb = np.zeros((h, w, 3), dtype=np.float64)
    if kind == "polarity":
        rgb[..., 1] = _scale(positive)
        rgb[..., 0] = _scale(negative)
    elif kind == "net":
        net = positive.astype(np.int64) - negative
        up, down = _scale(np.clip(net, 0, None)), _scale(np.clip(-net, 0, None))
        rgb[:] = 1.0
        rgb[..., 0] -= up  # blue for positive net
        rgb[..., 1] -= np.maximum(up, down)
        rgb[..., 2] -= down  # red for negative net
    else:
        rgb[:] = _scale(positive if kind == "positive" else negative)[..., None]
    return np.round(rgb * 255).astype(np.uint8)


def _png_info(meta: Mapping[str, str]) -> PngImagePlugin.PngInfo:
    info = PngImagePlugin.PngInfo()
    for key, value in meta.items():
        info.add_text(key, value)
    return info


def write_png(path: str | Path, rgb: np.ndarray, *,
              meta: Mapping[str, str] | None = None) -> Path:
    """Write (H, W, 3) uint8 ``rgb`` atomically (temporary file + rename)."""
    path = Path(path)
    with atomic_file(path, overwrite=True) as tmp:
        Image.fromarray(rgb, mode="RGB").save(tmp, format="PNG", compress_level=3,
                                              pnginfo=_png_info(meta or {}))
    return path


def contact_sheet(
    frames: Sequence[tuple[float, np.ndarray]],
    path: str | Path,
    *,
    rois: Sequence[Roi] = (),
    title: str = "",
    window_s: float,
    meta: Mapping[str, str] | None = None,
) -> Path:
    """One PNG of (t_s, (H, W, 3) uint8) frames in a grid, ROIs drawn as rectangles and each
    tile titled with its window ``[t, t + window_s)`` (as Fig. 13 highlights the ROIs)."""
    n = len(frames)
    if n == 0:
        raise ValueError("no frames for the contact sheet")
    cols = min(n, 6)
    rows = -(-n // cols)
    h, w = frames[0][1].shape[:2]
    tile_in = 2.4
    fig, axes = plt.subplots(rows, cols, figsize=(cols * tile_in, rows * tile_in * h / w + 0.6),
                             squeeze=False)
    for ax in axes.ravel():
        ax.axis("off")
    for ax, (t_s, rgb) in zip(axes.ravel(), frames, strict=False):
        ax.imshow(rgb, interpolation="nearest")
        for r in rois:
            ax.add_patch(Rectangle((r.x0_px - 0.5, r.y0_px - 0.5), r.width_px, r.height_px,
                                   fill=False, edgecolor="#00bfff", linewidth=0.8))
        ax.set_title(f"{t_s:.3f}-{t_s + window_s:.3f} s", fontsize=7)
    if title:
        fig.suptitle(title, fontsize=9)
    fig.tight_layout()
    return save_figure(fig, path, meta=meta, dpi=110, overwrite=True)


def plot_slip(estimate: SlipRateEstimate, path: str | Path, *,
              meta: Mapping[str, str] | None = None) -> Path:
    """Fig. 23 for one trial: centroid y per ROI (shifted to a common intercept) with the
    line fitted over the trimmed slip region, and the velocity (eq. 20, mm/s) and the
    displacement (eq. 21, mm) over the slip region."""
    r, tr = estimate.result, estimate.trace
    if tr is None:
        raise ValueError(f"trial {r.trial!r} has no slip trace ({r.status}: {r.message})")
    m = r.strip_m_per_px
    fig, axes = plt.subplots(3, 1, figsize=(7, 7.5), sharex=True)
    a0, a1, a2 = axes
    # each ROI shifted to the ROIs' mean intercept, so the curves overlay in image px
    base = float(np.nanmean(tr.intercepts_px))
    for j, roi in enumerate(tr.rois):
        a0.plot(tr.t_s, tr.centroid_y_px[:, j] - tr.intercepts_px[j] + base, lw=0.6,
                alpha=0.6, label=roi.name)
    a0.plot(tr.t_s, tr.aligned_y_px + base, color="k", lw=1.0, label="ROI mean")
    a0.plot(tr.t_s[tr.in_fit], tr.fitted_y_px[tr.in_fit] + base, color="#d62728", lw=1.6,
            label=f"fit: {r.velocity_px_s:.1f} px/s = {r.speed_m_s * 1e3:.3f} mm/s")
    a0.set_ylabel("centroid y (px), eq. 19")
    a0.invert_yaxis()  # image rows grow downwards
    a0.legend(fontsize=7, loc="best")
    a1.plot(tr.t_s, tr.velocity_px_s * m * 1e3, color="#1f77b4", lw=0.8)
    a1.axhline(np.sign(r.velocity_px_s) * r.speed_m_s * 1e3, color="#d62728", lw=1.0, ls="--",
               label="fitted slope")
    a1.set_ylabel("velocity y (mm/s), eq. 20")
    a1.legend(fontsize=7, loc="best")
    a2.plot(tr.t_s, tr.displacement_px * m * 1e3, color="#2ca02c", lw=1.0)
    a0.axvspan(r.fit_start_s, r.fit_end_s, color="#d62728", alpha=0.06, lw=0)
    a2.set_ylabel("displacement y (mm), eq. 21")
    a2.set_xlabel("time (s)")
    for ax in axes:
        ax.axvspan(r.slip_start_s, r.slip_end_s, color="#ffe0c2", alpha=0.5, lw=0)
    truth = "" if r.truth_speed_m_s is None else f", truth {r.truth_speed_m_s * 1e3:.3f} mm/s"
    fig.suptitle(f"{r.trial}: slip speed {r.speed_m_s * 1e3:.3f} +- "
                 f"{r.speed_se_m_s * 1e3:.3f} mm/s{truth}; displacement "
                 f"{r.displacement_m * 1e3:.3f} +- {r.displacement_se_m * 1e3:.3f} mm",
                 fontsize=9)
    fig.tight_layout()
    return save_figure(fig, path, meta=meta, overwrite=True)


def write_trial_frames(
    trial: Trial,
    out_dir: str | Path,
    *,
    window_s: float,
    median: int = 1,
    kind: str = "polarity",
    rois: Sequence[Roi] = (),
    start_s: float = 0.0,
    end_s: float | None = None,
    sheet_max: int = 24,
    frame_pngs: bool = True,
    meta: Mapping[str, str] | None = None,
) -> dict[str, object]:
    """The event frames of one trial as ``out_dir/frame_NNNN.png`` (unless ``frame_pngs`` is
    False) and ``out_dir/contact_sheet.png`` (up to ``sheet_max`` frames evenly spread over
    the trial, ROIs drawn). Returns a summary: trial, n_frames, window_s, median, kind,
    frames (file names), contact_sheet, sheet_t_s."""
    from .frames import iter_trial_frames
    from .trial_events import spatial_events

    if kind not in KINDS:
        raise ValueError(f"`kind` (={kind!r}) must be one of {', '.join(KINDS)}")
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    trial_end_s = spatial_events(trial).end_s
    stop_s = trial_end_s if end_s is None else end_s
    window_us = round(window_s * 1e6)
    n_total = max(0, -(-round((stop_s - start_s) * 1e6) // window_us))
    if n_total == 0:
        raise ValueError(f"no frames: the window [{start_s}, {stop_s}) s is empty")
    chosen = set(np.unique(np.linspace(0, n_total - 1, min(sheet_max, n_total)).round()
                           .astype(int)).tolist())
    sheet: list[tuple[float, np.ndarray]] = []
    names: list[str] = []
    k = 0
    for batch in iter_trial_frames(trial, window_s=window_s, start_s=start_s, end_s=stop_s,
                                   median=median):
        raise_if_requested()  # the CLI's Ctrl-C handler only marks the request
        for i in range(batch.n_frames):
            rgb = frame_rgb(batch.positive[i], batch.negative[i], kind=kind)
            if frame_pngs:
                name = f"frame_{k:04d}.png"
                write_png(out_dir / name, rgb,
                          meta={**(meta or {}),
                                "Description": f"{trial.name} t={batch.t_s[i]:.6f} s"})
                names.append(name)
            if k in chosen:
                sheet.append((float(batch.t_s[i]), rgb))
            k += 1
    title = (f"{trial.name}: {kind} event frames, {window_s * 1e3:g} ms windows"
             f"{f', median {median}x{median}' if median > 1 else ''}")
    contact_sheet(sheet, out_dir / "contact_sheet.png", rois=rois, title=title,
                  window_s=window_s, meta=meta)
    return {"trial": trial.name, "n_frames": k, "window_s": window_s, "median": median,
            "kind": kind, "frames": names, "contact_sheet": "contact_sheet.png",
            "sheet_t_s": [t for t, _ in sheet]}
