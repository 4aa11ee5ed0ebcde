"""Synthetic sliding-texture recordings: materials told apart by vibration, recorded one
material after another, with a known level offset (issue 34's drift, made to order).

Each trial is ``duration_s`` of a 2-channel taxel stream at ``rate_hz``: channel ``a`` is a
sine at the material's frequency (3 + 2 m Hz for material m) on the material's level
(``10 m`` counts) plus ``offset[0]``; channel ``b`` is white noise around ``offset[1]``.
Trial labels ``material`` (``mat<m>``), ``sample`` (text, ``"1"``...) and ``origin:
synthetic``; the trial attribute ``time_origin_unix_s`` puts material m's sample i at
``1.6e9 + 1000 m + 10 i`` s (materials recorded in turn, samples in order).
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import numpy as np

from tactile_cli.store import StoreWriter


def make_texture_file(path: Path, *, n_materials: int = 3, n_samples: int = 6, seed: int = 0,
                      offset: Sequence[float] = (0.0, 0.0), rate_hz: float = 100.0,
                      duration_s: float = 2.0, first_sample: int = 1) -> Path:
    """Write the file (see the module docstring) and return ``path``; samples are numbered
    from ``first_sample`` (a later session: ``first_sample=11``)."""
    rng = np.random.default_rng(seed)
    n = round(duration_s * rate_hz)
    t_s = np.arange(n) / rate_hz
    with StoreWriter(path, command="tests.factories.texture_files") as w:
        s = w.add_sensor("finger", kind="taxel_array", sample_rate_hz=rate_hz,
                         channel_names=["a", "b"], channel_units="counts")
        for m in range(1, n_materials + 1):
            for i in range(first_sample, first_sample + n_samples):
                phase = rng.uniform(0, 2 * np.pi)
                a = 10.0 * m + np.sin(2 * np.pi * (3 + 2 * m) * t_s + phase) \
                    + 0.1 * rng.standard_normal(n) + offset[0]
                b = rng.standard_normal(n) + offset[1]
                trial = w.trial(f"mat{m}_{i}", labels={"material": f"mat{m}", "sample": str(i),
                                                       "origin": "synthetic"},
                                time_origin_unix_s=1.6e9 + 1000.0 * m + 10.0 * i)
                trial.write_signal("finger", sensor=s, data=np.stack([a, b], axis=1),
                                   t_s=t_s)
        w.commit()
    return path
