"""``tactile features spectral FILE --stream NAME``: the power ratio Gamma and the group
square coherence G2 of any multichannel stream, per sliding window and band, written as a
new stream that ``tactile train`` reads.

The file-level verb of this package (it reads and writes through :mod:`tactile_cli.store`;
the rest of the package is arrays in, arrays out). Every trial with the stream is cut into
windows of ``window_s`` every ``hop_s`` (a window's sample is stamped at its end); each
window's channels, or each channel group (``groups``, for example one group per finger),
give Gamma and G2 per band (:func:`._array_features.array_features`, every channel taken as
in contact and sampled at the same instant); with two or more groups, G2 across the groups
too (each group summed into one virtual channel). The input stream's per-sample labels are
carried over at each window's last sample, so a classifier trained on the features learns
the same targets. The taxel chain's own feature stream (contact estimation, slip labels
from its annotations) is :func:`tactile_cli.taxel.write_feature_stream`.

Many files: :func:`stream_features_each`, one task per file on Dask
(:func:`tactile_cli.batch.run_each`), each output written atomically by its worker.
"""

from __future__ import annotations

import fnmatch
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from ..batch import FileBatchResult, FileCounts, FileItem
from ..errors import InputError
from ..progress import NullProgress, Progress
from ..store.trials import TactileFile
from ..store.writer import StoreWriter
from ._array_features import array_features, finger_ensembles, multi_finger_g2

#: Name of the stream written.
FEATURE_STREAM = "spectral_features"


@dataclass(frozen=True)
class StreamFeaturesResult:
    """What :func:`write_stream_features` wrote: ``channels`` of the feature stream,
    ``rank_deficient`` bands (fewer segment-bin products than channels in a group: G2
    biased upward) and the channel ``groups`` used."""

    out: Path
    stream: str
    n_trials: int
    n_windows: int
    channels: tuple[str, ...]
    groups: tuple[tuple[str, ...], ...]
    window_s: float
    hop_s: float
    rank_deficient: tuple[str, ...]
    too_short: tuple[str, ...] = ()
    """Trials left out: their stream is shorter than one window."""

    def as_dict(self) -> dict[str, Any]:
        return {"out": str(self.out), "input_stream": self.stream, "stream": FEATURE_STREAM,
                "n_trials": self.n_trials, "n_windows": self.n_windows,
                "channels": list(self.channels), "groups": [list(g) for g in self.groups],
                "window_s": self.window_s, "hop_s": self.hop_s,
                "rank_deficient_bands": list(self.rank_deficient),
                "too_short": list(self.too_short)}


def channel_groups(names: Sequence[str], groups: Sequence[Sequence[str]] | None
                   ) -> list[list[int]]:
    """Column indices of each group of channel globs (``[["L_*"], ["R_*"]]``); None: one
    group of every channel. Each group needs two channels or more, and no channel may sit
    in two groups."""
    if not groups:
        picked = [list(range(len(names)))]
    else:
        picked = []
        for globs in groups:
            idx = [i for i, n in enumerate(names) if any(fnmatch.fnmatchcase(n, g)
                                                         for g in globs)]
            if not idx:
                raise InputError(f"`groups`: no channel matches {', '.join(globs)} "
                                 f"(channels: {', '.join(names)})")
            picked.append(idx)
        seen = [i for g in picked for i in g]
        if len(seen) != len(set(seen)):
            raise InputError("`groups`: a channel is in two groups")
    for g in picked:
        if len(g) < 2:
            raise InputError(f"`groups`: {', '.join(names[i] for i in g)} is one channel; "
                             "Gamma and G2 compare two or more")
    return picked


def named_bins(f_hz: np.ndarray, bands_hz: Mapping[str, tuple[float, float]]
               ) -> tuple[list[str], np.ndarray, np.ndarray]:
    """Band names (``full`` last: bins 1 .. end) and their inclusive Welch bin ranges."""
    df = float(f_hz[1] - f_hz[0])
    top = len(f_hz) - 1
    names, lo, hi = [], [], []
    for name, (a, b) in bands_hz.items():
        if not 0 <= a < b:
            raise InputError(f"`bands_hz` {name}: {a:g}-{b:g} Hz is not a band (0 <= low < "
                             "high)")
        i = int(np.clip(np.ceil(a / df - 1e-9), 1, top))
        j = int(np.clip(np.floor(b / df + 1e-9), i, top))
        names.append(name)
        lo.append(i)
        hi.append(j)
    return names + ["full"], np.array(lo + [1]), np.array(hi + [top])


