"""The grader's input: the area of net pressing events in each trial's press region.

Paper 000, sec. 4.4 and Fig. 15: the pressing-force extent shows in the area under the net
(positive minus negative) event count over the press region. Here the area is the sum of
the net counts of the bins whose centre lies in the press region, in events (the count
per bin summed over bins, so it does not depend on the bin width).

Where the numbers come from, per trial of a tactile HDF5 file:

- net counts: the trial's events binned by :func:`tactile_cli.events.trial_counts`, else
  a sampled stream with a ``net`` channel (``signals/event_counts`` written by
  ``tactile synth`` or ``tactile accumulate --out``);
- press region: the trial's annotation labelled ``press``, else the stream's per-sample
  ``action`` labels, else :func:`tactile_cli.events.segment_actions` on the net counts.

A plain CSV ``trial,area[,level]`` gives the areas directly (any sensor); ``level`` is an
integer force level or a grade name. A trial whose press region cannot be found gets a
NaN area and a status saying why; the other trials are unaffected.

With ``kind="fos_alpha"`` the input is instead the press gain alpha_1 that ``tactile
fit-fos`` stored in ``/derived/fits/fos_press`` (events per bin): the area is proportional
to alpha_1 times the press duration, so when the duration varies much from press to press
the fitted gain is the better force measure (a +-25 % spread: 72.9 % graded right against
20.8 % for the area); with a repeatable press (+-1.25 %) the noise of the fitted duration
makes it the worse one (91.8 % against 94.7 % on held-out scenes, benchmarks/RESULTS.md).
A trial whose fit did not converge gets NaN.
"""

from __future__ import annotations

import csv
import io
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from ..config_file import missing_file_error, read_text
from ..errors import InputError
from ..store.trials import TactileFile, Trial, is_hdf5
from ..vocabulary import BIN_S

#: Trial labels the grader reads as the truth.
LABEL_KEYS = ("force_grade", "force_level")


@dataclass(frozen=True)
class TrialArea:
    """One trial's grader input.

    ``area`` net events in the press region (NaN when no region was found, see
    ``status``); ``region_start_s``/``region_end_s`` the region in trial seconds (NaN for a
    CSV); ``source`` where the region came from (``annotations``, ``sample_labels``,
    ``segmentation``, ``csv``); ``labels`` the trial's ``force_grade``/``force_level``
    labels when it has them.
    """

    file: str
    trial: str
    area: float
    region_start_s: float = float("nan")
    region_end_s: float = float("nan")
    source: str = ""
    labels: dict[str, Any] = field(default_factory=dict)
    status: str = "ok"


def press_area(net: np.ndarray, t_s: np.ndarray, start_s: float, end_s: float) -> float:
    """Sum of ``net`` (n_bins,) over the bins whose centre ``t_s`` (n_bins,) lies in
    ``[start_s, end_s)``, events."""
    t_s = np.asarray(t_s, dtype=np.float64)
    inside = (t_s >= start_s) & (t_s < end_s)
    return float(np.asarray(net, dtype=np.float64)[inside].sum())


def load_areas(paths: list[Path], *, bin_s: float = BIN_S, region: str = "press",
               kind: str = "area") -> list[TrialArea]:
    """Grader inputs of every trial of every file: tactile HDF5 files and ``.csv`` tables.
    ``kind`` ``area`` (the default) or ``fos_alpha`` (see the module docstring)."""
    if kind not in ("area", "fos_alpha"):
        raise ValueError(f"`kind` (={kind!r}) must be 'area' or 'fos_alpha'")
    out: list[TrialArea] = []
    for path in paths:
        path = Path(path)
        if not path.exists():
            raise missing_file_error(path)
        if path.suffix.lower() == ".csv":
            out.extend(read_area_csv(path))
        elif is_hdf5(path) and kind == "fos_alpha":
            out.extend(fos_alphas(path))
        elif is_hdf5(path):
            out.extend(hdf5_areas(path, bin_s=bin_s, region=region))
        else:
            raise InputError("neither a tactile HDF5 file nor a .csv table of areas "
                             "(trial,area[,level])", path=path)
    return out


# -- CSV -------------------------------------------------------------------------------------
def read_area_csv(path: str | Path) -> list[TrialArea]:
    """Rows ``trial,area[,level]`` under a header naming those columns (``level`` may also
    be called ``force_level`` or ``force_grade``)."""
    path = Path(path)
    reader = csv.reader(io.StringIO(read_text(path, "CSV file"), newline=""), strict=True)
    try:
        rows = list(reader)
    except csv.Error as exc:
        raise InputError(f"not valid CSV ({exc})", path=path,
                         where=f"line {reader.line_num}") from None
    if not rows:
        raise InputError("empty file; expected a header trial,area[,level]", path=path)
    header = [c.strip().lower() for c in rows[0]]
    level_names = ("level", "force_level", "force_grade")
    if header[:2] != ["trial", "area"] or len(header) > 3 or (
            len(header) == 3 and header[2] not in level_names):
        raise InputError(f"header {','.join(rows[0])!r} must be trial,area or "
                         "trial,area,level", path=path, where="line 1")
    out = []
    seen: set[str] = set()
    for line, row in enumerate(rows[1:], start=2):
        if not row or all(not c.strip() for c in row):
            continue
        if len(row) != len(header):
            raise InputError(f"{len(row)} fields, expected {len(header)} "
                             f"({','.join(header)})", path=path, where=f"line {line}")
        trial, area_text = row[0].strip(), row[1].strip()
        if not trial:
            raise InputError("empty trial name", path=path, where=f"line {line}")
        if any(ord(c) < 32 for c in trial):
            raise InputError(f"trial name {trial!r} holds control characters (binary data, or "
                             "a damaged file)", path=path, where=f"line {line}")
        if trial in seen:
            raise InputError(f"trial {trial!r} appears twice", path=path, where=f"line {line}")
        seen.add(trial)
        try:
            area = float(area_text)
        except ValueError:
            raise InputError(f"area {area_text!r} is not a number", path=path,
                             where=f"line {line}") from None
        if not math.isfinite(area):
            raise InputError(f"area {area_text!r} is not finite", path=path,
                             where=f"line {line}")
        labels: dict[str, Any] = {}
        if len(header) == 3 and row[2].strip():
            value = row[2].strip()
            try:
                level = int(value)
            except ValueError:
                if header[2] == "force_level":
                    raise InputError(f"force level {value!r} is not a whole number",
                                     path=path, where=f"line {line}") from None
                labels["force_grade"] = value
            else:
                labels["force_level"] = level
        out.append(TrialArea(str(path), trial, area, source="csv", labels=labels))
    return out


