"""A tactile file whose sampled stream (``taxels``, channels fz_0..fz_3 in N and one
temperature channel) follows known first-order steps inside annotated ``press`` regions,
for the ``fit-fos --stream`` tests."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from tactile_cli.store import StoreWriter

RATE_HZ = 200.0
NOISE_N = 0.01
PRESS = (0.5, 2.0)  # s: the annotated press region of every trial
RELEASE = (2.0, 2.5)


def write_stream_file(path: Path, *, n_trials: int = 3, seed: int = 0,
                      annotate: bool = True) -> list[dict]:
    """Write the file; returns per trial and channel the true alpha (N), tau (s) and offset."""
    rng = np.random.default_rng(seed)
    t = np.arange(0.0, 2.5, 1 / RATE_HZ)
    truth = []
    with StoreWriter(path, command="test") as w:
        sensor = w.add_sensor("skin", kind="taxel_array", sample_rate_hz=RATE_HZ,
                              channel_names=["fz_0", "fz_1", "fz_2", "fz_3", "temp"],
                              channel_units=["N", "N", "N", "N", "degC"])
        for k in range(n_trials):
            cols = []
            for c in range(4):
                alpha, tau = rng.uniform(1.0, 3.0), rng.uniform(0.08, 0.25)
                offset = rng.uniform(-0.5, 0.5)
                x = offset + np.where(t >= PRESS[0],
                                      alpha * (1 - np.exp(-(t - PRESS[0]) / tau)), 0.0)
                cols.append(x + rng.normal(0, NOISE_N, len(t)))
                truth.append({"trial": f"trial_{k}", "channel": f"fz_{c}", "alpha": alpha,
                              "tau_s": tau, "offset": offset})
            cols.append(25.0 + rng.normal(0, 0.01, len(t)))
            ann = [(PRESS[0], PRESS[1], "press"), (RELEASE[0], RELEASE[1], "release")] \
                if annotate else []
            trial = w.trial(f"trial_{k}", annotations=ann)
            trial.write_signal("taxels", sensor=sensor, data=np.stack(cols, axis=1), t_s=t)
        w.commit()
    return truth
