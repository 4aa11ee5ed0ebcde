"""The event-count trajectory of one approach-press-slip-release trial (paper 000, sec. 4.2).

One model shared by the marker-event scene (``tactile simulate marker-events``, which turns it
into events) and the model-based trajectories (``tactile synth``, which samples it with
noise), so that the two generators agree on what the FOS parameters mean while differing in
everything else (events, optics, noise, saturation).

The net event count per 20 ms bin of a trial is the superposition of linear first-order
responses (the system is linear, so contributions add):

- approach ``[0, press_start)``: nothing but background (no contact);
- press ``[press_start, slip_start)``: eq. 16, the pulse response of ``alpha_press``,
  ``tau_press_s`` to a press lasting ``press_duration_s`` (T); its decay continues into the
  later regions;
- slip ``[slip_start, release_start)``: eq. 17, the ramp response of ``alpha_slip``,
  ``tau_slip_s``, added to the press tail;
- release ``[release_start, end)``: the markers spring back, the reverse of a press: a
  negative pulse of ``release_gain * alpha_press`` with ``tau_press_s`` and duration
  ``release_duration_s``, while what the slip built up decays with ``tau_press_s``.

The release model is this toolkit's assumption (the paper fits only press and slip); it
makes release the mirror of press in the net count, which is what the strips closing and
the markers uncovering do to the two polarities.

Times in seconds from the trial's time origin; counts in events per bin. Every response is
evaluated at bin centres, which is within 0.02 % of the bin integral for tau >= 0.1 s.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass

import numpy as np

from ..vocabulary import ACTIONS, BIN_S
from .models import pulse_response, ramp_response


@dataclass(frozen=True)
class ActionTimeline:
    """When each action of one trial starts, seconds from the trial's time origin.

    ``press_duration_s`` is T of eq. 16 (how long the press input lasts, at most the press
    region); ``release_duration_s`` the same for the release.
    """

    press_start_s: float
    slip_start_s: float
    release_start_s: float
    end_s: float
    press_duration_s: float
    release_duration_s: float = 0.2

    def __post_init__(self) -> None:
        order = (0.0, self.press_start_s, self.slip_start_s, self.release_start_s, self.end_s)
        if any(b <= a for a, b in zip(order, order[1:], strict=False)):
            raise ValueError(
                "action times must increase: 0 < press_start_s < slip_start_s < "
                f"release_start_s < end_s, got {order[1:]}"
            )
        if not 0 < self.press_duration_s <= self.slip_start_s - self.press_start_s:
            raise ValueError(
                f"`press_duration_s` (={self.press_duration_s}) must be in (0, press region "
                f"length {self.slip_start_s - self.press_start_s:.3f} s]"
            )
        if self.release_duration_s <= 0:
            raise ValueError(f"`release_duration_s` (={self.release_duration_s}) must be > 0")

    @property
    def boundaries_s(self) -> np.ndarray:
        """(5,) start of approach, press, slip, release and the trial end, seconds."""
        return np.array([0.0, self.press_start_s, self.slip_start_s, self.release_start_s,
                         self.end_s])

    def intervals(self) -> list[tuple[float, float, str]]:
        """``(start_s, end_s, action)`` of the four regions, as trial annotations."""
        b = self.boundaries_s
        return [(float(b[i]), float(b[i + 1]), ACTIONS[i]) for i in range(len(ACTIONS))]

    def labels(self, t_s: np.ndarray) -> np.ndarray:
        """(n,) int8 action index (into :data:`tactile_cli.vocabulary.ACTIONS`) at each time
        ``t_s`` (seconds)."""
        edges = self.boundaries_s[1:4]
        return np.searchsorted(edges, np.asarray(t_s, dtype=np.float64), side="right").astype(
            np.int8)

    def as_dict(self) -> dict[str, float]:
        return asdict(self)


@dataclass(frozen=True)
class FosActionParams:
    """First-order-system parameters of one trial: gains in events per bin, times in s."""

    alpha_press: float  # alpha_1 of eq. 16
    tau_press_s: float  # tau_1
    alpha_slip: float  # alpha_2 of eq. 17
    tau_slip_s: float  # tau_2
    release_gain: float = 0.8  # release pulse gain as a fraction of alpha_press

    def __post_init__(self) -> None:
        for name in ("alpha_press", "tau_press_s", "alpha_slip", "tau_slip_s"):
            value = getattr(self, name)
            if not (np.isfinite(value) and value > 0):
                raise ValueError(f"`{name}` (={value}) must be finite and > 0")
        if not (np.isfinite(self.release_gain) and self.release_gain >= 0):
            raise ValueError(f"`release_gain` (={self.release_gain}) must be finite and >= 0")

    def as_dict(self) -> dict[str, float]:
        return asdict(self)


def bin_centres_s(end_s: float, bin_s: float = BIN_S) -> np.ndarray:
    """(n_bins,) centres of the bins ``[k bin_s, (k+1) bin_s)`` covering ``[0, end_s)``, s."""
    n_bins = int(np.floor(end_s / bin_s + 1e-9))
    return (np.arange(n_bins) + 0.5) * bin_s


def net_count_components(
    t_s: np.ndarray, timeline: ActionTimeline, params: FosActionParams
) -> dict[str, np.ndarray]:
    """Expected net events per bin of each action's response at times ``t_s`` (s), (n,) each.

    Keys ``press``, ``slip``, ``release``; their sum is :func:`expected_net_counts`. Each
    component is zero before its action starts.
    """
    t = np.asarray(t_s, dtype=np.float64)
    tl, pa = timeline, params
    since_press = t - tl.press_start_s
    press = np.where(
        since_press >= 0,
        pulse_response(np.maximum(since_press, 0.0), pa.alpha_press, pa.tau_press_s,
                       tl.press_duration_s),
        0.0,
    )
    since_slip = t - tl.slip_start_s
    slip_len = tl.release_start_s - tl.slip_start_s
    ramp = ramp_response(np.clip(since_slip, 0.0, slip_len), pa.alpha_slip, pa.tau_slip_s)
    since_release = t - tl.release_start_s
    # after release the slip's build-up decays with the press time constant
    decay = np.exp(-np.maximum(since_release, 0.0) / pa.tau_press_s)
    slip = np.where(since_slip >= 0, ramp * np.where(since_release >= 0, decay, 1.0), 0.0)
    release = np.where(
        since_release >= 0,
        -pulse_response(np.maximum(since_release, 0.0), pa.release_gain * pa.alpha_press,
                        pa.tau_press_s, tl.release_duration_s),
        0.0,
    )
    return {"press": press, "slip": slip, "release": release}


def expected_net_counts(
    t_s: np.ndarray, timeline: ActionTimeline, params: FosActionParams
) -> np.ndarray:
    """(n,) expected net (positive minus negative) events per bin at times ``t_s`` (s)."""
    parts = net_count_components(t_s, timeline, params)
    return parts["press"] + parts["slip"] + parts["release"]


def saturate(counts: np.ndarray, limit: float | None) -> np.ndarray:
    """Big-force flattening ``limit * tanh(counts / limit)`` (odd, so release flattens too);
    ``None`` or ``inf`` leaves the counts linear."""
    if limit is None or not np.isfinite(limit):
        return np.asarray(counts, dtype=np.float64)
    if limit <= 0:
        raise ValueError(f"`limit` (={limit}) must be > 0")
    return limit * np.tanh(np.asarray(counts, dtype=np.float64) / limit)


__all__ = ["ActionTimeline", "FosActionParams", "bin_centres_s",
           "net_count_components", "expected_net_counts", "saturate"]
