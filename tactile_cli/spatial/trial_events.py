"""The event trials of the spatial chain: which trials of a file have events, and one trial's
events checked for what the chain needs (at least one event, a camera with a pixel grid).

Reading is :mod:`tactile_cli.store.trials`: windows in trial seconds through the millisecond
index, on the one time origin (events attribute ``t_origin_us``, else
``ms_index_origin_us``). This module adds only the spatial chain's requirements and their
error wording.
"""

from __future__ import annotations

from ..errors import InputError
from ..store.trials import TactileFile, Trial, TrialEvents


def event_trial_names(file: TactileFile) -> list[str]:
    """Names of the trials of ``file`` that have events, in file order."""
    return [t.name for t in file.trials() if t.has_events]


def spatial_events(trial: Trial) -> TrialEvents:
    """The events of ``trial`` for frames, ROI centroids and slip rates.

    Raises :class:`InputError` when the trial has no events group or no event, or when its
    camera does not record its grid (``width_px``, ``height_px``).
    """
    if not trial.has_events:
        raise InputError("trial has no events (the spatial chain needs an event-camera "
                         "recording)", path=trial.path, where=trial.where)
    te = trial.events
    if te.n_events == 0:
        raise InputError("trial has no events", path=trial.path, where=te.where)
    sensor = te.sensor
    if sensor.width_px is None or sensor.height_px is None:
        raise InputError(f"sensor {sensor.name!r} lacks width_px/height_px; the spatial chain "
                         "needs the camera's pixel grid", path=trial.path,
                         where=f"/sensors/{sensor.name}")
    return te


__all__ = ["event_trial_names", "spatial_events"]