# -- HDF5 ------------------------------------------------------------------------------------
def hdf5_areas(path: str | Path, *, bin_s: float = BIN_S, region: str = "press") \
        -> list[TrialArea]:
    """Areas of every trial of one tactile HDF5 file (see the module docstring), the file
    opened once."""
    with TactileFile(path) as f:
        return [trial_area(trial, bin_s=bin_s, region=region) for trial in f]


def _grade_labels(trial: Trial) -> dict[str, Any]:
    """The trial's ``force_grade``/``force_level`` labels (those it has)."""
    return {k: v for k, v in trial.labels.items() if k in LABEL_KEYS}


def fos_alphas(path: str | Path) -> list[TrialArea]:
    """The fitted press gain of every trial of ``path`` (``/derived/fits/fos_press``)."""
    from ..fos.table import read_fit_group

    path = Path(path)
    with TactileFile(path) as f:
        cols = read_fit_group(path, "fos_press")
        labels = {name: _grade_labels(f.trial(name))
                  for name in dict.fromkeys(str(t) for t in cols["trial"])
                  if name in f.trial_names}
    out = []
    for k, trial in enumerate(cols["trial"]):
        ok = str(cols["status"][k]) == "converged" and np.isfinite(cols["alpha"][k])
        out.append(TrialArea(
            str(path), str(trial), float(cols["alpha"][k]) if ok else float("nan"),
            float(cols["region_start_s"][k]), float(cols["region_end_s"][k]), "fos_press",
            labels.get(str(trial), {}),
            "ok" if ok else f"press fit not converged: {cols['status'][k]}"))
    return out


def _net_stream(trial: Trial) -> dict[str, Any] | None:
    """net counts, bin centres, per-sample action labels of a stream with a ``net`` channel
    (``event_counts`` first), or None."""
    for stream_name in sorted(trial.signal_names, key=lambda s: s != "event_counts"):
        # a stream whose sensor is missing or damaged (rate, kind, channel names or units)
        # is damage, not "no count stream": the reader's checks refuse it
        sensor = trial.signal_sensor(stream_name)
        if not sensor.channel_names:
            trial.signal(stream_name)  # refuses a sampled stream whose sensor names no channel
        if "net" not in sensor.channel_names:
            continue
        signal = trial.signal(stream_name, channels=["net"])
        action = signal.sample_labels.get("action")
        return {
            "stream": stream_name,
            "net": signal.data[:, 0].astype(np.float64),
            "t_s": signal.t_s,
            "action": None if action is None else (action.values, list(action.classes or ())),
        }
    return None


def trial_area(trial: Trial, *, bin_s: float = BIN_S, region: str = "press") -> TrialArea:
    """The grader input of one trial of an open tactile file (see the module docstring):
    NaN with a ``status`` saying why when its press region cannot be found."""
    file, name = str(trial.path), trial.name
    labels = _grade_labels(trial)
    annotation = trial.annotation(region)
    if trial.has_events:
        from ..events import trial_counts  # lazy: the grader also runs on CSV areas

        counts = trial_counts(trial, bin_s=bin_s)
        net, t_s, step_s = counts.net, counts.t_s, counts.bin_s
        action = None
    elif (stream := _net_stream(trial)) is not None:
        net, t_s, action = stream["net"], stream["t_s"], stream["action"]
        step_s = float(np.median(np.diff(t_s))) if t_s.shape[0] > 1 else bin_s
    else:
        return TrialArea(file, name, float("nan"), labels=labels,
                         status="no events and no stream with a `net` channel")
    if annotation is not None:
        start, end = annotation.start_s, annotation.end_s
        source = "annotations"
    elif action is not None and region in action[1]:
        idx = np.flatnonzero(action[0] == action[1].index(region))
        if idx.size == 0:
            return TrialArea(file, name, float("nan"), labels=labels,
                             status=f"no sample labelled {region!r}")
        start, end = t_s[idx[0]] - 0.5 * step_s, t_s[idx[-1]] + 0.5 * step_s
        source = "sample_labels"
    elif region == "press":
        from ..events import segment_actions

        seg = segment_actions(np.asarray(net, dtype=np.float64), bin_s=step_s)
        if not seg.segmented:
            return TrialArea(file, name, float("nan"), labels=labels,
                             status=f"segmentation failed: {seg.message}")
        start, end = seg.press_start_s, seg.slip_start_s
        source = "segmentation"
    else:
        return TrialArea(file, name, float("nan"), labels=labels,
                         status=f"no annotation or sample label {region!r}")
    return TrialArea(file, name, press_area(net, t_s, start, end), float(start),
                     float(end), source, labels)


__all__ = ["LABEL_KEYS", "TrialArea", "fos_alphas", "hdf5_areas", "load_areas", "press_area",
           "read_area_csv", "trial_area"]
