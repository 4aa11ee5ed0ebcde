"""ROI centroid trajectories as a signal stream: the features of the spatial-temporal
classifier (paper 000, sec. 5.2, eqs. 18-19).

Sec. 5.2 classifies each 20 ms bin from "the weighted centroid estimations of the ROI"
alone, so the stream carries eq. 19 per ROI and per bin, plus what is needed to make it a
complete, NaN-free feature:

- ``{roi}_x``, ``{roi}_y`` (px): the event-weighted centroid of the ROI (eq. 19). A bin in
  which an ROI has no events of the chosen polarity has no centroid (eq. 19 is 0/0); it is
  **filled with the ROI's centre** (pixel-centre coordinates, :attr:`Roi.centre_px`), the
  value the centroid of uniform background events has on average, and marked by
- ``{roi}_has_events`` (0 or 1): 1 where the centroid is measured, 0 where it was filled.
  Filling alone would hide the difference between "no contact" and "contact at the
  centre"; the flag keeps it, and a model never sees a NaN.
- ``{roi}_events`` (events/bin): ``sum I`` of eq. 19, the weight behind the centroid. It is
  stored for completeness (it sets the centroid's noise) but it is an event count, the
  temporal classifier's feature; ``configs/train_lstm_spatial.yaml`` leaves it out, so the
  spatial model sees centroids only, as in the paper.
- ``{roi}_vx``, ``{roi}_vy`` (px/s): the centroid's velocity, eq. 20, as the backward
  difference of consecutive measured centroids over one bin; 0 in the first bin and where
  either bin has no centroid (no motion is measured there). The same velocity that
  ``tactile slip-rate`` integrates (eq. 21); it gives a model the rate of change directly
  instead of a small drift of a standardised position.

Channel order: all ROIs' ``_x``/``_y`` pairs first (``strip1_x, strip1_y, ..., stripN_y``),
then the ``_has_events`` flags, the ``_events`` counts and the ``_vx``/``_vy`` pairs.

The sensor of the stream (``roi_centroids``, kind ``event_camera`` with the source camera's
width and height, ``sample_rate_hz = 1 / bin_s``) records the ROIs (``rois_json``), the
polarity, the median filter and the optics when known. :func:`write_centroid_file` turns
every event trial of a tactile file into such a stream with per-bin ``action`` labels from
the trial's annotations (``tactile centroids``); ``tactile synth --centroids`` writes the
same stream from the model (:mod:`tactile_cli.synth.centroids`).

No background subtraction: :func:`~tactile_cli.spatial.roi.background_rate` measures the
background over the annotated approach region, and the annotations are the labels the
classifier is evaluated against; the model-based trajectories include the background
events instead.
"""

from __future__ import annotations

import json
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import InputError
from ..progress import NullProgress, Progress
from ..store.trials import TactileFile, Trial
from ..store.writer import StoreWriter
from .config import SpatialConfig
from .roi import Roi, trial_roi_centroids
from .trial_events import event_trial_names, spatial_events

#: Name of the stream (``/trials/{t}/signals/roi_centroids``) and of its sensor.
STREAM = "roi_centroids"
SENSOR = "roi_centroids"
#: Per-ROI channel suffixes after the ``_x``/``_y`` pairs.
FLAG_SUFFIX = "_has_events"
COUNT_SUFFIX = "_events"
VELOCITY_AXES = ("vx", "vy")
#: Channels per ROI: x, y, has_events, events, vx, vy.
CHANNELS_PER_ROI = 6


def channel_names(rois: Sequence[Roi]) -> list[str]:
    """``[r1_x, r1_y, ..., rN_x, rN_y, r1_has_events, ..., rN_has_events, r1_events, ...,
    rN_events, r1_vx, r1_vy, ..., rN_vx, rN_vy]`` for ROIs named r1..rN."""
    pairs = [f"{r.name}_{axis}" for r in rois for axis in ("x", "y")]
    velocities = [f"{r.name}_{axis}" for r in rois for axis in VELOCITY_AXES]
    return [*pairs, *(r.name + FLAG_SUFFIX for r in rois),
            *(r.name + COUNT_SUFFIX for r in rois), *velocities]


def channel_units(rois: Sequence[Roi]) -> list[str]:
    """Units of :func:`channel_names`: px, 1 (flag), events/bin and px/s."""
    n = len(rois)
    return ["px"] * (2 * n) + ["1"] * n + ["events/bin"] * n + ["px/s"] * (2 * n)


def roi_centres(rois: Sequence[Roi]) -> np.ndarray:
    """(n_rois, 2) float64 pixel-centre coordinates (x, y) of each ROI's middle."""
    return np.array([r.centre_px for r in rois], dtype=np.float64).reshape(len(rois), 2)


