"""Small synthetic taxel streams with what real recordings do to a step detector (issue 34,
item 5): a logger that holds the sensor's value between updates, a press cut by the end of
the recording, a flat channel, a drifting baseline, a gripper closing in stages, repeated
timestamps and missing samples. Each factory returns ``(t_s, x, truth)`` from a seed;
``truth`` holds the onset (s) and the step's size where there is one.
:func:`write_press_file` puts several of them into one tactile file, one trial each.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from tactile_cli.store import StoreWriter

RATE_HZ = 42.0  # the Xela logger's rate (xela_press)
BASE = 37400.0  # counts, a uSkin z axis at rest


def _step(t: np.ndarray, onset: float, alpha: float, tau: float) -> np.ndarray:
    return np.where(t >= onset, alpha * -np.expm1(-np.clip(t - onset, 0, None) / tau), 0.0)


def first_order(seed: int, *, duration_s: float = 6.0, onset_s: float = 2.0,
                alpha: float = 2000.0, tau_s: float = 0.15, noise: float = 5.0
                ) -> tuple[np.ndarray, np.ndarray, dict]:
    """A first-order press in white noise at :data:`RATE_HZ`."""
    rng = np.random.default_rng(seed)
    t = np.arange(0.0, duration_s, 1 / RATE_HZ)
    x = BASE + _step(t, onset_s, alpha, tau_s) + rng.normal(0, noise, t.size)
    return t, x, {"onset_s": onset_s, "alpha": alpha, "tau_s": tau_s}


def held(seed: int, *, hold: int = 4, **kwargs) -> tuple[np.ndarray, np.ndarray, dict]:
    """:func:`first_order` logged faster than the sensor updates: every value repeated for
    ``hold`` samples (a run of equal samples, as ``xela_press`` has 76 % repeats)."""
    t, x, truth = first_order(seed, **kwargs)
    index = (np.arange(t.size) // hold) * hold
    return t, x[index], {**truth, "hold": hold}


def cut_at_end(seed: int, *, samples_after: int = 2, tau_s: float = 0.15
               ) -> tuple[np.ndarray, np.ndarray, dict]:
    """A press whose onset lies ``samples_after`` samples before the recording ends (the
    detector before issue 34 raised IndexError on such a step for 7..16 samples at
    tau 0.15-0.4 s: its refined onset lay past the lagged differences)."""
    t = np.arange(0.0, 6.0, 1 / RATE_HZ)
    onset = float(t[-samples_after])
    x = BASE + _step(t, onset, 2000.0, tau_s) + np.random.default_rng(seed).normal(0, 5, t.size)
    return t, x, {"onset_s": onset, "alpha": 2000.0, "tau_s": tau_s}


def flat(seed: int, *, duration_s: float = 4.0) -> tuple[np.ndarray, np.ndarray, dict]:
    """A channel that never changes (a dead taxel): no step."""
    t = np.arange(0.0, duration_s, 1 / RATE_HZ)
    return t, np.full(t.size, BASE), {}


def drifting(seed: int, *, drift_per_s: float = 150.0) -> tuple[np.ndarray, np.ndarray, dict]:
    """:func:`first_order` on a baseline that drifts by ``drift_per_s`` counts per second
    (about the press's size over the recording: temperature, creep)."""
    t, x, truth = first_order(seed, duration_s=12.0, onset_s=5.0)
    return t, x + drift_per_s * t, {**truth, "drift_per_s": drift_per_s}


def staircase(seed: int) -> tuple[np.ndarray, np.ndarray, dict]:
    """A press in three stages 0.25 s apart (a gripper closing in steps), held samples,
    then an overshoot that relaxes by 40 % of the rise: one press, not three steps."""
    rng = np.random.default_rng(seed)
    t = np.arange(0.0, 8.0, 1 / RATE_HZ)
    onset = 2.0
    x = BASE + sum(_step(t, onset + 0.25 * k, 800.0, 0.03) for k in range(3))
    x = x - _step(t, onset + 0.6, 960.0, 0.8) + rng.normal(0, 3, t.size)
    index = (np.arange(t.size) // 4) * 4
    return t, x[index], {"onset_s": onset, "alpha": 2400.0}


def repeated_stamps(seed: int) -> tuple[np.ndarray, np.ndarray, dict]:
    """:func:`first_order` whose logger stamped every fifth sample with the time of the one
    before it (a repeated millisecond, as the fabric set has)."""
    t, x, truth = first_order(seed)
    t = t.copy()
    t[5::5] = t[4::5][: t[5::5].size]
    return t, x, truth


def with_gaps(seed: int) -> tuple[np.ndarray, np.ndarray, dict]:
    """:func:`first_order` with a few samples lost as NaN."""
    t, x, truth = first_order(seed)
    x = x.copy()
    x[np.random.default_rng(seed).choice(t.size, 5, replace=False)] = np.nan
    return t, x, truth


#: name -> factory, for the file and the parametrised tests.
CASES = {"first_order": first_order, "held": held, "cut_at_end": cut_at_end, "flat": flat,
         "drifting": drifting, "staircase": staircase, "with_gaps": with_gaps,
         "repeated_stamps": repeated_stamps}
#: The cases a tactile file can hold (the store refuses a time that does not increase and
#: non-finite samples).
FILE_CASES = tuple(name for name in CASES if name not in ("repeated_stamps", "with_gaps"))


def write_press_file(path: Path, cases: dict[str, int] | None = None) -> dict[str, dict]:
    """One trial per case (name -> seed; default every case of :data:`FILE_CASES`, seed 0),
    each a stream ``taxels`` of one channel ``z`` (counts) sampled as its factory makes it;
    returns name -> truth."""
    cases = cases or dict.fromkeys(FILE_CASES, 0)
    truth = {}
    with StoreWriter(path, command="test") as w:
        sensor = w.add_sensor("pad", kind="taxel_array", sample_rate_hz=RATE_HZ,
                              channel_names=["z"], channel_units=["counts"])
        for name, seed in cases.items():
            t, x, truth[name] = CASES[name](seed)
            w.trial(name).write_signal("taxels", sensor=sensor, data=x[:, None], t_s=t)
        w.commit()
    return truth


__all__ = ["BASE", "CASES", "FILE_CASES", "RATE_HZ", "cut_at_end", "drifting", "first_order",
           "flat", "held", "repeated_stamps", "staircase", "with_gaps", "write_press_file"]
