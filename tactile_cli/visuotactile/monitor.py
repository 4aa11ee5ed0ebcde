"""The slip-avoidance state monitor and its monitor manager (paper 002, sec. V, Fig. 12).

A pure state machine, no I/O: it is fed one slip-signal value (and the frame time in s)
per frame and answers with :class:`MonitorEvent` records.

- :class:`SlipMonitor` (the paper's "state monitor" and timer): modes ``no_slip`` and
  ``slip``. A signal *larger* than the threshold (strictly: a signal equal to it is not a
  slip) in ``no_slip`` switches to ``slip`` and commands ``raise_grip``; in ``slip`` it
  restarts the hold timer. When ``hold_s`` (3 s by default, as in the paper) have passed
  since the last slip without a new one, the monitor switches back to ``no_slip`` and
  commands ``release_grip``. The timer is checked after the frame's signal, so a slip at
  exactly ``hold_s`` after the previous one keeps the slip mode. A NaN signal (the first
  frame of a slip signal has no predecessor) is never a slip.
- :class:`MonitorManager` (the paper's "monitor manager"): changing the grip force changes
  the contact shape and gives a large signal (the second peak of each pair in Fig. 14),
  so while the gripper moves the signal is not judged. The gripper is taken to move for
  ``motion_s`` after each grip command, or, where the recording says when it moved,
  from per-frame ``gripper_moving`` flags. The hold timer keeps counting meanwhile.
- :func:`static_threshold`: the "adaptive threshold" request made when the monitor is
  launched: ``scale`` (2) x the mean of the first ``n_static`` (30, one second at 30 Hz)
  finite slip signals, by :func:`tactile_cli.visuotactile.slip.adaptive_threshold`.
- :func:`replay`: a whole recorded signal through threshold request, manager and monitor.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import asdict, dataclass, field
from typing import Any, Literal

import numpy as np

from ..errors import InputError

Mode = Literal["no_slip", "slip"]
#: Kinds of :class:`MonitorEvent`, in the order they can happen for one frame.
EVENT_KINDS = ("ignored_moving", "slip", "timer_restart", "raise_grip", "no_slip",
               "release_grip")
#: The paper's timer: seconds without a slip before the grip is released (sec. V).
DEFAULT_HOLD_S = 3.0
#: Seconds the gripper is taken to move after a grip command when the recording does not
#: say (a small parallel gripper changing its force by a few newtons).
DEFAULT_MOTION_S = 0.5
#: Times closer than this count as equal in the hold timer, so frame times rounded when
#: written (``timestamps.csv`` holds microseconds) release on the same frame.
TIME_TOLERANCE_S = 1e-9
#: Static signals averaged by the adaptive threshold (one second at DIGIT's 30 Hz).
DEFAULT_N_STATIC = 30
#: Threshold = scale x mean static signal (the paper's "twice the average").
DEFAULT_SCALE = 2.0


@dataclass(frozen=True)
class MonitorEvent:
    """One thing the monitor did at one frame.

    t_s: frame time, seconds from the trial's time origin. frame: frame index. kind: one
    of :data:`EVENT_KINDS` -- ``slip``/``no_slip`` are mode changes, ``raise_grip``/
    ``release_grip`` grip commands, ``timer_restart`` a new slip while in slip mode,
    ``ignored_moving`` a signal above threshold not judged because the gripper moved.
    detail: a short human description (signal and threshold values)."""

    t_s: float
    frame: int
    kind: str
    detail: str

    def as_dict(self) -> dict[str, Any]:
        return asdict(self)


def _check_positive(name: str, value: float, *, allow_zero: bool = False) -> None:
    ok = value >= 0 if allow_zero else value > 0
    if not (math.isfinite(value) and ok):
        what = "non-negative" if allow_zero else "positive"
        raise InputError(f"`{name}` (={value}) must be a finite {what} number")


class SlipMonitor:
    """The state monitor and its hold timer (sec. V); see the module docstring.

    threshold: slip-signal threshold (the signal's units, e.g. mm summed over the mesh);
    a signal strictly above it is a slip. hold_s: seconds without a slip before leaving
    the slip mode.
    """

    def __init__(self, threshold: float, *, hold_s: float = DEFAULT_HOLD_S):
        _check_positive("threshold", threshold, allow_zero=True)
        _check_positive("hold_s", hold_s)
        self.threshold = float(threshold)
        self.hold_s = float(hold_s)
        self.mode: Mode = "no_slip"
        self.last_slip_s: float | None = None

    def is_slip(self, signal: float) -> bool:
        """Whether one signal value counts as a slip: strictly above the threshold (NaN
        never does)."""
        return bool(signal > self.threshold)  # NaN > x is False

    def step(self, t_s: float, frame: int, signal: float, *, judge: bool = True
             ) -> list[MonitorEvent]:
        """Feed one frame. ``judge=False`` (the manager's gripper-moving case) skips the
        signal but still runs the timer. Returns the events of this frame."""
        events: list[MonitorEvent] = []
        if judge and self.is_slip(signal):
            what = f"signal {signal:.6g} > threshold {self.threshold:.6g}"
            self.last_slip_s = t_s
            if self.mode == "no_slip":
                self.mode = "slip"
                events.append(MonitorEvent(t_s, frame, "slip", what))
                events.append(MonitorEvent(t_s, frame, "raise_grip", "slip detected"))
            else:
                events.append(MonitorEvent(t_s, frame, "timer_restart", what))
        elif self.mode == "slip" and self.last_slip_s is not None \
                and t_s - self.last_slip_s >= self.hold_s - TIME_TOLERANCE_S:
            self.mode = "no_slip"
            quiet = t_s - self.last_slip_s
            events.append(MonitorEvent(t_s, frame, "no_slip", f"no slip for {quiet:.3g} s "
                                       f"(hold {self.hold_s:g} s)"))
            events.append(MonitorEvent(t_s, frame, "release_grip", "slip gone"))
        return events


class MonitorManager:
    """Disables the monitor while the gripper moves (sec. V, "monitor manager").

    monitor: the :class:`SlipMonitor` to manage. motion_s: seconds the gripper moves
    after each grip command. A frame's signal is the change since the previous frame, so a
    frame is not judged when that interval overlaps the motion: the previous frame came
    before ``t_command + motion_s`` (the frame of the command itself is judged: its change
    came before the command). Frames given a ``gripper_moving`` flag use the flag instead
    (:func:`.signals.moving_flags` derives the same rule from motion intervals).
    """

    def __init__(self, monitor: SlipMonitor, *, motion_s: float = DEFAULT_MOTION_S):
        _check_positive("motion_s", motion_s, allow_zero=True)
        self.monitor = monitor
        self.motion_s = float(motion_s)
        self.moving_until_s = -math.inf
        self.previous_t_s = -math.inf

    def is_moving(self, t_s: float) -> bool:
        """Whether the frame at ``t_s`` (the next one fed) spans gripper motion by the
        ``motion_s`` model."""
        return self.motion_s > 0 and self.previous_t_s < self.moving_until_s

    def step(self, t_s: float, frame: int, signal: float, *,
             gripper_moving: bool | None = None) -> list[MonitorEvent]:
        """Feed one frame; ``gripper_moving`` (when the recording has it) overrides the
        ``motion_s`` model for this frame. Returns the events of this frame."""
        moving = self.is_moving(t_s) if gripper_moving is None else bool(gripper_moving)
        self.previous_t_s = t_s
        events: list[MonitorEvent] = []
        if moving and self.monitor.is_slip(signal):
            events.append(MonitorEvent(t_s, frame, "ignored_moving",
                                       f"signal {signal:.6g} > threshold "
                                       f"{self.monitor.threshold:.6g} while the gripper moves"))
        events += self.monitor.step(t_s, frame, signal, judge=not moving)
        if any(e.kind in ("raise_grip", "release_grip") for e in events):
            self.moving_until_s = t_s + self.motion_s
        return events


def static_threshold(signal: np.ndarray, *, n_static: int = DEFAULT_N_STATIC,
                     scale: float = DEFAULT_SCALE) -> float:
    """The adaptive threshold asked for when the monitor is launched: ``scale`` x the mean
    of the first ``n_static`` finite values of ``signal`` ((n_frames,) slip signal), by
    :func:`tactile_cli.visuotactile.slip.adaptive_threshold`. InputError when fewer than
    ``n_static`` finite values are there."""
    signal = np.asarray(signal, dtype=np.float64)
    finite = int(np.isfinite(signal).sum())
    if n_static < 1:
        raise InputError(f"`n_static` (={n_static}) must be at least 1")
    _check_positive("scale", scale)
    if finite < n_static:
        raise InputError(f"the adaptive threshold needs {n_static} static slip signals "
                         f"but the recording has {finite} ({signal.size} frames); record a "
                         "longer static grip, lower `n_static` or give `threshold`")
    from .slip import adaptive_threshold

    return float(adaptive_threshold(signal, n_static=n_static, scale=scale))


def n_static_frames(signal: np.ndarray, n_static: int) -> int:
    """Frames the threshold request uses: up to and including the ``n_static``-th finite
    value of ``signal`` (the monitor runs from the next frame on)."""
    idx = np.flatnonzero(np.isfinite(np.asarray(signal, dtype=np.float64)))
    return int(idx[n_static - 1]) + 1 if idx.size >= n_static else int(np.size(signal))


@dataclass(frozen=True)
class MonitorReplay:
    """A recorded slip signal replayed through the monitor.

    threshold: the threshold used. start_frame: first frame the monitor judged (frames
    before it served the threshold request). events: every :class:`MonitorEvent` in order.
    mode: (n_frames,) bool, True where the monitor was in slip mode after the frame.
    moving: (n_frames,) bool, True where the signal was not judged (gripper moving).
    """

    threshold: float
    start_frame: int
    hold_s: float
    motion_s: float
    events: list[MonitorEvent]
    mode: np.ndarray = field(repr=False)
    moving: np.ndarray = field(repr=False)

    def of_kind(self, *kinds: str) -> list[MonitorEvent]:
        """The events of the given kinds, in order."""
        return [e for e in self.events if e.kind in kinds]

    @property
    def slip_times_s(self) -> np.ndarray:
        """Times (s) of the frames the monitor judged to be slips (mode changes and timer
        restarts)."""
        return np.array([e.t_s for e in self.of_kind("slip", "timer_restart")], dtype=float)


def replay(signal: np.ndarray, t_s: np.ndarray, *, threshold: float | None = None,
           n_static: int = DEFAULT_N_STATIC, scale: float = DEFAULT_SCALE,
           hold_s: float = DEFAULT_HOLD_S, motion_s: float = DEFAULT_MOTION_S,
           gripper_moving: Sequence[bool] | np.ndarray | None = None) -> MonitorReplay:
    """Run a recorded slip signal through the monitor, frame by frame.

    signal, t_s: (n_frames,) slip signal and frame times (s). threshold: fixed threshold;
    None asks :func:`static_threshold` for it from the first ``n_static`` finite signals,
    and the monitor starts after them (the paper launches the monitor once the grasp is
    formed). gripper_moving: optional (n_frames,) per-frame flags of a moving gripper,
    used instead of the ``motion_s`` model.
    """
    signal = np.asarray(signal, dtype=np.float64)
    t_s = np.asarray(t_s, dtype=np.float64)
    if signal.ndim != 1 or t_s.shape != signal.shape:
        raise InputError(f"`signal` {signal.shape} and `t_s` {t_s.shape} must both be "
                         "(n_frames,)")
    if (np.diff(t_s) < 0).any():
        raise InputError("`t_s` must not decrease")
    moving_flags = None
    if gripper_moving is not None:
        moving_flags = np.asarray(gripper_moving, dtype=bool)
        if moving_flags.shape != signal.shape:
            raise InputError(f"`gripper_moving` {moving_flags.shape} must match `signal` "
                             f"{signal.shape}")
    if threshold is None:
        threshold = static_threshold(signal, n_static=n_static, scale=scale)
        start = n_static_frames(signal, n_static)
    else:
        start = 0
    manager = MonitorManager(SlipMonitor(threshold, hold_s=hold_s), motion_s=motion_s)
    events: list[MonitorEvent] = []
    mode = np.zeros(signal.shape, dtype=bool)
    moving = np.zeros(signal.shape, dtype=bool)
    for k in range(start, signal.size):
        flag = None if moving_flags is None else bool(moving_flags[k])
        moving[k] = manager.is_moving(float(t_s[k])) if flag is None else flag
        events += manager.step(float(t_s[k]), k, float(signal[k]), gripper_moving=flag)
        mode[k] = manager.monitor.mode == "slip"
    return MonitorReplay(float(threshold), start, float(hold_s), float(motion_s), events,
                         mode, moving)


@dataclass(frozen=True)
class SlipScore:
    """Monitor slips against known interferences.

    caught / missed: interferences with / without a judged slip inside their window.
    false_slips: judged slips (mode changes or timer restarts) inside no interference's
    window. delays_s: for each caught interference, its first judged slip minus its onset
    (s).
    """

    n_interferences: int
    caught: int
    missed: int
    false_slips: int
    delays_s: list[float]

    def as_dict(self) -> dict[str, Any]:
        return asdict(self)


def score_slips(slip_times_s: np.ndarray, interference_s: Sequence[float], *,
                ends_s: Sequence[float | None] | None = None,
                match_s: float = 0.5) -> SlipScore:
    """Match judged slip times (s) to true interferences: onsets ``interference_s`` (s) and,
    where known, their ends ``ends_s`` (s; None or absent: the onset). A judged slip in
    ``[onset - 1e-9, end + match_s]`` belongs to that interference (a slow slip goes on
    being judged while it lasts); each interference counts once."""
    slips = np.sort(np.asarray(slip_times_s, dtype=float))
    onsets = np.asarray(list(interference_s), dtype=float)
    ends = onsets.copy()
    if ends_s is not None:
        ends = np.array([o if e is None else max(float(e), o)
                         for o, e in zip(onsets, ends_s, strict=True)], dtype=float)
    order = np.argsort(onsets, kind="stable")
    onsets, ends = onsets[order], ends[order]
    if onsets.size == 0:
        return SlipScore(0, 0, 0, int(slips.size), [])
    inside = ((slips[:, None] >= onsets[None, :] - 1e-9)
              & (slips[:, None] <= ends[None, :] + match_s))
    matched = inside.any(axis=1)
    delays: list[float] = []
    for i in range(onsets.size):
        hits = slips[inside[:, i]]
        if hits.size:
            delays.append(float(hits[0] - onsets[i]))
    caught = len(delays)
    return SlipScore(int(onsets.size), caught, int(onsets.size) - caught,
                     int((~matched).sum()), delays)


__all__ = ["DEFAULT_HOLD_S", "DEFAULT_MOTION_S", "DEFAULT_N_STATIC", "DEFAULT_SCALE",
           "EVENT_KINDS", "MonitorEvent", "MonitorManager", "MonitorReplay", "SlipMonitor",
           "SlipScore", "n_static_frames", "replay", "score_slips", "static_threshold"]
