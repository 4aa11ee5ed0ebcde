"""Preparation of ingested accel-tree recordings for training (paper 001, sec. 4).

:func:`prepare_file` reads a file written by ``tactile ingest --format accel-tree`` (or by
this function) and writes a new file in which

- every recording is cut into **segments** of ``segment_s`` seconds, each a trial named
  ``<recording>_s<k>`` with the recording's labels plus ``recording`` and ``segment``
  (``<recording>/s<k>``). Training configs split with ``split: {mode: group, by:
  segment}``, so whole segments, never neighbouring windows, land in train, val or test
  (the paper's 80/10/10 split);
- the ``accel`` stream carries, besides ``motion``, the numeric per-sample label
  ``speed_cm_s``: the speed of whatever moves, ``100 x max(|v_slip|, |v_slide|)`` (the
  object's speed during slippage, the slider's during sliding, below 5 during no-motion;
  the paper's speed target, sec. 6.3);
- optionally the accelerations are **band-limited** to ``cutoff_hz`` (sec. 6.4): an
  8th-order zero-phase Butterworth anti-alias filter, resampling to ``2 x cutoff_hz``
  (what a sensor of that bandwidth delivers) and back to the original rate, so that
  windows keep their length in time and every model of a bandwidth study sees the same
  window and labels.

Per-window mean removal and scaling to [-1, 1] is not done here but in the training
config (``data.window_norm: center_scale``), so evaluation applies it the same way.
"""

from __future__ import annotations

from dataclasses import dataclass
from fractions import Fraction
from pathlib import Path
from typing import Any

import numpy as np
from scipy import signal as _signal

from ..errors import InputError
from ..progress import NullProgress, Progress
from ..spectral import limit_bandwidth

#: Streams and labels the accel-tree ingest writes (tactile_cli.ingest.accel_tree).
from ..store.provenance import current_command
from ..store.trials import TactileFile
from ..store.writer import StoreWriter

ACCEL_STREAM = "accel"
VELOCITY_STREAM = "velocity"
MOTION_LABEL = "motion"
SPEED_LABEL = "speed_cm_s"
#: Most segments (trials) one prepared file may hold: a segment shorter than a training
#: window only makes the file (and every later read of it) slow.
MAX_SEGMENTS = 10_000


@dataclass(frozen=True)
class PrepareResult:
    """What :func:`prepare_file` wrote."""

    out: Path
    n_recordings: int
    n_segments: int
    segment_s: float
    cutoff_hz: float | None
    sample_rate_hz: float

    def as_dict(self) -> dict[str, Any]:
        return {"out": str(self.out), "n_recordings": self.n_recordings,
                "n_segments": self.n_segments, "segment_s": self.segment_s,
                "cutoff_hz": self.cutoff_hz, "sample_rate_hz": self.sample_rate_hz}

    def summary_lines(self) -> list[str]:
        return [f"wrote {self.out}: {self.n_segments} segments of {self.segment_s:g} s from "
                f"{self.n_recordings} recordings"
                + (f", band-limited to {self.cutoff_hz:g} Hz" if self.cutoff_hz else "")]


def speed_cm_s(v_slip_m_s: np.ndarray, v_slide_m_s: np.ndarray) -> np.ndarray:
    """(n,) speed target in cm/s: ``100 x max(|v_slip|, |v_slide|)`` from (n,) m/s."""
    return 100.0 * np.maximum(np.abs(v_slip_m_s), np.abs(v_slide_m_s))


def band_limit_round_trip(x: np.ndarray, rate_hz: float, cutoff_hz: float) -> np.ndarray:
    """(n, c) -> (n, c) float32: :func:`tactile_cli.spectral.limit_bandwidth` to
    ``cutoff_hz`` (filter and resample), then back to ``rate_hz`` on the same grid."""
    low, low_rate = limit_bandwidth(x, rate_hz, cutoff_hz)
    if low_rate == rate_hz:
        return low.astype(np.float32)
    ratio = Fraction(rate_hz / low_rate).limit_denominator(1000)
    up = _signal.resample_poly(low, ratio.numerator, ratio.denominator, axis=0)
    n = x.shape[0]
    if up.shape[0] < n:
        up = np.concatenate([up, np.repeat(up[-1:], n - up.shape[0], axis=0)])
    return up[:n].astype(np.float32)


def segment_bounds(n: int, segment_samples: int) -> list[tuple[int, int]]:
    """``[(start, stop), ...]`` cutting ``n`` samples into pieces of ``segment_samples``;
    a last piece shorter than half a segment joins the one before it."""
    if segment_samples < 1:
        raise ValueError(f"`segment_samples` (={segment_samples}) must be >= 1")
    edges = list(range(0, n, segment_samples)) + [n]
    if len(edges) > 2 and edges[-1] - edges[-2] < segment_samples / 2:
        edges.pop(-2)
    return list(zip(edges[:-1], edges[1:], strict=True))


def check_settings(segment_s: float, cutoff_hz: float | None) -> None:
    """``segment_s`` and ``cutoff_hz`` positive finite numbers (one InputError)."""
    if not (np.isfinite(segment_s) and segment_s > 0):
        raise InputError(f"`segment_s` (={segment_s}) must be a positive number of seconds")
    if cutoff_hz is not None and not (np.isfinite(cutoff_hz) and cutoff_hz > 0):
        raise InputError(f"`cutoff_hz` (={cutoff_hz}) must be a positive frequency in Hz")


