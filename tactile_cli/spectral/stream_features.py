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
from its annotations) is :func:`tactile_cli.taxel.write_taxel_features`.

Both write through the one feature-stream writer, :func:`write_feature_stream`: a chain
computes each trial's windows (:class:`FeatureTrial`) and the writer makes the new file
(trials with their labels, split and annotations, one sensor per :class:`FeatureSensor`,
the provenance). :func:`window_plan` checks a window and hop against a stream's rate and
length before any work: a hop below one sample, or windows whose arrays would not fit in
memory, are refused with the estimate.

Many files: :func:`stream_features_each`, one task per file on Dask
(:func:`tactile_cli.batch.run_each`), each output written atomically by its worker.
"""

from __future__ import annotations

import fnmatch
from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from ..batch import FileBatchResult, FileCounts, FileItem
from ..errors import InputError
from ..progress import NullProgress, Progress
from ..store.trials import TactileFile, Trial
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

    def summary_lines(self) -> list[str]:
        return [f"wrote {self.out}: {self.n_trials} trial(s), {self.n_windows} windows of "
                f"{self.window_s:g} s every {self.hop_s:g} s, {len(self.channels)} channels "
                f"from {len(self.groups)} array(s) of {self.stream}"
                + (f"; rank-deficient bands (G2 biased up): {', '.join(self.rank_deficient)}"
                   if self.rank_deficient else "")]


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


@dataclass(frozen=True)
class FeatureSensor:
    """A sensor of a feature stream: ``name``, ``channels`` (``<feature>_<band>``), its
    ``kind``, ``sample_rate_hz`` (1 / hop) and further attributes (``description``,
    window, hop, ...)."""

    name: str
    channels: tuple[str, ...]
    kind: str
    sample_rate_hz: float
    attrs: Mapping[str, Any] = field(default_factory=dict)


@dataclass(frozen=True)
class FeatureTrial:
    """One trial's feature windows: the source ``trial`` (its labels, split, annotations
    and duration are copied), the ``sensor``, ``values`` (n_windows, n_channels) (NaN
    written as 0), ``t_s`` (n_windows,) each window's time and per-window
    ``sample_labels`` (name -> (values, classes or None))."""

    trial: Trial
    sensor: FeatureSensor
    values: np.ndarray
    t_s: np.ndarray
    sample_labels: Mapping[str, tuple[np.ndarray, Sequence[str] | None]] = field(
        default_factory=dict)


@dataclass(frozen=True)
class FeatureStreamWritten:
    """What :func:`write_feature_stream` wrote: the file, trials and windows."""

    out: Path
    n_trials: int
    n_windows: int


def write_feature_stream(path: str | Path, out: str | Path,
                         trials: Callable[[TactileFile], Iterable[FeatureTrial]], *,
                         command: str | None = None, config: Mapping[str, Any] | None = None,
                         overwrite: bool = False) -> FeatureStreamWritten:
    """The one writer of feature streams: open ``path``, write each :class:`FeatureTrial`
    that ``trials(file)`` yields as stream :data:`FEATURE_STREAM` of a new tactile file
    ``out`` (one sensor per :class:`FeatureSensor` name; every trial of a sensor must give
    its channels), with ``path`` as the source and ``config`` in the provenance. ``trials``
    raises :class:`InputError` when nothing is left to write; nothing is written then."""
    n_trials = n_windows = 0
    sensors: dict[str, tuple[str, tuple[str, ...]]] = {}
    with TactileFile(path) as tf, StoreWriter(out, command=command, config=dict(config or {}),
                                              overwrite=overwrite) as w:
        source = w.add_source(path)
        for ft in trials(tf):
            s, trial = ft.sensor, ft.trial
            if s.name not in sensors:
                sensors[s.name] = (w.add_sensor(
                    s.name, kind=s.kind, sample_rate_hz=s.sample_rate_hz,
                    channel_names=s.channels, channel_units="1", **s.attrs), s.channels)
            elif sensors[s.name][1] != s.channels:
                raise InputError(f"trial {trial.name!r} gives other feature channels than the "
                                 f"first trial of {s.name!r} (another rate or channel set)",
                                 path=tf.path)
            tw = w.trial(trial.name, labels=trial.labels, split=trial.split, sources=[source],
                         annotations=[(a.start_s, a.end_s, a.label) for a in trial.annotations],
                         duration_s=trial.duration_s)
            tw.write_signal(FEATURE_STREAM, sensor=sensors[s.name][0],
                            data=np.nan_to_num(ft.values), t_s=ft.t_s,
                            sample_labels=dict(ft.sample_labels))
            n_trials += 1
            n_windows += len(ft.t_s)
        written = w.commit()
    return FeatureStreamWritten(written, n_trials, n_windows)


def window_plan(window_s: float, hop_s: float, rate_hz: float, n_samples: int,
                n_channels: int, *, what: str, path: str | Path | None = None
                ) -> tuple[int, int]:
    """``(window, hop)`` in samples of windows ``window_s`` long every ``hop_s`` over a
    stream of ``n_samples`` x ``n_channels`` at ``rate_hz`` (``what`` names it), checked
    before any work: both positive and finite, the hop at least one sample, and the
    windows' arrays (the windows, their Welch segments and spectra: about 5 x the windowed
    samples in float64) within this machine's memory; one :class:`InputError` otherwise."""
    from ..config_file import check_fits_in_memory

    for name, value in (("window_s", window_s), ("hop_s", hop_s)):
        if not (np.isfinite(value) and value > 0):
            raise InputError(f"`{name}` (={value}) must be a positive number of seconds")
    win = int(round(window_s * rate_hz))
    hop = int(round(hop_s * rate_hz))
    if hop < 1:
        raise InputError(f"`hop_s` (={hop_s:g}) is shorter than one sample of {what} "
                         f"({1 / rate_hz:.3g} s); give a hop of one sample or more", path=path)
    n_windows = 0 if n_samples < win else (n_samples - win) // hop + 1
    check_fits_in_memory(5.0 * 8 * n_windows * win * max(1, n_channels),
                         f"`hop_s` (={hop_s:g}) with `window_s` (={window_s:g})",
                         f"for the {n_windows:,} windows of {what}", path=path, text=None,
                         keys=())
    return win, hop


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
    window is left out and named in the result (``too_short``); none left is an error.
    ``out`` may not be ``path`` (refused before any work, with or without ``overwrite``)."""
    from ..input_guard import check_outputs
    from ..store.atomic import check_output_file

    progress = progress or NullProgress()
    check_outputs({"out": out}, [path])
    check_output_file(out, overwrite=overwrite)
    if not (np.isfinite(window_s) and window_s > 0 and np.isfinite(hop_s) and hop_s > 0):
        raise InputError(f"`window_s` (={window_s}) and `hop_s` (={hop_s}) must be positive")
    bands = dict(bands_hz or {})
    flagged: set[str] = set()
    short: list[str] = []
    first: dict[str, Any] = {}  # channels and groups of the first trial written

    def windows_of(tf: TactileFile) -> Iterable[FeatureTrial]:
        trials = [t for t in tf.trials() if t.has_signal(stream)]
        if not trials:
            raise InputError(f"no trial has a stream {stream!r}", path=tf.path)
        progress.start(len(trials), "spectral features")
        for trial in trials:
            sig = trial.signal(stream)
            rate = 1.0 / sig.sample_period_s
            win, hop = window_plan(window_s, hop_s, rate, len(sig.data),
                                   len(sig.channel_names), what=repr(stream), path=tf.path)
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
            flagged.update(b for b, a in zip(band_names, n_seg * (hi - lo + 1), strict=True)
                           if a < smallest)
            these = tuple(f"{feat}_{b}" for feat in names for b in band_names)
            first.setdefault("channels", these)
            first.setdefault("groups", tuple(tuple(sig.channel_names[i] for i in g)
                                             for g in idx_groups))
            sensor = FeatureSensor(
                f"{stream}_spectral", these, sig.sensor.kind, 1.0 / hop_s, {
                    "input_stream": stream, "window_s": window_s, "hop_s": hop_s,
                    "nperseg": seg, "noverlap": overlap,
                    "groups": ";".join(",".join(g) for g in first["groups"]),
                    "description": "power ratio Gamma and group square coherence G2 per "
                    f"window and band of stream {stream} (paper 004)"})
            labels = {name: (lab.values[ends - 1], lab.classes)
                      for name, lab in sig.sample_labels.items()}
            yield FeatureTrial(trial, sensor, np.concatenate(values, axis=1),
                               sig.t_s[ends - 1], labels)
            progress.advance(1)
        progress.finish()
        if len(short) == len(trials):
            raise InputError(f"every trial's {stream!r} is shorter than one window "
                             f"({window_s:g} s): {', '.join(short[:5])}", path=tf.path)

    written = write_feature_stream(path, out, windows_of, command=command, config=config,
                                   overwrite=overwrite)
    return StreamFeaturesResult(written.out, stream, written.n_trials, written.n_windows,
                                first["channels"], first["groups"], window_s, hop_s,
                                tuple(sorted(flagged)), tuple(short))


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
    folder or an input, a folder that cannot be written."""
    from ..batch import plan_outputs, run_each
    from ..input_guard import check_outputs
    from ..store.outdir import check_output_folder
    from ..store.provenance import current_command

    items = plan_outputs(inputs, out_dir, overwrite=overwrite)
    check_outputs([item.output for item in items], inputs)
    check_output_folder(out_dir, merge=True)
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


