"""The sensor unit a run was trained on (``run.json`` key ``sensor_unit``; issue 35, item 4).

A camera-based sensor's normal network holds only for the unit, frame size and scale it was
calibrated on (:mod:`tactile_cli.visuotactile.sensor_unit`). ``tactile normal-labels``
writes them as attributes of the pixel table's sensor (``sensor_unit``,
``sensor_unit_from``, ``width_px``, ``height_px``, ``px_per_mm``); :func:`sensor_unit_record`
reads them from the training files for ``run.json``. Other streams carry no such attribute
and their runs record None.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from ..store.trials import TactileFile


def sensor_unit_record(paths: Sequence[Path], stream: str) -> dict[str, Any] | None:
    """``{unit, unit_from, width_px, height_px, px_per_mm}`` of the sensor named ``stream``
    in the first of ``paths`` whose sensor has a ``sensor_unit`` attribute; None when none
    has."""
    for p in paths:
        with TactileFile(p) as tf:
            if stream not in tf.sensor_names:
                continue
            sensor = tf.sensor(stream)
            unit = sensor.attrs.get("sensor_unit")
            if unit is None or sensor.width_px is None or sensor.height_px is None:
                continue
            ppm = sensor.attrs.get("px_per_mm")
            return {"unit": str(unit), "unit_from": str(sensor.attrs.get("sensor_unit_from",
                                                                         "")),
                    "width_px": int(sensor.width_px), "height_px": int(sensor.height_px),
                    "px_per_mm": None if ppm is None else float(ppm)}
    return None


@dataclass(frozen=True)
class RunSummary:
    """What ``tactile info RUN`` prints of a run folder: family, stream and channels, heads,
    training data, and the sensor unit it was calibrated on (None: not recorded)."""

    run: str
    family: str
    stream: str
    channels: tuple[str, ...]
    heads: tuple[str, ...]
    data: tuple[str, ...]
    created_utc: str
    sensor_unit: dict[str, Any] | None

    def as_dict(self) -> dict[str, Any]:
        return {"run": self.run, "family": self.family, "stream": self.stream,
                "channels": list(self.channels), "heads": list(self.heads),
                "data": list(self.data), "created_utc": self.created_utc,
                "sensor_unit": self.sensor_unit}

    def summary_lines(self) -> list[str]:
        u = self.sensor_unit
        unit = ("sensor unit: not recorded (no calibrated camera sensor in its data)"
                if u is None else
                f"sensor unit: {u['unit']!r} ({u['unit_from']}), frames {u['width_px']}x"
                f"{u['height_px']} px, px_per_mm "
                + ("unknown" if u["px_per_mm"] is None else f"{u['px_per_mm']:g}"))
        return [f"{self.run}: run of family {self.family}, trained {self.created_utc}",
                f"input: stream {self.stream}, channels {', '.join(self.channels)}",
                f"heads: {', '.join(self.heads)}",
                f"data: {', '.join(self.data)}", unit]


def is_run_folder(path: str | Path) -> bool:
    """``path`` is a folder holding ``run.json`` (what ``tactile train`` writes). A file
    path is answered without importing the run module (and torch with it)."""
    if not Path(path).is_dir():
        return False
    from .runs import RUN_JSON

    return Path(path).is_dir() and (Path(path) / RUN_JSON).is_file()


def run_summary(path: str | Path) -> RunSummary:
    """The :class:`RunSummary` of run folder ``path`` (its run.json checked as every
    reader checks it)."""
    from .runs import read_run_info

    info = read_run_info(path)
    model = info["model"]
    return RunSummary(str(path), str(model.get("family")), str(model.get("stream", "")),
                      tuple(str(c) for c in model.get("channels", [])),
                      tuple(str(h.get("name")) for h in info["heads"]),
                      tuple(str(d.get("path")) for d in info["data"]),
                      str(info["created_utc"]), info.get("sensor_unit"))


__all__ = ["RunSummary", "is_run_folder", "run_summary", "sensor_unit_record"]
