"""Read tactile HDF5 files: version gate, trial listing and the summary behind `tactile info`.

The summary says what a user needs to write a train config: each sensor's streams, rate,
channel names and units, the trial labels (trials per value) and per-sample labels
(samples per class), the splits; labels with many values are summarised
(:mod:`tactile_cli.store.labels`).
"""

from __future__ import annotations

from collections import Counter
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

import h5py
import numpy as np

from ..errors import InputError
from ..natural import natural_key
from .labels import LabelCounts, SampleLabelTally, count_trial_labels
from .trials import TactileFile, _reading, attr_value, open_checked

#: Channel names listed in full up to this many; a longer list is shown as its first
#: :data:`CHANNELS_HEAD` names, ``..``, the last name and the count.
MAX_CHANNELS_LISTED = 6
CHANNELS_HEAD = 3


def open_tactile(path: str | Path) -> h5py.File:
    """Open a tactile HDF5 file for reading after the schema version gate
    (:func:`~tactile_cli.store.validate.check_readable`); a file HDF5 cannot open is one
    :class:`InputError` line naming it (:func:`~tactile_cli.store.trials.open_checked`).
    Use as a context manager."""
    return open_checked(Path(path))[1]


def brief_names(names: list[str]) -> str:
    """``a, b, c`` for a few names; ``txl1_x, txl1_y, txl1_z .. txl16_z (48)`` for many."""
    if len(names) <= MAX_CHANNELS_LISTED:
        return ", ".join(names)
    return f"{', '.join(names[:CHANNELS_HEAD])} .. {names[-1]} ({len(names)})"


@dataclass
class SensorInfo:
    """One sensor: units are the distinct channel units (sorted); channel_names and
    channel_units one per channel; streams: the stream names it records, over all trials
    (what a train config names in ``data.stream``)."""

    name: str
    kind: str
    sample_rate_hz: float
    n_channels: int
    geometry: str
    units: list[str]
    channel_names: list[str] = field(default_factory=list)
    channel_units: list[str] = field(default_factory=list)
    streams: list[str] = field(default_factory=list)

    @property
    def channels_brief(self) -> str:
        """The channel names, abbreviated when there are many (:func:`brief_names`)."""
        return brief_names(self.channel_names)


@dataclass
class TrialInfo:
    name: str
    duration_s: float
    split: str
    labels: dict[str, Any]
    n_events: int
    streams: dict[str, list[int]]  # stream -> [n_samples, n_channels]
    n_frames: int
    n_annotations: int = 0  # time-interval annotations (AEDAT4 triggers among them)


@dataclass
class FileSummary:
    """What `tactile info` shows about one file."""

    file: str
    schema_version: str
    tool_version: str
    created_utc: str
    command: str
    n_sources: int
    sensors: list[SensorInfo] = field(default_factory=list)
    trials: list[TrialInfo] = field(default_factory=list)
    sample_labels: list[LabelCounts] = field(default_factory=list)

    @property
    def trial_labels(self) -> list[LabelCounts]:
        """Every trial label counted in trials per value (natural order)."""
        return count_trial_labels([t.labels for t in self.trials])

    @property
    def label_counts(self) -> dict[str, dict[str, int]]:
        """label -> value -> trials, every value (natural order)."""
        return {lc.name: dict(lc.counts or {}) for lc in self.trial_labels}

    @property
    def splits(self) -> dict[str, int]:
        """split -> trials (``""``: not assigned), in the order train, val, test, ``""``."""
        counts = Counter(t.split for t in self.trials)
        order = {"train": 0, "val": 1, "test": 2, "": 4}
        return {k: counts[k] for k in sorted(counts, key=lambda k: (order.get(k, 3), k))}

    @property
    def total_duration_s(self) -> float:
        return float(sum(t.duration_s for t in self.trials))

    def as_dict(self) -> dict[str, Any]:
        out = asdict(self)
        out["label_counts"] = self.label_counts
        out["trial_labels"] = [asdict(lc) for lc in self.trial_labels]
        out["splits"] = self.splits
        out["total_duration_s"] = self.total_duration_s
        return out