def write_stream_features(
    path: str | Path,
    out: str | Path,
    *,
    stream: str,
    window_s: float = 1.0,
    hop_s: float = 0.25,
    nperseg: int = 64,
    noverlap: int | None = None,
    bands_hz: Mapping[str, tuple[float, float]] | None = None,
    groups: Sequence[Sequence[str]] | None = None,
    command: str | None = None,
    config: Mapping[str, Any] | None = None,
    overwrite: bool = False,
    progress: Progress | None = None,
) -> StreamFeaturesResult:
    """Gamma and G2 per window and band of ``stream`` in every trial of ``path`` that has
    it, written to ``out`` as stream ``spectral_features`` (see the module docstring).

    Channels of the output: ``gamma_<band>`` and ``g2_<band>`` (the groups' mean), and
    ``g2_groups_<band>`` with two groups or more. ``nperseg``: Welch segment (samples, at
    most the window), ``noverlap`` default half. A trial whose stream is shorter than one
    window is left out and named in the result (``too_short``); none left is an error."""
    progress = progress or NullProgress()
    if not (window_s > 0 and hop_s > 0):
        raise InputError(f"`window_s` (={window_s}) and `hop_s` (={hop_s}) must be positive")
    bands = dict(bands_hz or {})
    n_windows = 0
    channels: tuple[str, ...] = ()
    flagged: set[str] = set()
    short: list[str] = []
    used_groups: tuple[tuple[str, ...], ...] = ()
    written_trials = 0
    with TactileFile(path) as tf, StoreWriter(out, command=command, config=dict(config or {}),
                                              overwrite=overwrite) as w:
        source = w.add_source(path)
        trials = [t for t in tf.trials() if t.has_signal(stream)]
        if not trials:
            raise InputError(f"no trial has a stream {stream!r}", path=tf.path)
        progress.start(len(trials), "spectral features")
        sensor = None
        for trial in trials:
            sig = trial.signal(stream)
            rate = 1.0 / sig.sample_period_s
            win = int(round(window_s * rate))
            hop = max(1, int(round(hop_s * rate)))
            seg = min(int(nperseg), win)
            if seg < 8:
                raise InputError(f"`window_s` (={window_s}) holds {win} samples of {stream!r} "
                                 "at its rate; a Welch segment needs at least 8",
                                 path=tf.path)
            overlap = seg // 2 if noverlap is None else min(int(noverlap), seg - 1)
            idx_groups = channel_groups(sig.channel_names, groups)
            f_hz = np.fft.rfftfreq(seg, 1.0 / rate)
            band_names, lo, hi = named_bins(f_hz, bands)
            n = len(sig.data)
            if n < win:
                short.append(trial.name)
                progress.advance(1)
                continue
            ends = np.arange(win, n + 1, hop)
            windows = np.asarray(sig.data, dtype=np.float64)[ends[:, None] - win
                                                              + np.arange(win)]
            feats = [array_features(windows[..., g], rate, lo, hi, nperseg=seg,
                                    noverlap=overlap) for g in idx_groups]
            values = [np.nanmean([f.gamma for f in feats], axis=0),
                      np.nanmean([f.g2 for f in feats], axis=0)]
            names = ["gamma", "g2"]
            if len(idx_groups) >= 2:
                contacts = [np.ones(len(g), dtype=bool) for g in idx_groups]
                values.append(multi_finger_g2(finger_ensembles(feats, None, contacts), lo, hi))
                names.append("g2_groups")
            n_seg = (win - overlap) // (seg - overlap)
            smallest = min(len(g) for g in idx_groups)
            flagged |= {b for b, a in zip(band_names, n_seg * (hi - lo + 1), strict=True)
                        if a < smallest}
            these = tuple(f"{feat}_{b}" for feat in names for b in band_names)
            if sensor is None:
                channels = these
                used_groups = tuple(tuple(sig.channel_names[i] for i in g) for g in idx_groups)
                sensor = w.add_sensor(
                    f"{stream}_spectral", kind=sig.sensor.kind, sample_rate_hz=1.0 / hop_s,
                    channel_names=channels, channel_units="1", input_stream=stream,
                    window_s=window_s, hop_s=hop_s, nperseg=seg, noverlap=overlap,
                    groups=";".join(",".join(g) for g in used_groups),
                    description="power ratio Gamma and group square coherence G2 per "
                    f"window and band of stream {stream} (paper 004)")
            elif these != channels:
                raise InputError(f"trial {trial.name!r}: stream {stream!r} gives other "
                                 "feature channels than the first trial (another rate or "
                                 "channel set)", path=tf.path)
            labels = {name: (lab.values[ends - 1], lab.classes)
                      for name, lab in sig.sample_labels.items()}
            tw = w.trial(trial.name, labels=trial.labels, split=trial.split, sources=[source],
                         annotations=[(a.start_s, a.end_s, a.label) for a in trial.annotations],
                         duration_s=trial.duration_s)
            tw.write_signal(FEATURE_STREAM, sensor=sensor,
                            data=np.nan_to_num(np.concatenate(values, axis=1)),
                            t_s=sig.t_s[ends - 1], sample_labels=labels)
            n_windows += len(ends)
            written_trials += 1
            progress.advance(1)
        progress.finish()
        if not written_trials:
            raise InputError(f"every trial's {stream!r} is shorter than one window "
                             f"({window_s:g} s): {', '.join(short[:5])}", path=tf.path)
        written = w.commit()
    return StreamFeaturesResult(written, stream, written_trials, n_windows, channels,
                                used_groups, window_s, hop_s, tuple(sorted(flagged)),
                                tuple(short))