def parse_bands(texts: Sequence[str] | None) -> dict[str, tuple[float, float]]:
    """``["mid=100-400"]`` -> ``{"mid": (100.0, 400.0)}`` (Hz); one :class:`InputError`
    naming ``bands_hz`` for a malformed text."""
    bands: dict[str, tuple[float, float]] = {}
    for text in texts or []:
        name, sep, span = text.partition("=")
        lo, dash, hi = span.partition("-")
        try:
            if not (sep and dash and name.strip()):
                raise ValueError
            bands[name.strip()] = (float(lo), float(hi))
        except ValueError:
            raise InputError(f"`bands_hz` {text!r}: give NAME=LOW-HIGH in Hz, e.g. "
                             "mid=100-400") from None
    return bands


def check_feature_modes(files: Sequence[Path], *, out: Path | None, out_dir: Path | None,
                        stream: str | None, scheduler: str | None = None,
                        workers: int | None = None, groups: Sequence[str] | None = None,
                        bands_hz: Sequence[str] | None = None,
                        config: Path | None = None) -> None:
    """Which arguments of a features run go together, refused in one line before any
    work: one input into ``out``, or several into ``out_dir`` (a stream's features only:
    the taxel-slip layout is one file per scene); ``scheduler``/``workers`` with
    ``out_dir``; ``groups``/``bands_hz`` with a ``stream``; ``config`` (the taxel-slip
    layout's) without one."""
    if (out is None) == (out_dir is None):
        raise InputError("give `out` (one input) or `out_dir` (one file per input)")
    if out_dir is not None and stream is None:
        raise InputError("`out_dir` goes with `stream` (the taxel-slip layout is one file "
                         "per scene: `out`)")
    if out is not None and len(files) > 1:
        raise InputError("`out` takes one input; give `out_dir` for several", path=files[1])
    if out is not None and (scheduler is not None or workers is not None):
        raise InputError("`scheduler` and `workers` go with `out_dir` (one task per file)")
    if stream is None and (groups or bands_hz):
        raise InputError("`groups` and `bands_hz` go with `stream`")
    if stream is not None and config is not None:
        raise InputError("`config` is the taxel-slip layout's; with `stream` give `window_s`, "
                         "`hop_s`, `nperseg`, `bands_hz` and `groups`")


__all__ = ["FEATURE_STREAM", "FeatureSensor", "FeatureStreamWritten", "FeatureTrial",
           "StreamFeaturesResult", "channel_groups", "check_feature_modes", "named_bins",
           "parse_bands", "stream_features_each",
           "stream_features_task", "window_plan", "write_feature_stream",
           "write_stream_features"]