def centroid_features(centroid_px: np.ndarray, weight: np.ndarray,
                      rois: Sequence[Roi], *, bin_s: float) -> np.ndarray:
    """(n_bins, 6 n_rois) float32 stream data in :func:`channel_names` order.

    centroid_px: (n_bins, n_rois, 2) eq. 19 ``[x_bar, y_bar]`` px, NaN where undefined;
    weight: (n_bins, n_rois) ``sum I`` per bin and ROI; bin_s: bin width (s), for the
    velocity in px/s. A centroid is measured where its weight is > 0 and finite; elsewhere
    it is replaced by the ROI's centre and its flag is 0. The velocity (eq. 20) of bin i is
    ``(c[i] - c[i-1]) / bin_s`` where both bins are measured, else 0. Raises ValueError on
    mismatched shapes, a non-positive ``bin_s`` or a NaN centroid with a positive weight (a
    caller's bug: eq. 19 is defined there).
    """
    if not bin_s > 0:
        raise ValueError(f"`bin_s` (={bin_s}) must be > 0")
    c = np.asarray(centroid_px, dtype=np.float64)
    w = np.asarray(weight, dtype=np.float64)
    n = len(rois)
    if c.ndim != 3 or c.shape[1:] != (n, 2) or w.shape != c.shape[:2]:
        raise ValueError(f"`centroid_px` {c.shape} and `weight` {w.shape} must be "
                         f"(n_bins, {n}, 2) and (n_bins, {n})")
    has = np.isfinite(w) & (w > 0)
    if np.any(has[..., None] & ~np.isfinite(c)):
        raise ValueError("a centroid is NaN where its ROI has events; eq. 19 is defined there")
    filled = np.where(has[..., None], c, roi_centres(rois)[None])
    velocity = np.zeros_like(filled)
    both = has[1:] & has[:-1]
    velocity[1:] = np.where(both[..., None], (filled[1:] - filled[:-1]) / bin_s, 0.0)
    out = np.concatenate([filled.reshape(c.shape[0], 2 * n), has.astype(np.float64),
                          np.where(has, w, 0.0), velocity.reshape(c.shape[0], 2 * n)],
                         axis=1)
    return out.astype(np.float32)


def add_centroid_sensor(
    writer: StoreWriter,
    rois: Sequence[Roi],
    *,
    bin_s: float,
    width_px: int,
    height_px: int,
    description: str,
    polarity: str = "positive",
    median: int = 1,
    optics: dict[str, float] | None = None,
    **extra: float | int | str,
) -> str:
    """Describe the ``roi_centroids`` sensor in ``writer``; returns its name."""
    return writer.add_sensor(
        SENSOR, kind="event_camera", sample_rate_hz=1.0 / bin_s,
        channel_names=channel_names(rois), channel_units=channel_units(rois),
        width_px=width_px, height_px=height_px, bin_s=bin_s, polarity=polarity,
        median_px=median, rois_json=json.dumps([r.as_dict() for r in rois]),
        description=description, **(optics or {}), **extra)


# -- recordings -> stream ---------------------------------------------------------------------
@dataclass(frozen=True)
class CentroidTrialStream:
    """One trial's stream: t_s (n_bins,) bin centres, s; data (n_bins, 6 n_rois) float32 in
    :func:`channel_names` order; action (n_bins,) int8 class index from the annotations
    (-1 outside every action region) or None without annotations; annotations: the
    trial's ``(start_s, end_s, label)``."""

    trial: str
    t_s: np.ndarray
    data: np.ndarray
    action: np.ndarray | None
    annotations: tuple[tuple[float, float, str], ...] = ()

    @property
    def measured_fraction(self) -> float:
        """Share of (bin, ROI) cells with a measured (not filled) centroid."""
        n = self.data.shape[1] // CHANNELS_PER_ROI
        flags = self.data[:, 2 * n:3 * n]
        return float(flags.mean()) if flags.size else 0.0


@dataclass(frozen=True)
class CentroidFileResult:
    """What :func:`write_centroid_file` wrote: the file and one row per trial."""

    path: Path
    trials: tuple[CentroidTrialStream, ...]
    rois: tuple[Roi, ...]
    bin_s: float

    def as_dict(self) -> dict[str, Any]:
        return {
            "out": str(self.path), "bin_s": self.bin_s,
            "rois": [r.as_dict() for r in self.rois],
            "channels": channel_names(self.rois),
            "trials": [{"trial": t.trial, "n_bins": int(t.t_s.shape[0]),
                        "measured_fraction": round(t.measured_fraction, 6),
                        "labelled": t.action is not None} for t in self.trials],
        }


def trial_centroid_stream(trial: Trial, config: SpatialConfig) -> CentroidTrialStream:
    """Eq. 19 per ROI per bin of one event trial (the config's ROIs, polarity, median and
    bin width), filled and flagged (:func:`centroid_features`), with action labels."""
    from ..events.accumulate import counts_to_labels  # lazy: pulls in the FOS package

    opts = config.centroid
    c = trial_roi_centroids(trial, config.rois, bin_s=opts.bin_s,
                            polarity=opts.polarity, median=opts.median)
    annotations = trial.annotations
    action = counts_to_labels(c.t_s, annotations).astype(np.int8) if annotations else None
    data = centroid_features(c.centroid_px, c.weight, config.rois, bin_s=opts.bin_s)
    return CentroidTrialStream(trial.name, c.t_s, data, action, tuple(annotations))