def stream_features_task(spec: dict[str, Any]) -> dict[str, Any]:
    """One task of :func:`stream_features_each` (module level, so Dask workers import it):
    spec ``{"input", "output", "settings" (the keyword arguments of
    :func:`write_stream_features`), "command"}``; returns the result as a dict, with the
    trials left out as notes."""
    result = write_stream_features(spec["input"], spec["output"], overwrite=True,
                                   command=spec["command"], config=spec["settings"],
                                   **spec["settings"])
    out = result.as_dict()
    out["notes"] = ([f"left out, shorter than one window: {', '.join(result.too_short)}"]
                    if result.too_short else [])
    return out


def stream_features_each(
    inputs: Sequence[str | Path],
    out_dir: str | Path,
    *,
    settings: Mapping[str, Any],
    overwrite: bool = False,
    scheduler: str | None = None,
    workers: int | None = None,
    command: str | None = None,
    on_plan: Callable[[list[FileItem]], None] | None = None,
    on_progress: Callable[[FileCounts], None] | None = None,
    on_item: Callable[[FileItem], None] | None = None,
) -> FileBatchResult:
    """The features of each input file into ``<out_dir>/<input stem>.h5``, one task per
    file on Dask (:func:`tactile_cli.batch.run_each`); ``settings``: the keyword arguments
    of :func:`write_stream_features` (``stream``, ``window_s``, ...). Outputs newer than
    their input are skipped unless ``overwrite``; a failed file never stops the others.
    Refused before any work: a missing input, two inputs of one stem, an output that is a
    folder."""
    from ..batch import plan_outputs, run_each
    from ..store.provenance import current_command

    items = plan_outputs(inputs, out_dir, overwrite=overwrite)
    out = Path(out_dir)
    if on_plan is not None:
        on_plan(items)
    out.mkdir(parents=True, exist_ok=True)
    command = command if command is not None else current_command()
    base = dict(settings)
    return run_each(stream_features_task, items,
                    lambda item: {"input": item.input, "output": item.output,
                                  "settings": base, "command": command},
                    verb="features", out_dir=str(out), scheduler=scheduler,
                    workers=workers, on_progress=on_progress, on_item=on_item)


__all__ = ["FEATURE_STREAM", "StreamFeaturesResult", "channel_groups", "named_bins",
           "stream_features_each", "stream_features_task", "write_stream_features"]
