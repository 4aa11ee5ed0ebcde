"""Model-based training trajectories (``tactile synth``; paper 000, sec. 5.1).

The paper trains its classifiers on trajectories generated from the identified
first-order-system model: FOS parameters drawn per force level from the fitted ones, random
action sequences with random timings and initial conditions. This package does that:

- :mod:`.config`: the typed config (``configs/synth_fos.yaml``);
- :mod:`.params`: per-level log-normal parameter distributions, from a file's fits
  (``/derived/fits/fos_press``, ``fos_slip``, written by ``tactile fit-fos``) or from the
  config (the paper's values);
- :mod:`.trajectories`: the random trials (timeline, expected counts, noise, labels);
- :mod:`.centroids`: ROI centroid trajectories of the same trials (``--centroids``, the
  spatial-temporal classifier's features, sec. 5.2);
- :mod:`.write`: the HDF5 output (an ``event_counts`` stream per trial, and a
  ``roi_centroids`` stream with ``--centroids``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from ..errors import InputError
from ..progress import Progress
from .centroids import CentroidModel as CentroidModel
from .centroids import CentroidTrajectory as CentroidTrajectory
from .centroids import draw_centroids as draw_centroids
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


#: Bins one call may write at most (trials x bins of the longest trial the config allows):
#: measured ~0.15 ms of one core and ~35 bytes of output per bin with the default config
#: (300 trials of ~205 bins in 9 s, 2 MB), so 2e7 bins are about 50 minutes and 0.7 GB.
MAX_BINS = 20_000_000
_S_PER_BIN = 1.5e-4
_BYTES_PER_BIN = 35


def check_size(n: int, config: SynthConfig) -> None:
    """Refuse, with the time and disk it would take, ``n`` trials of ``config`` that could
    hold more than :data:`MAX_BINS` bins (the longest trial the timing ranges allow)."""
    from ..config_file import format_bytes

    if n < 1:
        raise InputError(f"`n` (={n}) must be at least 1")
    t = config.timing
    longest_s = (t.approach_s[1] + config.fos.press_duration_s[1] + t.press_after_s[1]
                 + t.slip_s[1] + t.release_s[1])
    bins = n * math.ceil(longest_s / config.bin_s)
    if bins > MAX_BINS:
        raise InputError(f"`n` (={n}) trials of up to {longest_s:.3g} s in "
                         f"{config.bin_s * 1e3:g} ms bins are up to {bins:,} bins, more than "
                         f"{MAX_BINS:,}: about {bins * _S_PER_BIN / 3600:.1f} h of work and "
                         f"{format_bytes(bins * _BYTES_PER_BIN)} of output; draw fewer trials "
                         "or give wider bins (`bin_s`)")


def synthesize(
    out: str | Path,
    *,
    n: int,
    seed: int,
    config: SynthConfig | str | Path | None = None,
    bin_s: float | None = None,
    fits: str | Path | None = None,
    overwrite: bool = False,
    command: str | None = None,
    progress: Progress | None = None,
    centroids: str | Path | None = None,
) -> SynthResult:
    """Draw ``n`` trials (deterministic for a ``seed``) and write them to ``out``.

    ``config``: a :class:`SynthConfig`, the path of its YAML file, or None (the defaults);
    ``bin_s`` replaces its bin width. ``fits``: a tactile file with
    ``/derived/fits/fos_press`` and ``fos_slip`` (the parameter distributions come from its
    converged fits and its trials' force_level labels); None: from ``config.fos``.
    ``centroids``: an ROI config (YAML, or a scene's ``scene.json``) with ROIs and optics;
    every trial then also gets ROI centroid trajectories (:mod:`.centroids`, the
    ``centroids`` section of the config). Raises :class:`InputError` before any work for an
    output that is an input or cannot be written, a missing input, or more than
    :data:`MAX_BINS` bins.
    """
    from ..input_guard import check_outputs
    from ..store.atomic import check_output_file

    config_file = None if config is None or isinstance(config, SynthConfig) else config
    check_outputs({"out": out}, [fits, centroids, config_file])
    for given in (fits, centroids):
        if given is not None and not Path(given).is_file():
            raise InputError("file not found", path=given)
    check_output_file(out, overwrite=overwrite)
    if not isinstance(config, SynthConfig):
        config = load_synth_config(config)
    config = config.with_bin_s(bin_s)
    check_size(n, config)
    model = None if centroids is None else centroid_model(centroids, config)
    if fits is not None:
        press, slip, grades = from_fits(fits, config)
    else:
        (press, slip), grades = from_config(config), {}
    provenance: dict[str, Any] = {
        "config": config.model_dump(mode="json"), "seed": seed, "n": n,
        "fits": None if fits is None else str(fits),
        "distributions": {"press": press.summary(), "slip": slip.summary()},
        "force_grades": {str(k): v for k, v in sorted(grades.items())},
        "centroids": None if model is None else {"rois_config": str(centroids),
                                                 **model.as_dict()},
    }
    trials = generate_trials(n, seed=seed, config=config, press=press, slip=slip,
                             grades=grades, centroids=model)
    path = write_synth(out, trials, n=n, bin_s=config.bin_s, width_px=config.width_px,
                       height_px=config.height_px, provenance=provenance, fits_path=fits,
                       command=command, overwrite=overwrite, progress=progress,
                       centroids=model, centroids_path=centroids,
                       dataset=synth_dataset(seed, fits))
    return SynthResult(path=path, n=n, press=press, slip=slip)


def synth_dataset(seed: int, fits: str | Path | None) -> str:
    """The ``dataset`` label of synthetic trials: ``synth seed 1 from the fits of scene.h5``
    or ``synth seed 1 from the config's FOS values``."""
    source = "the config's FOS values" if fits is None else f"the fits of {Path(fits).name}"
    return f"synth seed {seed} from {source}"


def centroid_model(rois: str | Path, config: SynthConfig) -> CentroidModel:
    """The centroid model of ``config`` for the ROIs and optics of the ROI config ``rois``
    (YAML or a scene's scene.json); InputError when it has no ROIs or optics, or its ROIs
    leave the config's ``width_px`` x ``height_px`` sensor."""
    from ..spatial.config import load_config

    spatial = load_config(rois)
    if not spatial.rois:
        raise InputError("the ROI config lists no ROIs; `centroids` needs them under `rois:`",
                         path=rois)
    if spatial.optics is None:
        raise InputError("the ROI config has no `optics` (pixel_pitch_m, focal_length_m, "
                         "strip_distance_m); `centroids` needs them to turn slip speeds in m/s "
                         "into px/s (eq. 15)", path=rois)
    spatial.check_sensor(config.width_px, config.height_px)
    if abs(spatial.centroid.bin_s - config.bin_s) > 1e-12:
        raise InputError(f"the ROI config's centroid.bin_s (={spatial.centroid.bin_s:g}) differs "
                         f"from the synth bin_s (={config.bin_s:g}); `tactile centroids` would "
                         "bin recordings otherwise than the model was trained on: make them "
                         "equal", path=rois)
    return CentroidModel(spatial.rois, spatial.optics, config.width_px, config.height_px,
                         config.centroids, config.noise.opposite_fraction)


__all__ = ["MAX_BINS", "CentroidModel", "CentroidTrajectory", "LevelDistribution", "SynthConfig",
           "SynthResult", "SynthTrial", "centroid_model", "check_size", "draw_centroids",
           "draw_trial",
           "from_config", "from_fits", "generate_trials", "load_synth_config",
           "noisy_net_counts", "synth_dataset", "synthesize", "write_synth"]
