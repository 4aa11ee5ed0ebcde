"""Which sensor unit a normal model was calibrated on, and whether frames fit it.

A normal network (paper 002, sec. II-B) maps a pixel's position and colour change to a
normal; both depend on the unit it was calibrated on: the frame size sets the positions,
the scale (``px_per_mm``) the heights, and the unit's LEDs and gel the colours (DIGIT units
differ in their LED diffusion). So the chain records and checks them:

- ``tactile normal-labels`` writes on the pixel table's sensor the calibration frames'
  unit (:func:`frames_unit`: the trial label ``sensor_id`` or ``serial``, else the frames
  sensor's attribute ``serial`` or ``sensor_id``, else the frames sensor's name), besides
  ``width_px``, ``height_px`` and ``px_per_mm``;
- ``tactile train`` copies them into ``run.json`` (key ``sensor_unit``,
  :mod:`tactile_cli.learn.sensor_unit`);
- ``heightmap``, ``slip-signal --source height`` and ``monitor`` check frames against it
  (:func:`check_frames`): another frame size is refused (the positions the network learnt
  are other pixels), another unit or scale is a warning (the network may still be close).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from ..errors import InputError
from ..store.trials import TactileFile, Trial

#: trial labels, then sensor attributes, naming a unit (first found wins)
UNIT_LABELS = ("sensor_id", "serial")


@dataclass(frozen=True)
class SensorCalibration:
    """The unit a normal model was calibrated on (``run.json`` key ``sensor_unit``).

    unit: the unit's id; unit_from: where it was read (``label sensor_id``, ``sensor
    attribute serial``, ``sensor name``); width_px, height_px: frame size (px);
    px_per_mm: the gel's scale (pixels per mm), None when unknown.
    """

    unit: str
    unit_from: str
    width_px: int
    height_px: int
    px_per_mm: float | None

    def as_dict(self) -> dict[str, Any]:
        return {"unit": self.unit, "unit_from": self.unit_from, "width_px": self.width_px,
                "height_px": self.height_px, "px_per_mm": self.px_per_mm}

    @classmethod
    def from_dict(cls, d: Any, *, path: str | Path | None = None) -> SensorCalibration:
        """Read the record back; a malformed one is an InputError naming ``path``."""
        try:
            if not isinstance(d, dict):
                raise TypeError("not a mapping")
            ppm = d.get("px_per_mm")
            return cls(str(d["unit"]), str(d.get("unit_from", "")), int(d["width_px"]),
                       int(d["height_px"]), None if ppm is None else float(ppm))
        except (KeyError, TypeError, ValueError) as exc:
            raise InputError(f"`sensor_unit` is not a valid record ({exc}); re-create the run "
                             "with `tactile train`", path=path) from None

    def line(self) -> str:
        """``unit 'D20001' (label sensor_id), 320x240 px, 16 px/mm``."""
        ppm = "px_per_mm unknown" if self.px_per_mm is None else f"{self.px_per_mm:g} px/mm"
        return (f"unit {self.unit!r} ({self.unit_from}), {self.width_px}x{self.height_px} px, "
                f"{ppm}")


def frames_unit(tf: TactileFile, trial: Trial) -> tuple[str, str]:
    """(unit id, where it was read) of ``trial``'s frames (see the module docstring)."""
    for key in UNIT_LABELS:
        value = trial.labels.get(key)
        if value is not None and str(value) != "":
            return str(value), f"label {key}"
    name = trial.frames().sensor_name
    attrs = tf.sensor(name).attrs if name in tf.sensor_names else {}
    for key in UNIT_LABELS:
        value = attrs.get(key)
        if value is not None and str(value) != "":
            return str(value), f"sensor attribute {key}"
    return str(name), "sensor name"


def check_frames(calibration: SensorCalibration | None, tf: TactileFile, trial: Trial, *,
                 run: str | Path | None, px_per_mm: float | None) -> list[str]:
    """Check ``trial``'s frames against the unit a model was calibrated on.

    Raises one InputError naming the file when the frame size differs; returns warnings
    (one line each) for another unit or another ``px_per_mm`` (relative difference above
    1 %). ``calibration`` None (a run trained before the record existed): one warning."""
    if calibration is None:
        return [f"the normal model {run} records no sensor unit, frame size or px_per_mm "
                "(trained before they were recorded): nothing checks that these frames "
                "come from the unit it was calibrated on; retrain it"]
    h, w = trial.frames().shape[:2]
    if (w, h) != (calibration.width_px, calibration.height_px):
        raise InputError(f"frames are {w}x{h} px but the normal model {run} was calibrated on "
                         f"{calibration.width_px}x{calibration.height_px} px frames (unit "
                         f"{calibration.unit!r}); calibrate on frames of this size",
                         path=tf.path, where=f"/trials/{trial.name}")
    warnings = []
    unit, unit_from = frames_unit(tf, trial)
    if unit != calibration.unit:
        warnings.append(f"frames come from unit {unit!r} ({unit_from}) but the normal model "
                        f"{run} was calibrated on unit {calibration.unit!r}: units differ in "
                        "LEDs and gel, so heights may be wrong; calibrate this unit")
    cal_ppm = calibration.px_per_mm
    if (px_per_mm is not None and cal_ppm is not None
            and not math.isclose(px_per_mm, cal_ppm, rel_tol=0.01)):
        warnings.append(f"frames have px_per_mm {px_per_mm:g} but the normal model {run} was "
                        f"calibrated at {cal_ppm:g}: heights scale with it")
    return warnings


__all__ = ["UNIT_LABELS", "SensorCalibration", "check_frames", "frames_unit"]
