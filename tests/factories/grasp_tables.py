"""Small synthetic grasp-outcome files shaped like ``biotac_grasps`` ingested with
``configs/biotac_grasps.yaml`` (issue 34): one trial per grasp holding a one-sample stream
``electrodes`` of 72 channels (``ff_biotac_1..24``, ``mf_...``, ``th_...``: three BioTac SP
in the order of the ``biotac_sp`` layout), counts around 2,800, and the trial labels
``slipped`` (0/1) and ``object``.

The outcome is known: a grasp slips when the index finger's distal electrodes (7..10) press
less than its proximal ones (1..3) by more than a threshold, so a linear model on the
electrodes separates the classes up to the noise.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from tactile_cli.store import StoreWriter

FINGERS = ("ff", "mf", "th")
CHANNELS = [f"{f}_biotac_{i}" for f in FINGERS for i in range(1, 25)]


def write_grasp_file(path: Path, *, n_grasps: int = 60, n_objects: int = 6, seed: int = 0,
                     noise: float = 15.0) -> np.ndarray:
    """Write the file; returns the (n_grasps,) int outcome (1 = slipped)."""
    rng = np.random.default_rng(seed)
    x = 2800.0 + rng.normal(0, 120, (n_grasps, 72))
    margin = x[:, 6:10].mean(axis=1) - x[:, 0:3].mean(axis=1)
    slipped = (margin < np.median(margin)).astype(int)
    x += rng.normal(0, noise, x.shape)
    with StoreWriter(path, command="test") as w:
        sensor = w.add_sensor("electrodes", kind="taxel_array", sample_rate_hz=1.0,
                              channel_names=CHANNELS, channel_units="counts")
        for k in range(n_grasps):
            trial = w.trial(f"grasp_{k + 1}", labels={
                "slipped": int(slipped[k]), "object": f"obj{k % n_objects}",
                "origin": "synthetic", "dataset": "grasp_table"})
            trial.write_signal("electrodes", sensor=sensor, data=x[k:k + 1],
                               t_s=np.zeros(1))
        w.commit()
    return slipped


__all__ = ["CHANNELS", "FINGERS", "write_grasp_file"]
