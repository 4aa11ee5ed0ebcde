"""Quick-look figures of a tactile HDF5 file, and an HTML page that shows them.

One figure per trial and modality:

- events: counts per 20 ms bin by polarity and their net (the accumulation the event-camera
  paper uses, 000 section 4), beside the net-polarity event frame of the whole trial;
- signals: every stream over time (up to 8 channels drawn), categorical per-sample labels
  shaded behind;
- frames: the no-contact reference, the frame that differs most from it, and their
  absolute difference.
"""

from __future__ import annotations

import base64
import html
import json
from dataclasses import dataclass
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from ..errors import InputError  # noqa: E402
from ..interrupt import raise_if_requested  # noqa: E402
from ..store.atomic import write_text  # noqa: E402
from ..store.reader import summarize  # noqa: E402
from ..store.trials import Frames, Signal, TactileFile, Trial, TrialEvents  # noqa: E402

BIN_US = 20_000
MAX_CHANNELS_DRAWN = 8
LABEL_COLOURS = ["#cfe8ff", "#ffe0c2", "#d8f5d0", "#f5d0e8", "#e8e8e8", "#fff5b8"]


@dataclass
class Figure:
    """A written figure: its file and a caption."""

    path: Path
    caption: str


def event_counts(
    t_us: np.ndarray, p: np.ndarray, *, bin_us: int = BIN_US
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Events per bin: (bin start in s from the first event (n_bins,), ON counts, OFF counts)."""
    if t_us.size == 0:
        return np.zeros(0), np.zeros(0, np.int64), np.zeros(0, np.int64)
    b = (t_us - t_us[0]) // bin_us
    n_bins = int(b[-1]) + 1
    on = np.bincount(b[p > 0], minlength=n_bins)
    off = np.bincount(b[p < 0], minlength=n_bins)
    return np.arange(n_bins) * bin_us * 1e-6, on, off


def _events_figure(events: TrialEvents, title: str, out: Path) -> None:
    sensor = events.sensor
    if sensor.width_px is None or sensor.height_px is None:
        raise InputError("an event camera needs width_px and height_px", path=events.path,
                         where=f"/sensors/{sensor.name}")
    width, height = sensor.width_px, sensor.height_px
    ev = events.all()
    t, p, x, y = ev.t_us, ev.p, ev.x, ev.y
    start, on, off = event_counts(t, p)
    frame = np.zeros((height, width), dtype=np.int64)
    np.add.at(frame, (y, x), p.astype(np.int64))
    fig, (a0, a1) = plt.subplots(1, 2, figsize=(12, 3.6), gridspec_kw={"width_ratios": [2, 1]})
    a0.plot(start, on, lw=0.8, label="ON (+1)")
    a0.plot(start, off, lw=0.8, label="OFF (-1)")
    a0.plot(start, on - off, lw=1.0, color="k", label="net")
    a0.set_xlabel("time since first event (s)")
    a0.set_ylabel(f"events per {BIN_US // 1000} ms")
    a0.legend(loc="upper right", fontsize=8)
    lim = max(1, int(np.percentile(np.abs(frame), 99.5)))
    im = a1.imshow(frame, cmap="coolwarm", vmin=-lim, vmax=lim, interpolation="nearest")
    a1.set_title("net polarity per pixel", fontsize=9)
    fig.colorbar(im, ax=a1, fraction=0.046)
    fig.suptitle(title, fontsize=10)
    fig.tight_layout()
    fig.savefig(out, dpi=90)
    plt.close(fig)


def _shade_labels(ax, t: np.ndarray, labels: np.ndarray, classes: list[str]) -> None:
    change = np.flatnonzero(np.diff(labels)) + 1
    starts = np.r_[0, change]
    ends = np.r_[change, len(labels)]
    seen = set()
    for s, e in zip(starts, ends, strict=True):
        k = int(labels[s])
        name = classes[k] if 0 <= k < len(classes) else str(k)
        ax.axvspan(
            t[s],
            t[min(e, len(t) - 1)],
            color=LABEL_COLOURS[k % len(LABEL_COLOURS)],
            lw=0,
            label=None if name in seen else name,
            zorder=0,
        )
        seen.add(name)


def _baseline_dominates(data: np.ndarray) -> tuple[bool, np.ndarray]:
    """Whether per-channel offsets hide the signal, and those offsets (first 5 % mean).

    Raw taxel counts sit at 15k..40k and change by hundreds: drawn as they are, every line
    is flat. When the spread of channel offsets is more than 5x the largest within-channel
    variation, the figure draws the change from the start instead.
    """
    k = max(1, len(data) // 20)
    offsets = data[:k].mean(axis=0)
    spread = float(np.ptp(offsets)) if offsets.size else 0.0
    variation = float(np.max(np.std(data - offsets, axis=0))) if data.size else 0.0
    return spread > 5 * max(variation, 1e-12), offsets


def _varying_label(s: Signal) -> tuple[str, np.ndarray, list[str]] | None:
    """The categorical per-sample label with the most changes of class (None if all constant)."""
    best, best_changes = None, 0
    for lname, label in s.sample_labels.items():
        if label.classes is None:
            continue
        changes = int(np.count_nonzero(np.diff(label.values)))
        if changes > best_changes:
            best, best_changes = (lname, label.values, list(label.classes)), changes
    return best


def _signals_figure(trial: Trial, title: str, out: Path) -> None:
    streams = trial.signal_names
    fig, axes = plt.subplots(len(streams), 1, figsize=(12, 2.6 * len(streams)), squeeze=False)
    for ax, name in zip(axes[:, 0], streams, strict=True):
        s = trial.signal(name)  # one stream in memory at a time
        data, t = s.data, s.t_s
        # the sensor's own names and units: none drawn as the column number, as before
        channels, units = s.sensor.channel_names, s.sensor.channel_units
        delta, offsets = _baseline_dominates(data)
        if delta:
            data = data - offsets
        step = max(1, len(t) // 20000)  # draw at most ~20k points per line
        shown = data[::step, :MAX_CHANNELS_DRAWN]
        for k in range(shown.shape[1]):
            ax.plot(
                t[::step], shown[:, k], lw=0.7, label=channels[k] if k < len(channels) else str(k)
            )
        if data.shape[1] > MAX_CHANNELS_DRAWN:
            ax.plot(t[::step], data[::step].mean(axis=1), lw=1.2, color="k", label="mean of all")
        label = _varying_label(s)
        if label is not None:
            _shade_labels(ax, t, label[1], label[2])
        more = data.shape[1] - shown.shape[1]
        unit = f" ({units[0]})" if len(set(units)) == 1 else ""
        ax.set_ylabel(("change in " if delta else "") + f"{name}{unit}", fontsize=8)
        ax.set_title(
            f"{name}: {data.shape[0]} samples x {data.shape[1]} channels"
            + (f" ({more} not drawn)" if more > 0 else "")
            + (", change from the first 5 %" if delta else "")
            + (f"; shaded: {label[0]}" if label else ""),
            fontsize=9,
        )
        ax.legend(loc="upper left", bbox_to_anchor=(1.005, 1.0), fontsize=7, frameon=False)
    axes[-1, 0].set_xlabel("time (s)")
    fig.suptitle(title, fontsize=10)
    fig.tight_layout()
    fig.savefig(out, dpi=90)
    plt.close(fig)


def _frames_figure(frames: Frames, title: str, out: Path) -> None:
    ref = frames.reference
    # frames are read one at a time: a long sequence never sits in memory
    diffs = np.array([np.abs(image.astype(np.int16) - ref).mean() for _, image in frames])
    k = int(np.argmax(diffs)) if diffs.size else 0
    frame = frames[k] if frames.n_frames else ref
    diff = np.abs(frame.astype(np.int16) - ref).sum(axis=2)
    fig, axes = plt.subplots(1, 4, figsize=(14, 3.4), gridspec_kw={"width_ratios": [1, 1, 1, 1.3]})
    axes[0].imshow(ref)
    axes[0].set_title("reference (no contact)", fontsize=9)
    axes[1].imshow(frame)
    axes[1].set_title(f"frame {k} (largest change)", fontsize=9)
    axes[2].imshow(diff, cmap="magma")
    axes[2].set_title("|frame - reference|", fontsize=9)
    for a in axes[:3]:
        a.axis("off")
    axes[3].plot(frames.t_s, diffs)
    axes[3].set_xlabel("time (s)")
    axes[3].set_ylabel("mean |frame - ref|")
    fig.suptitle(title, fontsize=10)
    fig.tight_layout()
    fig.savefig(out, dpi=90)
    plt.close(fig)


def quicklook(path: str | Path, out_dir: str | Path, *, max_trials: int = 4) -> list[Figure]:
    """Write quick-look PNGs of the first ``max_trials`` trials of a file into ``out_dir``."""
    path = Path(path)
    out_dir = Path(out_dir)
    figures: list[Figure] = []
    with TactileFile(path) as tf:
        out_dir.mkdir(parents=True, exist_ok=True)
        for name in tf.trial_names[:max_trials]:
            raise_if_requested()  # Ctrl-C stops between figures (the CLI's handler only marks)
            trial = tf.trial(name)
            labels = ", ".join(f"{k}={v}" for k, v in trial.labels.items())
            title = f"{path.name} / {name}" + (f" ({labels})" if labels else "")
            if trial.has_events:
                f = out_dir / f"{path.stem}__{name}__events.png"
                _events_figure(trial.events, title, f)
                figures.append(Figure(f, f"{title}: events per 20 ms and net polarity per pixel"))
            raise_if_requested()
            if trial.signal_names:
                f = out_dir / f"{path.stem}__{name}__signals.png"
                _signals_figure(trial, title, f)
                figures.append(Figure(f, f"{title}: sampled streams"))
            raise_if_requested()
            if trial.has_frames:
                f = out_dir / f"{path.stem}__{name}__frames.png"
                _frames_figure(trial.frames(), title, f)
                figures.append(Figure(f, f"{title}: image frames"))
    return figures


def write_html(
    files: list[Path],
    out_dir: str | Path,
    *,
    max_trials: int = 4,
    title: str = "tactile quick look",
) -> Path:
    """One self-contained HTML page (figures embedded) with a summary and figures per file."""
    out_dir = Path(out_dir)
    parts = [
        f"<!doctype html><meta charset='utf-8'><title>{html.escape(title)}</title>",
        "<style>body{font-family:sans-serif;max-width:1200px;margin:auto}"
        "table{border-collapse:collapse}td,th{border:1px solid #ccc;padding:2px 6px;font-size:13px}"
        "img{max-width:100%}</style>",
        f"<h1>{html.escape(title)}</h1>",
    ]
    for f in files:
        raise_if_requested()
        s = summarize(f)
        parts.append(
            f"<h2>{html.escape(f.name)}</h2><p>schema {s.schema_version}, tactile "
            f"{html.escape(s.tool_version)}, {len(s.trials)} trials, {s.total_duration_s:.2f} s, "
            f"{s.n_sources} source files; command: <code>{html.escape(s.command)}</code></p>"
        )
        parts.append(
            "<table><tr><th>sensor</th><th>kind</th><th>rate (Hz)</th><th>channels</th>"
            "<th>geometry</th></tr>"
        )
        for sensor in s.sensors:
            parts.append(
                f"<tr><td>{html.escape(sensor.name)}</td><td>{sensor.kind}</td>"
                f"<td>{sensor.sample_rate_hz:g}</td><td>{sensor.n_channels}</td>"
                f"<td>{sensor.geometry}</td></tr>"
            )
        parts.append("</table>")
        if s.label_counts:
            parts.append(
                "<p>label counts: <code>" + html.escape(json.dumps(s.label_counts)) + "</code></p>"
            )
        for fig in quicklook(f, out_dir, max_trials=max_trials):
            data = base64.b64encode(fig.path.read_bytes()).decode()
            parts.append(
                f"<figure><img src='data:image/png;base64,{data}'>"
                f"<figcaption>{html.escape(fig.caption)}</figcaption></figure>"
            )
    return write_text(out_dir / "index.html", "\n".join(parts), overwrite=True)


def write_quicklook(files: list[str | Path], out: str | Path, *, max_trials: int = 4) -> Path:
    """The figures of the first ``max_trials`` trials of every file and one self-contained
    ``index.html`` (:func:`write_html`), added to folder ``out`` (same names replaced) when
    all are drawn. Raises :class:`InputError` before any figure for an output that is,
    holds or lies inside an input, one that cannot be written, or a file that does not
    open as a tactile file. Returns the page."""
    from ..input_guard import check_outputs
    from ..store.outdir import check_output_folder, output_folder

    if max_trials < 1:
        raise InputError(f"`max_trials` (={max_trials}) must be at least 1")
    paths = [Path(f) for f in files]
    check_outputs({"out": out}, paths)
    check_output_folder(out, merge=True)  # figures are added to it; a file there is not
    for f in paths:  # every input opens (schema gate included) before any work
        with TactileFile(f):
            pass
    with output_folder(out, merge=True) as tmp:  # in place only when every figure is
        write_html(paths, tmp, max_trials=max_trials)
    return Path(out) / "index.html"