def summarize(path: str | Path) -> FileSummary:
    """Summarise a tactile file (sensors, trials, labels, durations).

    Reads through :class:`TactileFile`, so a missing or retyped node, or a corrupt one, is
    one :class:`InputError` naming the HDF5 path (sensor attributes are checked as every
    command checks them)."""
    with TactileFile(path) as f:
        a = f.attrs
        h5 = f._h5  # /sensors and /trials are groups (checked by TactileFile)
        with _reading(f.path, "/provenance/sources/path"):
            n_sources = int(h5["provenance/sources/path"].shape[0]) \
                if "provenance/sources/path" in h5 else 0
        summary = FileSummary(
            file=str(path),
            schema_version=f.schema_version,
            tool_version=str(a.get("tool_version", "")),
            created_utc=str(a.get("created_utc", "")),
            command=str(a.get("command", "")),
            n_sources=n_sources,
        )
        for name in f.sensor_names:
            sensor = f.sensor(name)
            geometry = ""
            if sensor.width_px is not None and sensor.height_px is not None:
                geometry = f"{sensor.width_px}x{sensor.height_px} px"
            else:
                with _reading(f.path, f"/sensors/{name}/taxel_positions_m"):
                    g = h5["sensors"][name]
                    if "taxel_positions_m" in g:
                        geometry = f"{g['taxel_positions_m'].shape[0]} taxels"
            summary.sensors.append(
                SensorInfo(name, sensor.kind, sensor.sample_rate_hz,
                           len(sensor.channel_names), geometry,
                           sorted(set(sensor.channel_units)),
                           channel_names=list(sensor.channel_names),
                           channel_units=list(sensor.channel_units))
            )
        by_name = {s.name: s for s in summary.sensors}
        tally = SampleLabelTally()
        for trial in f.trials():
            streams = {}
            for s_name in trial.signal_names:
                sensor_info = by_name.get(trial.signal_sensor(s_name).name)
                if sensor_info is not None and s_name not in sensor_info.streams:
                    sensor_info.streams.append(s_name)
                tally.add(s_name, trial.sample_labels(s_name))
                where = f"{trial.where}/signals/{s_name}/data"
                with _reading(f.path, where):
                    shape = list(trial._group["signals"][s_name]["data"].shape)
                if len(shape) != 2:
                    raise InputError(f"data has shape {tuple(shape)}; expected (n_samples, "
                                     "n_channels); `tactile validate FILE` lists every problem "
                                     "of the file", path=f.path, where=where)
                streams[s_name] = shape
            with _reading(f.path, trial.where):
                g = trial._group
                n_events = int(g["events/t"].shape[0]) if "events" in g else 0
                n_frames = int(g["frames/images"].shape[0]) if "frames" in g else 0
                n_annotations = (int(g["annotations/start_s"].shape[0])
                                 if "annotations/start_s" in g else 0)
            summary.trials.append(
                TrialInfo(
                    name=trial.name,
                    duration_s=trial.duration_s,
                    split=trial.split,
                    labels=trial.labels,
                    n_events=n_events,
                    streams=streams,
                    n_frames=n_frames,
                    n_annotations=n_annotations,
                )
            )
    for s in summary.sensors:
        s.streams.sort(key=natural_key)
    summary.sample_labels = tally.result()
    return summary


def trial_names(path: str | Path) -> list[str]:
    """Names of the trials of a tactile file, in file order."""
    with TactileFile(path) as f:
        return f.trial_names


def read_events(path: str | Path, trial: str) -> dict[str, np.ndarray]:
    """All events of one trial as arrays ``x, y, t, p`` (see the schema for dtypes)."""
    with TactileFile(path) as f:
        ev = f.trial(trial).events
        g = ev.slice(0, ev.n_events)
        # the stored dtypes (uint16 x/y), not the int64 of an EventWindow
        return {"x": g.x.astype(np.uint16), "y": g.y.astype(np.uint16), "t": g.t_us,
                "p": g.p}


