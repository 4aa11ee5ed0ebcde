"""Write synthetic trials as a tactile HDF5 file of event-count streams (contract 3).

Layout: sensor ``event_counts`` (kind ``event_camera``, the configured geometry, channel
``net`` in events/bin, ``sample_rate_hz = 1/bin_s``, attribute ``bin_s``); per trial
``/trials/synth_00000/signals/event_counts`` with ``data`` (n_bins, 1) float32 net counts,
``t_s`` the bin centres and ``sample_labels/action`` (int8, attribute ``classes`` =
approach, press, slip, release); the labels ``force_level``, ``force_grade``, every
sampled parameter, ``origin`` = synthetic and ``dataset`` (see
:mod:`tactile_cli.store.origin`); the four action regions as annotations. Provenance: the
fits file as the source of every trial, and the resolved config, seed, n and the distributions drawn
from in the root's ``config_json``.

With ``centroids`` (``tactile synth --centroids ROIS``) every trial also has the stream
``signals/roi_centroids`` of sensor ``roi_centroids`` (:mod:`tactile_cli.spatial.stream`:
each ROI's centroid x, y in px, filled with the ROI centre where it had no events, a
``_has_events`` flag and the events per bin), with the same action labels, and the ROI
config is a source of every trial.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from pathlib import Path
from typing import Any

from ..progress import NullProgress, Progress
from ..store.origin import DATASET_LABEL, ORIGIN_LABEL
from ..store.writer import StoreWriter
from ..vocabulary import ACTIONS
from .centroids import CentroidModel
from .trajectories import SynthTrial

SENSOR = "event_counts"
STREAM = "event_counts"
#: The trial label ``origin`` of every synthetic trial.
ORIGIN = "synthetic"


def write_synth(
    out: str | Path,
    trials: Iterable[SynthTrial],
    *,
    n: int,
    bin_s: float,
    width_px: int,
    height_px: int,
    provenance: Mapping[str, Any],
    fits_path: str | Path | None = None,
    command: str | None = None,
    overwrite: bool = False,
    progress: Progress | None = None,
    centroids: CentroidModel | None = None,
    centroids_path: str | Path | None = None,
    dataset: str = "synth",
) -> Path:
    """Write ``trials`` (``n`` of them, for the progress bar) to ``out``, atomically.

    ``provenance``: JSON-ready resolved config, seed and distributions, stored as the root's
    ``config_json``. ``fits_path``: the fits file the parameters came from (recorded with
    its SHA-256 as the source of every trial). ``centroids``: the model the trials'
    centroid trajectories were drawn with (every trial must have them), and
    ``centroids_path`` the ROI config it came from (a source of every trial).
    """
    progress = progress or NullProgress()
    with StoreWriter(out, command=command, config=provenance, overwrite=overwrite) as w:
        sources = [w.add_source(fits_path)] if fits_path is not None else []
        if centroids_path is not None:
            sources.append(w.add_source(centroids_path))
        sensor = w.add_sensor(
            SENSOR, kind="event_camera", sample_rate_hz=1.0 / bin_s, channel_names=["net"],
            channel_units="events/bin", width_px=width_px, height_px=height_px, bin_s=bin_s,
            description="net (positive - negative) events per bin of model-based synthetic "
                        "trials (tactile synth)")
        centroid_sensor = None
        if centroids is not None:
            from ..spatial.stream import add_centroid_sensor

            centroid_sensor = add_centroid_sensor(
                w, centroids.rois, bin_s=bin_s, width_px=width_px, height_px=height_px,
                optics=centroids.optics.as_dict(),
                description="model-based event-weighted ROI centroids (eq. 19) per bin of "
                            "synthetic trials (tactile synth --centroids), filled with the ROI "
                            "centre and flagged where the ROI had no events")
        progress.start(n, "synthesising trials")
        for trial in trials:
            labels = {**trial.label_attrs(), ORIGIN_LABEL: ORIGIN, DATASET_LABEL: dataset}
            tw = w.trial(trial.name, labels=labels, sources=sources,
                         annotations=trial.timeline.intervals())
            tw.write_signal(STREAM, sensor=sensor, data=trial.net[:, None], t_s=trial.t_s,
                            sample_labels={"action": (trial.labels, ACTIONS)})
            if centroid_sensor is not None:
                _write_centroids(tw, centroid_sensor, trial, centroids, bin_s)
            progress.advance()
        progress.finish()
        return w.commit()


def _write_centroids(tw: Any, sensor: str, trial: SynthTrial, model: CentroidModel,
                     bin_s: float) -> None:
    from ..spatial.stream import STREAM as CENTROID_STREAM
    from ..spatial.stream import centroid_features

    c = trial.centroids
    if c is None:
        raise ValueError(f"trial {trial.name} has no centroid trajectories to write")
    tw.write_signal(CENTROID_STREAM, sensor=sensor,
                    data=centroid_features(c.centroid_px, c.weight, model.rois,
                                           bin_s=bin_s),
                    t_s=trial.t_s,
                    sample_labels={"action": (trial.labels, ACTIONS)})


__all__ = ["ORIGIN", "SENSOR", "STREAM", "write_synth"]
