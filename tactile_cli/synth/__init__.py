"""Model-based training trajectories (``tactile synth``; paper 000, sec. 5.1).

The paper trains its classifiers on trajectories generated from the identified
first-order-system model: FOS parameters drawn per force level from the fitted ones, random
action sequences with random timings and initial conditions. This package does that:

- :mod:`.config`: the typed config (``configs/synth_fos.yaml``);
- :mod:`.params`: per-level log-normal parameter distributions, from a file's fits
  (``/derived/fits/fos_press``, ``fos_slip``, written by ``tactile fit-fos``) or from the
  config (the paper's values);
- :mod:`.trajectories`: the random trials (timeline, expected counts, noise, labels);
- :mod:`.write`: the HDF5 output (an ``event_counts`` stream per trial).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

from ..progress import Progress
from .config import SynthConfig as SynthConfig
from .config import load_synth_config as load_synth_config
from .params import LevelDistribution as LevelDistribution
from .params import from_config as from_config
from .params import from_fits as from_fits
from .trajectories import SynthTrial as SynthTrial
from .trajectories import draw_trial as draw_trial
from .trajectories import generate_trials as generate_trials
from .trajectories import noisy_net_counts as noisy_net_counts
from .write import write_synth as write_synth


@dataclass(frozen=True)
class SynthResult:
    """What :func:`synthesize` wrote: the file and the distributions it drew from."""

    path: Path
    n: int
    press: LevelDistribution
    slip: LevelDistribution


def synthesize(
    out: str | Path,
    *,
    n: int,
    seed: int,
    config: SynthConfig,
    fits: str | Path | None = None,
    overwrite: bool = False,
    command: str | None = None,
    progress: Progress | None = None,
) -> SynthResult:
    """Draw ``n`` trials (deterministic for a ``seed``) and write them to ``out``.

    ``fits``: a tactile file with ``/derived/fits/fos_press`` and ``fos_slip`` (the
    parameter distributions come from its converged fits and its trials' force_level
    labels); None: from ``config.fos``.
    """
    if fits is not None:
        press, slip, grades = from_fits(fits, config)
    else:
        (press, slip), grades = from_config(config), {}
    provenance: dict[str, Any] = {
        "config": config.model_dump(mode="json"), "seed": seed, "n": n,
        "fits": None if fits is None else str(fits),
        "distributions": {"press": press.summary(), "slip": slip.summary()},
        "force_grades": {str(k): v for k, v in sorted(grades.items())},
    }
    trials = generate_trials(n, seed=seed, config=config, press=press, slip=slip,
                             grades=grades)
    path = write_synth(out, trials, n=n, bin_s=config.bin_s, width_px=config.width_px,
                       height_px=config.height_px, provenance=provenance, fits_path=fits,
                       command=command, overwrite=overwrite, progress=progress)
    return SynthResult(path=path, n=n, press=press, slip=slip)


__all__ = ["LevelDistribution", "SynthConfig", "SynthResult", "SynthTrial", "draw_trial",
           "from_config", "from_fits", "generate_trials", "load_synth_config",
           "noisy_net_counts", "synthesize", "write_synth"]
