"""The non-event streams of an AEDAT4 file: APS frames, IMU samples and triggers.

Each collector takes the decoder's packets of one stream (``aedat`` package layouts) and
writes them into the trial when the file ends. Times become seconds from the trial's time
origin ``origin_us`` (its first event, in the camera clock).

- **Frames** (``FRME``): ``/trials/<trial>/frames``: ``images`` (n, height, width, 3) uint8
  RGB (grey frames repeated over the three channels, BGRA's alpha dropped), ``t_s`` the
  frame timestamps, and, where the camera records them for every frame,
  ``exposure_start_s``/``exposure_end_s``. ``reference`` is the first frame (an APS camera
  has no no-contact frame).
- **IMU** (``IMUS``): ``/trials/<trial>/signals/imu``, sensor kind ``imu``: accelerometer in
  g, gyroscope in deg/s, temperature in degC (the AEDAT4 IMU units), and the magnetometer
  in uT only when the file holds a non-zero value (cameras without one write zeros).
- **Triggers** (``TRIG``): annotations ``trigger_<type>`` (start = end = the trigger time),
  in time order, with the AEDAT4 trigger types named below.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from ..errors import InputError
from ..store.writer import FrameAppender, StoreWriter, TrialWriter, safe_name

#: (decoder field, channel name, unit) of the IMU stream, in output order.
IMU_CHANNELS: tuple[tuple[str, str, str], ...] = (
    ("accelerometer_x", "accel_x", "g"), ("accelerometer_y", "accel_y", "g"),
    ("accelerometer_z", "accel_z", "g"),
    ("gyroscope_x", "gyro_x", "deg/s"), ("gyroscope_y", "gyro_y", "deg/s"),
    ("gyroscope_z", "gyro_z", "deg/s"),
    ("temperature", "temperature", "degC"),
)
MAGNETOMETER: tuple[tuple[str, str, str], ...] = (
    ("magnetometer_x", "mag_x", "uT"), ("magnetometer_y", "mag_y", "uT"),
    ("magnetometer_z", "mag_z", "uT"),
)

#: AEDAT4 trigger type codes (dv ``TriggerType``) -> annotation label.
TRIGGER_LABELS: dict[int, str] = {
    0: "trigger_timestamp_reset", 1: "trigger_external_rising_edge",
    2: "trigger_external_falling_edge", 3: "trigger_external_pulse",
    4: "trigger_generator_rising_edge", 5: "trigger_generator_falling_edge",
    6: "trigger_frame_begin", 7: "trigger_frame_end", 8: "trigger_exposure_begin",
    9: "trigger_exposure_end",
}


def _seconds(t_us: np.ndarray, origin_us: int) -> np.ndarray:
    """(n,) camera-clock microseconds -> (n,) float64 seconds from ``origin_us`` (exact
    integer difference first, so 2^50 us clocks keep their microseconds)."""
    return (np.asarray(t_us, dtype=np.int64) - np.int64(origin_us)) * 1e-6


class FrameCollector:
    """APS frames of one ``FRME`` stream, appended to the trial frame by frame."""

    def __init__(self, trial: TrialWriter, sensor: str, path: Path, stream_id: int,
                 origin_us: int):
        self.trial, self.sensor, self.path = trial, sensor, path
        self.stream_id, self.origin_us = stream_id, origin_us
        self.appender: FrameAppender | None = None
        self.t_us: list[int] = []
        self.exposure_us: list[tuple[int, int]] = []

    def add(self, frame: dict[str, Any]) -> None:
        """frame: the decoder's dict (``t``, ``exposure_begin_t``, ``exposure_end_t`` in us,
        ``format`` 'L'/'RGB'/'RGBA', ``pixels`` (height, width[, 3|4]) uint8)."""
        k = len(self.t_us)
        rgb = self._rgb(frame, k)
        t_us = int(frame["t"])
        if self.t_us and t_us < self.t_us[-1]:
            raise self._error(f"frame {k} at {t_us} us is earlier than frame {k - 1} "
                              f"({self.t_us[-1]} us); frame times must not decrease")
        if self.appender is None:
            self.appender = self.trial.frames(self.sensor, reference=rgb)
        elif rgb.shape != self.appender.frame_shape:
            h, w = self.appender.frame_shape[:2]
            raise self._error(f"frame {k} is {rgb.shape[1]}x{rgb.shape[0]} px, earlier frames "
                              f"{w}x{h} px; a trial holds frames of one size")
        self.appender.append(rgb, _seconds(np.array([t_us]), self.origin_us))
        self.t_us.append(t_us)
        self.exposure_us.append((int(frame.get("exposure_begin_t", 0)),
                                 int(frame.get("exposure_end_t", 0))))

    def _rgb(self, frame: dict[str, Any], k: int) -> np.ndarray:
        pixels = np.asarray(frame["pixels"])
        fmt = str(frame.get("format"))
        if pixels.dtype != np.uint8:
            raise self._error(f"frame {k} has {pixels.dtype} pixels; tactile stores 8-bit frames")
        if fmt == "L" and pixels.ndim == 2:
            return np.repeat(pixels[:, :, None], 3, axis=2)
        if fmt in ("RGB", "RGBA") and pixels.ndim == 3 and pixels.shape[2] == len(fmt):
            return np.ascontiguousarray(pixels[:, :, :3])
        raise self._error(f"frame {k} has pixel format {fmt!r} with shape {pixels.shape}; "
                          "tactile reads grey (L), RGB and RGBA frames")

    def _error(self, message: str) -> InputError:
        return InputError(f"frame stream {self.stream_id}: {message}", path=self.path)

    def close(self) -> int:
        """Write the exposure times (when every frame has them) and the trial duration;
        returns the frame count."""
        if self.appender is None:
            return 0
        ex = np.array(self.exposure_us, dtype=np.int64).reshape(-1, 2)
        if (ex[:, 0] > 0).all() and (ex[:, 1] >= ex[:, 0]).all():
            for i, name in enumerate(("exposure_start_s", "exposure_end_s")):
                self.appender.group.create_dataset(name, data=_seconds(ex[:, i], self.origin_us))
        return self.appender.close()


class ImuCollector:
    """The samples of one ``IMUS`` stream, written as one signal stream at the end."""

    def __init__(self, path: Path, stream_id: int):
        self.path, self.stream_id = path, stream_id
        self.packets: list[np.ndarray] = []

    def add(self, samples: np.ndarray) -> None:
        """samples: (k,) structured: ``t`` uint64 us and the float32 fields of
        :data:`IMU_CHANNELS` and :data:`MAGNETOMETER`."""
        self.packets.append(samples)

    def __len__(self) -> int:
        return sum(len(p) for p in self.packets)

    def write(self, writer: StoreWriter, trial: TrialWriter, *, stream: str, sensor: str,
              camera: str, origin_us: int) -> int:
        """Write ``signals/<stream>`` (and the sensor once per output file); returns the
        sample count (0: nothing written)."""
        if not self.packets:
            return 0
        rows = np.concatenate(self.packets)
        t_s = _seconds(rows["t"], origin_us)
        steps = np.diff(t_s)
        bad = np.flatnonzero(~(steps > 0))
        if len(bad):
            i = int(bad[0]) + 1
            raise InputError(f"IMU stream {self.stream_id}: sample {i} at {int(rows['t'][i])} us "
                             f"does not come after sample {i - 1} ({int(rows['t'][i - 1])} us); "
                             "IMU times must increase", path=self.path)
        fields = list(IMU_CHANNELS)
        if any(np.any(rows[f] != 0) for f, _, _ in MAGNETOMETER):
            fields += list(MAGNETOMETER)
        data = np.column_stack([rows[f] for f, _, _ in fields]).astype(np.float32)
        if not np.isfinite(data).all():
            i = int(np.flatnonzero(~np.isfinite(data).all(axis=1))[0])
            raise InputError(f"IMU stream {self.stream_id}: sample {i} holds a non-finite value",
                             path=self.path)
        rate_hz = 1.0 / float(np.median(steps)) if len(steps) else 1.0
        key = _imu_sensor(writer, sensor, fields, rate_hz, camera, self.path)
        group = trial.write_signal(stream, sensor=key, data=data, t_s=t_s)
        group.attrs["sample_rate_hz"] = rate_hz
        return len(data)


def _imu_sensor(writer: StoreWriter, name: str, fields: list[tuple[str, str, str]],
                rate_hz: float, camera: str, path: Path) -> str:
    """Add the IMU sensor once per output file (the first file's median rate), or reuse
    it when an earlier input added it with the same channels."""
    key = safe_name(name)
    names = [c for _, c, _ in fields]
    sensors = writer.h5["sensors"]
    if key not in sensors:
        return writer.add_sensor(name, kind="imu", sample_rate_hz=rate_hz, channel_names=names,
                                 channel_units=[u for _, _, u in fields],
                                 description=f"IMU of {camera} (AEDAT4 IMUS stream): "
                                 "accelerometer (g), gyroscope (deg/s), temperature (degC)"
                                 + (", magnetometer (uT)" if len(fields) > 7 else ""))
    have = list(sensors[key]["channel_names"].asstr()[()])
    if have != names:
        raise InputError(f"IMU sensor {key!r} has channels {', '.join(names)} here but "
                         f"{', '.join(have)} in an earlier input (a magnetometer in one file "
                         "only); ingest them separately", path=path)
    return key


class TriggerCollector:
    """The triggers of every ``TRIG`` stream, written as annotations at the end."""

    def __init__(self) -> None:
        self.t_us: list[np.ndarray] = []
        self.codes: list[np.ndarray] = []

    def add(self, triggers: np.ndarray) -> None:
        """triggers: (k,) structured: ``t`` uint64 us, ``source`` uint8 trigger type."""
        self.t_us.append(np.asarray(triggers["t"], dtype=np.int64))
        self.codes.append(np.asarray(triggers["source"], dtype=np.int64))

    def __len__(self) -> int:
        return sum(len(t) for t in self.t_us)

    def annotations(self, origin_us: int) -> list[tuple[float, float, str]]:
        """``(t_s, t_s, label)`` per trigger, in time order (stable for equal times)."""
        if not self.t_us:
            return []
        t_us, codes = np.concatenate(self.t_us), np.concatenate(self.codes)
        order = np.argsort(t_us, kind="stable")
        t_s = _seconds(t_us[order], origin_us)
        return [(float(t), float(t), TRIGGER_LABELS.get(int(c), f"trigger_{int(c)}"))
                for t, c in zip(t_s, codes[order], strict=True)]


__all__ = ["FrameCollector", "ImuCollector", "TriggerCollector", "IMU_CHANNELS", "MAGNETOMETER",
           "TRIGGER_LABELS"]
