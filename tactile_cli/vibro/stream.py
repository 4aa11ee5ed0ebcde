"""The contact detector on a live stream (``tactile detect-contact --follow``).

Samples arrive as text, one acceleration value per line (g), from a file that may still be
growing or from standard input. Every ``hop`` samples (10 ms at the paper's 100 Hz refresh)
one spectrum frame is computed (:class:`~tactile_cli.spectral.SpectrumTracker`), its band
peak taken and the trigger of :mod:`.features` updated; each update's latency (from the
arrival of the chunk that completed the frame to the trigger's decision) is timed against
the refresh period.

A live stream is checked line by line, like any input: a value that is not a number, not
finite (``nan``, ``inf``, ``1e400``), beyond :data:`MAX_ABS_G` or on a line longer than
:data:`MAX_LINE_CHARS` stops the run with one :class:`InputError` naming its line, so no
event is ever reported from it.
"""

from __future__ import annotations

import math
import sys
import time
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import IO, Any

import numpy as np

from ..errors import InputError
from ..spectral import FrameSettings, SpectrumTracker, band_peak
from .config import DetectorConfig
from .features import StreamingTrigger

SCENARIOS = ("contact", "touch")
#: Longest line a stream may send (a number, or a ``#`` comment), characters.
MAX_LINE_CHARS = 1024
#: Largest |acceleration| a sample may hold (g): an accelerometer saturates far below it.
MAX_ABS_G = 1e6


def read_samples(source: IO[str], *, name: str, chunk: int, follow_s: float = 0.0,
                 poll_s: float = 0.005) -> Iterator[np.ndarray]:
    """Chunks (up to ``chunk`` values) of the numbers in ``source``, one per line, as they
    arrive; blank lines and ``#`` comments are skipped. At the end of the data: stop, or,
    with ``follow_s`` > 0, wait for more until ``follow_s`` seconds pass without any."""
    values: list[float] = []
    line_no = 0
    idle_since: float | None = None
    pending = ""

    def parse(text: str) -> None:
        nonlocal line_no
        line_no += 1
        if len(text.rstrip("\r\n")) > MAX_LINE_CHARS:
            raise InputError(f"line {line_no} is longer than {MAX_LINE_CHARS} characters (one "
                             "acceleration value in g per line)", path=name)
        text = text.strip()
        if not text or text.startswith("#"):
            return
        try:
            value = float(text)
        except ValueError:
            raise InputError(f"line {line_no}: {text[:40]!r} is not a number (one "
                             "acceleration value in g per line)", path=name) from None
        if not (math.isfinite(value) and abs(value) <= MAX_ABS_G):
            raise InputError(f"line {line_no}: {text[:40]!r} is not a finite acceleration "
                             f"within +-{MAX_ABS_G:g} g; no event is reported from it",
                             path=name)
        values.append(value)

    while True:
        line = source.readline(MAX_LINE_CHARS + 2)
        if len(pending) + len(line) > MAX_LINE_CHARS + 1 and not line.endswith("\n"):
            parse(pending + line)  # refuses it: too long, whether or not it is complete
        if not line:
            if follow_s > 0:
                now = time.monotonic()
                idle_since = now if idle_since is None else idle_since
                if now - idle_since <= follow_s:
                    if values:
                        yield np.asarray(values)
                        values = []
                    time.sleep(poll_s)
                    continue
            if pending:
                parse(pending)
            if values:
                yield np.asarray(values)
            return
        idle_since = None
        if not line.endswith("\n") and follow_s > 0:  # a line still being written
            pending += line
            continue
        parse(pending + line)
        pending = ""
        if len(values) >= chunk:
            yield np.asarray(values)
            values = []


@dataclass
class FollowResult:
    """What a followed stream gave: samples, updates (frames), events (start, end) s from
    the first sample, and the per-update latency statistics (ms)."""

    n_samples: int = 0
    n_updates: int = 0
    events: list[tuple[float, float | None]] = field(default_factory=list)
    latencies_ms: list[float] = field(default_factory=list)
    refresh_ms: float = 10.0
    scenario: str = "contact"

    def as_dict(self) -> dict[str, Any]:
        lat = np.asarray(self.latencies_ms) if self.latencies_ms else np.zeros(1)
        return {"scenario": self.scenario, "n_samples": self.n_samples,
                "n_updates": self.n_updates,
                "events": [{"start_s": round(a, 4), "end_s": None if b is None else round(b, 4)}
                           for a, b in self.events],
                "latency_ms": {"mean": round(float(lat.mean()), 4),
                               "p99": round(float(np.percentile(lat, 99)), 4),
                               "max": round(float(lat.max()), 4)},
                "refresh_ms": round(self.refresh_ms, 3),
                "over_budget": int(np.sum(lat > self.refresh_ms)) if self.latencies_ms else 0}

    def summary_lines(self) -> list[str]:
        out = self.as_dict()
        lat = out["latency_ms"]
        return [f"{self.n_samples} samples, {self.n_updates} updates, {len(self.events)} "
                f"{self.scenario} events; per-update latency mean {lat['mean']:.3f} ms, p99 "
                f"{lat['p99']:.3f} ms, max {lat['max']:.3f} ms (refresh every "
                f"{out['refresh_ms']:g} ms; {out['over_budget']} over)"]


