"""Multi-stream AEDAT4 files with known content, written by iniVation's ``dv-processing``.

``write_multistream(path, ...)`` writes events, APS frames, IMU samples and triggers (and,
with ``pose=True``, a pose stream, a type the ``aedat`` decoder does not read) through
dv-processing's own writer, so the files are real AEDAT4 as DV software writes them (LZ4
packets, XML header, file data table). It returns the ground truth per stream; ``streams``
picks the stream types written (a file without events: ``streams=("frames",)``). Tests skip
when dv-processing is not installed (it is in the ``dev`` extra).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pytest

T0_US = 1_700_000_000_000_000  # a camera clock with an epoch, as DV records it
W, H = 32, 24


@dataclass
class Aedat4Truth:
    """What :func:`write_multistream` wrote, per stream (times in camera microseconds)."""

    events: np.ndarray  # (n,) structured t (int64 us), x, y (uint16), p (int8 +-1)
    frame_t_us: np.ndarray  # (k,) int64
    frame_exposure_us: np.ndarray  # (k,) int64 exposure durations
    frames: np.ndarray  # (k, H, W) uint8 grey images
    imu_t_us: np.ndarray  # (m,) int64
    imu: np.ndarray  # (m, 10) float32: temperature, accel xyz, gyro xyz, mag xyz
    trigger_t_us: np.ndarray  # (j,) int64
    trigger_types: np.ndarray  # (j,) int64 dv TriggerType codes


#: The stream types :func:`write_multistream` can write (all of them by default).
STREAMS = ("events", "frames", "imu", "triggers")


def write_multistream(path: Path, *, n_events: int = 2500, n_frames: int = 3, n_imu: int = 40,
                      n_triggers: int = 2, pose: bool = False, seed: int = 0,
                      streams: tuple[str, ...] = STREAMS,
                      camera: str = "DAVIS346_test") -> Aedat4Truth:
    """Write an AEDAT4 file with the stream types ``streams`` (a subset of :data:`STREAMS`,
    default all; a pose stream too with ``pose=True``), see the module docstring. The truth
    of a stream not written is empty (length 0)."""
    dv = pytest.importorskip("dv_processing")
    unknown = set(streams) - set(STREAMS)
    if unknown:
        raise ValueError(f"unknown stream types {sorted(unknown)}; use some of {STREAMS}")
    rng = np.random.default_rng(seed)
    t = T0_US + np.sort(rng.integers(0, 50_000, n_events)).astype(np.int64)
    x = rng.integers(0, W, n_events).astype(np.uint16)
    y = rng.integers(0, H, n_events).astype(np.uint16)
    p = np.where(rng.random(n_events) < 0.5, 1, -1).astype(np.int8)
    frame_t = T0_US + 1_000 + 15_000 * np.arange(n_frames, dtype=np.int64)
    exposure = 200 + 10 * np.arange(n_frames, dtype=np.int64)
    frames = rng.integers(0, 256, (n_frames, H, W)).astype(np.uint8)
    imu_t = T0_US - 500 + 1_000 * np.arange(n_imu, dtype=np.int64)  # one before the 1st event
    imu = rng.normal(size=(n_imu, 10)).astype(np.float32)
    imu[:, 7:] = 0.0  # no magnetometer, as on DAVIS and DVXplorer cameras
    trig_t = T0_US + 2_000 + 7_000 * np.arange(n_triggers, dtype=np.int64)
    trig_types = np.array([1, 2] * n_triggers, dtype=np.int64)[:n_triggers]

    if "events" not in streams:
        n_events = 0
        t, x, y, p = t[:0], x[:0], y[:0], p[:0]
    if "frames" not in streams:
        frame_t, exposure, frames = frame_t[:0], exposure[:0], frames[:0]
        n_frames = 0
    if "imu" not in streams:
        imu_t, imu, n_imu = imu_t[:0], imu[:0], 0
    if "triggers" not in streams:
        trig_t, trig_types, n_triggers = trig_t[:0], trig_types[:0], 0

    cfg = dv.io.MonoCameraWriter.Config(camera)
    if "events" in streams:
        cfg.addEventStream((W, H))
    if "frames" in streams:
        cfg.addFrameStream((W, H))
    if "imu" in streams:
        cfg.addImuStream()
    if "triggers" in streams:
        cfg.addTriggerStream()
    if pose:
        cfg.addPoseStream()
    writer = dv.io.MonoCameraWriter(str(path), cfg)
    for chunk in np.array_split(np.arange(n_events), 5) if n_events else []:  # several packets
        store = dv.EventStore()
        for i in chunk.tolist():
            store.push_back(int(t[i]), int(x[i]), int(y[i]), bool(p[i] > 0))
        writer.writeEvents(store)
    for k in range(n_frames):
        writer.writeFrame(dv.Frame(int(frame_t[k]), int(exposure[k]), 0, 0, frames[k],
                                   dv.FrameSource.SENSOR))
    for i in range(n_imu):
        v = [float(a) for a in imu[i]]
        writer.writeImu(dv.IMU(int(imu_t[i]), *v))
    trigger_kinds = {1: dv.TriggerType.EXTERNAL_SIGNAL_RISING_EDGE,
                     2: dv.TriggerType.EXTERNAL_SIGNAL_FALLING_EDGE}
    for k in range(n_triggers):
        writer.writeTrigger(dv.Trigger(int(trig_t[k]), trigger_kinds[int(trig_types[k])]))
    if pose:
        writer.writePose(dv.Pose(int(T0_US + 9), (0.0, 0.0, 0.0), (1.0, 0.0, 0.0, 0.0), "a", "b"))
    del writer  # closes the file (writes the file data table)
    events = np.zeros(n_events, dtype=[("t", np.int64), ("x", np.uint16), ("y", np.uint16),
                                       ("p", np.int8)])
    events["t"], events["x"], events["y"], events["p"] = t, x, y, p
    return Aedat4Truth(events, frame_t, exposure, frames, imu_t, imu, trig_t, trig_types)


__all__ = ["Aedat4Truth", "STREAMS", "T0_US", "W", "H", "write_multistream"]