def read_events_window(
    path: str | Path, trial: str, t0_ms: int, t1_ms: int
) -> dict[str, np.ndarray]:
    """Events of ``[t0_ms, t1_ms)`` milliseconds from the trial's time origin (events
    attribute ``t_origin_us``, else the first event), through the millisecond index; the
    same origin as :meth:`~tactile_cli.store.trials.TrialEvents.window`."""
    with TactileFile(path) as f:
        ev = f.trial(trial).events
        w = ev.window_us(ev.origin_us + 1000 * int(t0_ms), ev.origin_us + 1000 * int(t1_ms))
        return {"x": w.x.astype(np.uint16), "y": w.y.astype(np.uint16), "t": w.t_us, "p": w.p}


def read_signal(path: str | Path, trial: str, stream: str) -> dict[str, Any]:
    """One sampled stream: ``data`` (n, c) float32, ``t_s`` (n,), ``sensor`` and
    ``sample_labels`` (name -> values)."""
    with TactileFile(path) as f:
        s = f.trial(trial).signal(stream)
        return {"data": s.data, "t_s": s.t_s, "sensor": s.sensor.name,
                "sample_labels": {k: v.values for k, v in s.sample_labels.items()}}


def trial_source_hashes(path: str | Path) -> dict[str, frozenset[str]]:
    """Trial name -> the SHA-256 of the source files that are its own: read for it and for
    no other trial of the file (its ``source_index`` rows of ``/provenance/sources``; a
    file every trial shares, such as a scene a synthetic set was drawn from, or two
    trials' identical header-only files, identify no recording). Two trials with an own
    source in common hold the same recording, whichever tactile file they are in: what
    "the run trained on these trials" is checked by. Empty for a trial with none."""
    rows_of: dict[str, list[str]] = {}
    with open_tactile(path) as h5, _reading(Path(path), "/provenance/sources"):
        shas = ([attr_value(s) for s in h5["provenance/sources/sha256"][()]]
                if "provenance/sources/sha256" in h5 else [])
        for name, group in (h5["trials"].items() if "trials" in h5 else ()):
            index = group.attrs.get("source_index")
            rows = [] if index is None else np.atleast_1d(np.asarray(index)).tolist()
            rows_of[name] = sorted({str(shas[i]) for i in rows if 0 <= int(i) < len(shas)})
    uses = Counter(sha for rows in rows_of.values() for sha in rows)
    return {name: frozenset(sha for sha in rows if uses[sha] == 1)
            for name, rows in rows_of.items()}


#: Source-file suffixes that mark a file as derived from another tactile HDF5 file.
TACTILE_SUFFIXES = (".h5", ".hdf5")


def recording_hashes(path: str | Path, own_sha256: str) -> list[str]:
    """The SHA-256 of the recordings a file holds, for "same data" checks.

    A file written from other tactile HDF5 files (``tactile centroids`` turns a scene file
    into ROI centroid streams) holds the same recordings as its sources, so its identity is
    the sorted SHA-256 of those sources (``/provenance/sources`` rows whose path ends in
    ``.h5``/``.hdf5``). Any other file (ingested from raw recordings, or made by ``tactile
    synth``) is its own recording: ``[own_sha256]``.
    """
    with open_tactile(path) as h5, _reading(Path(path), "/provenance/sources"):
        if "provenance/sources/path" not in h5:
            return [own_sha256]
        paths = [attr_value(p) for p in h5["provenance/sources/path"][()]]
        shas = [attr_value(s) for s in h5["provenance/sources/sha256"][()]]
    derived = sorted({s for p, s in zip(paths, shas, strict=True)
                      if str(p).lower().endswith(TACTILE_SUFFIXES)})
    return derived or [own_sha256]