class ContactStream:
    """The detector of one scenario fed chunk by chunk; :meth:`push` returns the events
    that started in that chunk (their start times)."""

    def __init__(self, cfg: DetectorConfig, rate_hz: float, *, scenario: str = "contact"):
        if scenario not in SCENARIOS:
            raise ValueError(f"`scenario` (={scenario!r}) must be one of {', '.join(SCENARIOS)}")
        self.cfg, self.scenario = cfg, scenario
        settings = FrameSettings.from_seconds(rate_hz, window_s=cfg.window_s, hop_s=cfg.hop_s,
                                              n_fft=cfg.n_fft)
        self.tracker = SpectrumTracker(settings)
        if scenario == "contact":
            band_peak(np.zeros(settings.n_fft // 2 + 1), settings.f_hz, cfg.band_hz)  # checks
            self.trigger = StreamingTrigger(calibration_s=cfg.calibration_s,
                                            average=cfg.average_frames,
                                            factor=cfg.vibration_factor, centre=False)
        else:
            band_peak(np.zeros(settings.n_fft // 2 + 1), settings.f_hz, cfg.touch_band_hz)
            self.trigger = StreamingTrigger(calibration_s=cfg.calibration_s,
                                            average=cfg.touch_average_frames,
                                            threshold=cfg.touch_shift, relative=True)
        self.events: list[tuple[float, float | None]] = []
        self._on = False
        self._last_off = -np.inf
        self._t_on = 0.0
        self.latencies_ms: list[float] = []
        self.n_updates = 0

    def push(self, samples: np.ndarray, *, arrived: float | None = None) -> list[float]:
        arrived = time.perf_counter() if arrived is None else arrived
        frames = self.tracker.push(samples)
        started: list[float] = []
        if len(frames.t_s) == 0:
            return started
        amp, peak_hz = band_peak(frames.magnitude, frames.f_hz,
                                 self.cfg.band_hz if self.scenario == "contact"
                                 else self.cfg.touch_band_hz, local=self.scenario == "touch")
        values = amp if self.scenario == "contact" else peak_hz
        for t, v in zip(frames.t_s, values, strict=True):
            on = self.trigger.update(float(t), float(v))
            if on and not self._on:
                if self.events and t - self._last_off < self.cfg.merge_s:
                    self.events[-1] = (self.events[-1][0], None)
                else:
                    self.events.append((float(t), None))
                    started.append(float(t))
            elif self._on and not on:  # ends at its last frame that was on, as offline
                self.events[-1] = (self.events[-1][0], self._t_on)
                self._last_off = self._t_on
            if on:
                self._t_on = float(t)
            self._on = on
            self.n_updates += 1
            self.latencies_ms.append((time.perf_counter() - arrived) * 1e3)
        return started


def follow(source: IO[str], cfg: DetectorConfig, *, rate_hz: float, name: str,
           scenario: str = "contact", follow_s: float = 0.0,
           on_event: Callable[[float], None] | None = None) -> FollowResult:
    """Run the detector over the samples of ``source`` as they arrive (see the module
    docstring); ``on_event`` is called with each event's start time (s) when it starts."""
    try:
        stream = ContactStream(cfg, rate_hz, scenario=scenario)
    except ValueError as exc:
        raise InputError(str(exc), path=name) from None
    hop = stream.tracker.settings.hop
    n = 0
    for chunk in read_samples(source, name=name, chunk=hop, follow_s=follow_s):
        n += len(chunk)
        for t in stream.push(chunk):
            if on_event is not None:
                on_event(t)
    return FollowResult(n, stream.n_updates, stream.events, stream.latencies_ms,
                        1e3 * cfg.hop_s, scenario)


def follow_input(source: str | Path, *, config: str | Path | None = None,
                 band_hz: tuple[float, float] | None = None, rate_hz: float = 2500.0,
                 scenario: str = "contact", follow_s: float = 0.0,
                 on_event: Callable[[float], None] | None = None) -> FollowResult:
    """:func:`follow` on the text file ``source`` (``"-"``: standard input) with the
    detector of ``config`` (default: the paper's settings) and, when given, its contact band
    replaced by ``band_hz``; ``rate_hz``: the stream's sample rate; ``follow_s``: seconds to
    wait for more samples at the end of a file."""
    from ..input_guard import note_input
    from .config import detector_config

    cfg = detector_config(config, band_hz=band_hz)
    if not (math.isfinite(rate_hz) and rate_hz > 0):
        raise InputError(f"`rate_hz` (={rate_hz}) must be a positive number of samples per "
                         "second")
    if not (math.isfinite(follow_s) and follow_s >= 0):
        raise InputError(f"`follow_s` (={follow_s}) must be >= 0 seconds")
    if str(source) == "-":
        return follow(sys.stdin, cfg, rate_hz=rate_hz, name="<stdin>", scenario=scenario,
                      on_event=on_event)
    path = Path(source)
    if not path.is_file():
        raise InputError("no such file", path=path)
    note_input(path)
    with open(path, encoding="utf-8", errors="replace") as src:
        return follow(src, cfg, rate_hz=rate_hz, name=str(path), scenario=scenario,
                      follow_s=follow_s, on_event=on_event)


def write_samples(values: np.ndarray, path: str | Path, *, overwrite: bool = False) -> Path:
    """Write (n,) samples as text, one per line (what :func:`follow` reads), atomically."""
    from ..store.atomic import atomic_file

    path = Path(path)
    with atomic_file(path, overwrite=overwrite) as tmp, open(tmp, "w", encoding="ascii",
                                                              newline="\n") as f:
        np.savetxt(f, np.asarray(values, dtype=np.float64).reshape(-1), fmt="%.6g")
    return path