def check_segments(f: TactileFile, segment_s: float, cutoff_hz: float | None) -> None:
    """Before any work, from the first recording (its rate and length, taken as every
    recording's): segments of at least one sample, at most about :data:`MAX_SEGMENTS` of
    them, and a cut-off the resampling can reach
    (:func:`tactile_cli.spectral.lowest_cutoff_hz`)."""
    from ..spectral import lowest_cutoff_hz

    first = f.trial(f.trial_names[0])
    if not first.has_signal(ACCEL_STREAM):
        return  # the loop names the missing stream
    sig = first.signal(ACCEL_STREAM)
    rate = float(sig.sample_rate_hz)
    step = int(round(segment_s * rate))
    if step < 1:
        raise InputError(f"`segment_s` (={segment_s:g}) is shorter than one sample of the "
                         f"{rate:g} Hz recordings; give {1 / rate:.3g} s or more", path=f.path)
    n = -(-len(sig.data) // step) * len(f.trial_names)
    if n > MAX_SEGMENTS:
        raise InputError(f"`segment_s` (={segment_s:g}) cuts the recordings into about {n:,} "
                         f"segments of {step} samples (at most {MAX_SEGMENTS:,}); give a "
                         "longer segment", path=f.path)
    if cutoff_hz is not None and cutoff_hz < lowest_cutoff_hz(rate):
        raise InputError(f"`cutoff_hz` (={cutoff_hz:g}) is below {lowest_cutoff_hz(rate):g} "
                         f"Hz, the lowest cut-off of the {rate:g} Hz recordings", path=f.path)


def prepare_file(src: str | Path, out: str | Path, *, segment_s: float = 2.0,
                 cutoff_hz: float | None = None, overwrite: bool = False,
                 progress: Progress | None = None, command: str | None = None
                 ) -> PrepareResult:
    """Write ``out`` from the accel-tree file ``src`` (see the module docstring).

    Raises :class:`InputError` (naming the file and trial) when a trial lacks the
    ``accel`` or ``velocity`` stream or the ``motion`` label, when ``segment_s`` is not
    positive or ``cutoff_hz`` not positive.
    """
    from ..input_guard import check_outputs
    from ..store.atomic import check_output_file

    progress = progress or NullProgress()
    check_settings(segment_s, cutoff_hz)
    check_outputs({"out": out}, [src])
    check_output_file(out, overwrite=overwrite)
    src = Path(src)
    config = {"segment_s": segment_s, "cutoff_hz": cutoff_hz}
    n_segments = 0
    with TactileFile(src) as f:
        names = f.trial_names
        if not names:
            raise InputError("the file has no trials", path=src)
        check_segments(f, segment_s, cutoff_hz)
        with StoreWriter(out, command=command or current_command(), config=config,
                         overwrite=overwrite) as w:
            w.add_source(src)
            sensor_name = rate = None
            progress.start(len(names), "recordings")
            for name in names:
                trial = f.trial(name)
                for stream in (ACCEL_STREAM, VELOCITY_STREAM):
                    if not trial.has_signal(stream):
                        raise InputError(f"trial has no {stream!r} stream; prepare reads files "
                                         "of `tactile ingest --format accel-tree`",
                                         path=src, where=trial.where)
                accel = trial.signal(ACCEL_STREAM)
                velocity = trial.signal(VELOCITY_STREAM).data
                if MOTION_LABEL not in accel.sample_labels:
                    raise InputError(f"no per-sample label {MOTION_LABEL!r}", path=src,
                                     where=f"{trial.where}/signals/{ACCEL_STREAM}")
                sensor = accel.sensor
                if sensor_name is None:
                    rate = sensor.sample_rate_hz
                    extra = {k: v for k, v in sensor.attrs.items()
                             if k == "full_scale_g"}
                    desc = str(sensor.attrs.get("description", ""))
                    if cutoff_hz is not None:
                        desc += f"; band-limited to {cutoff_hz:g} Hz (accel-prepare)"
                    sensor_name = w.add_sensor(
                        ACCEL_STREAM, kind=sensor.kind, sample_rate_hz=rate,
                        channel_names=accel.channel_names, channel_units=accel.channel_units,
                        description=desc, **extra)
                x = accel.data if cutoff_hz is None else \
                    band_limit_round_trip(accel.data, float(rate), cutoff_hz)
                motion = accel.sample_labels[MOTION_LABEL]
                speed = speed_cm_s(velocity[:, 0], velocity[:, 1])
                step = max(1, int(round(segment_s * float(rate))))
                for k, (lo, hi) in enumerate(segment_bounds(x.shape[0], step)):
                    labels = {**trial.labels, "recording": name, "segment": f"{name}/s{k:03d}"}
                    tw = w.trial(f"{name}_s{k:03d}", labels=labels, sources=[0])
                    tw.write_signal(ACCEL_STREAM, sensor=sensor_name, data=x[lo:hi],
                                    t_s=accel.t_s[lo:hi] - accel.t_s[lo], sample_labels={
                                        MOTION_LABEL: (motion.values[lo:hi], motion.classes),
                                        SPEED_LABEL: (speed[lo:hi], None)})
                    n_segments += 1
                progress.advance(1)
            progress.finish()
            w.commit()
    return PrepareResult(Path(out), len(names), n_segments, segment_s, cutoff_hz,
                         float(rate or 0.0))