def _check_config(config: SpatialConfig) -> None:
    src = config.source or None
    if not config.rois:
        raise InputError("the config lists no ROIs; the centroid stream needs them under "
                         "`rois:` (or a scene's scene.json)", path=src)
    if config.centroid.background == "approach":
        raise InputError("`centroid.background: approach` subtracts a background measured over "
                         "the annotated approach, and the annotations are the classifier's "
                         "labels; the centroid stream never subtracts it: set "
                         "`background: none` (or auto)", path=src)


def write_centroid_file(
    path: str | Path,
    out: str | Path,
    config: SpatialConfig | str | Path,
    *,
    trials: Sequence[str] | None = None,
    command: str | None = None,
    provenance: dict[str, Any] | None = None,
    overwrite: bool = False,
    progress: Progress | None = None,
) -> CentroidFileResult:
    """Write the ``roi_centroids`` stream of every event trial of ``path`` (or of
    ``trials``) to a new schema-valid tactile file ``out``.

    Each output trial keeps the source trial's name, labels, split and annotations and has
    ``signals/roi_centroids`` with ``sample_labels/action`` (from the annotations; absent
    for a trial without them). ``config``: the ROI config, or the path of its YAML file or
    of a scene's scene.json. ``provenance`` is stored as the root's ``config_json``
    (default: the config, the trials and every input with its SHA-256); the source file
    is recorded with its SHA-256. Raises :class:`InputError` before any work for an
    output that is an input or cannot be written, an unknown trial, a config without ROIs
    or for another sensor size, and a file without event trials.
    """
    from ..input_guard import check_outputs
    from ..store.atomic import check_output_file
    from ..store.provenance import provenance_record
    from ..vocabulary import ACTIONS
    from .pipeline import config_source

    path = Path(path)
    if not path.is_file():
        raise InputError("file not found", path=path)
    check_outputs({"out": out}, [path] + ([] if isinstance(config, SpatialConfig)
                                          else [config]))
    check_output_file(out, overwrite=overwrite)
    config, config_files = config_source(config)
    if provenance is None:
        provenance = provenance_record([path, *config_files], {
            "rois": config.as_dict(), "trials": list(trials) if trials else "all"})
    _check_config(config)
    with TactileFile(path) as src:
        names = event_trial_names(src)
        if trials:
            missing = [t for t in trials if t not in names]
            if missing:
                raise InputError(f"no event trial {missing[0]!r}; the file's event trials: "
                                 f"{', '.join(names[:10]) or 'none'}", path=path)
            names = list(trials)
        if not names:
            raise InputError("the file has no event trials", path=path)
        progress = progress or NullProgress()
        sensor = spatial_events(src.trial(names[0])).sensor
        config.check_sensor(sensor.width_px, sensor.height_px)
        optics = config.optics.as_dict() if config.optics is not None else sensor.optics
        done: list[CentroidTrialStream] = []
        with StoreWriter(out, command=command, config=provenance, overwrite=overwrite) as w:
            source = w.add_source(path)
            s = add_centroid_sensor(
                w, config.rois, bin_s=config.centroid.bin_s, width_px=sensor.width_px,
                height_px=sensor.height_px, polarity=config.centroid.polarity,
                median=config.centroid.median, optics=optics, source_sensor=sensor.name,
                description="event-weighted centroid (eq. 19) of each ROI per bin, filled with "
                            "the ROI centre and flagged where the ROI had no events")
            progress.start(len(names), "ROI centroids")
            for name in names:
                trial = src.trial(name)
                stream = trial_centroid_stream(trial, config)
                tw = w.trial(name, labels=trial.labels, split=trial.split, sources=[source],
                             annotations=stream.annotations, duration_s=trial.duration_s)
                sample_labels = {} if stream.action is None else {
                    "action": (stream.action, ACTIONS)}
                tw.write_signal(STREAM, sensor=s, data=stream.data, t_s=stream.t_s,
                                sample_labels=sample_labels)
                done.append(stream)
                progress.advance(1)
            progress.finish()
            written = w.commit()
    return CentroidFileResult(written, tuple(done), tuple(config.rois), config.centroid.bin_s)


__all__ = ["CHANNELS_PER_ROI", "COUNT_SUFFIX", "FLAG_SUFFIX", "SENSOR", "STREAM",
           "VELOCITY_AXES", "CentroidFileResult", "CentroidTrialStream", "add_centroid_sensor",
           "centroid_features", "channel_names", "channel_units", "roi_centres",
           "trial_centroid_stream", "write_centroid_file"]
