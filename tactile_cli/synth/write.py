"""Write synthetic trials as a tactile HDF5 file of event-count streams (contract 3).

Layout: sensor ``event_counts`` (kind ``event_camera``, the configured geometry, channel
``net`` in events/bin, ``sample_rate_hz = 1/bin_s``, attribute ``bin_s``); per trial
``/trials/synth_00000/signals/event_counts`` with ``data`` (n_bins, 1) float32 net counts,
``t_s`` the bin centres and ``sample_labels/action`` (int8, attribute ``classes`` =
approach, press, slip, release); the labels ``force_level``, ``force_grade`` and every
sampled parameter; the four action regions as annotations. Provenance: the fits file as
the source of every trial, and the resolved config, seed, n and the distributions drawn
from in the root's ``config_json``.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from pathlib import Path
from typing import Any

from ..fos.actions import ACTIONS
from ..progress import NullProgress, Progress
from ..store.writer import StoreWriter
from .trajectories import SynthTrial

SENSOR = "event_counts"
STREAM = "event_counts"


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
) -> Path:
    """Write ``trials`` (``n`` of them, for the progress bar) to ``out``, atomically.

    ``provenance``: JSON-ready resolved config, seed and distributions, stored as the root's
    ``config_json``. ``fits_path``: the fits file the parameters came from (recorded with
    its SHA-256 as the source of every trial).
    """
    progress = progress or NullProgress()
    with StoreWriter(out, command=command, config=provenance, overwrite=overwrite) as w:
        sources = [w.add_source(fits_path)] if fits_path is not None else []
        sensor = w.add_sensor(
            SENSOR, kind="event_camera", sample_rate_hz=1.0 / bin_s, channel_names=["net"],
            channel_units="events/bin", width_px=width_px, height_px=height_px, bin_s=bin_s,
            description="net (positive - negative) events per bin of model-based synthetic "
                        "trials (tactile synth)")
        progress.start(n, "synthesising trials")
        for trial in trials:
            tw = w.trial(trial.name, labels=trial.label_attrs(), sources=sources,
                         annotations=trial.timeline.intervals())
            tw.write_signal(STREAM, sensor=sensor, data=trial.net[:, None], t_s=trial.t_s,
                            sample_labels={"action": (trial.labels, ACTIONS)})
            progress.advance()
        progress.finish()
        return w.commit()


__all__ = ["SENSOR", "STREAM", "write_synth"]
