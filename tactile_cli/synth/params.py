"""Per-force-level distributions of the FOS parameters that ``tactile synth`` draws from.

Paper 000, sec. 5.1: the trajectories that train the classifiers are generated from the
identified FOS model, with parameters as the fits found them per force level. The choice
made here (one model for fitted and for configured parameters):

- Each parameter group, press ``(alpha_press, tau_press_s[, press_duration_s])`` and slip
  ``(alpha_slip, tau_slip_s)``, is **log-normal per force level**:
  ``log(params) ~ N(mu_level, Sigma)``. Logs keep gains and times positive and make the
  spread relative, which is how the fitted values scatter (alpha grows with the level, its
  spread in proportion).
- ``mu_level`` is the mean of the logs of that level's converged fits. A level with fewer
  than ``min_fits_per_level`` fits gets ``mu`` interpolated linearly in the level number
  between the nearest levels that have them (held constant beyond the outermost ones), so
  every configured level can be drawn.
- ``Sigma`` is the **pooled** within-level covariance of the logs: each fit's deviation from
  its level's mean, over the levels with at least two fits, divided by ``N - L``. With the
  paper's 4 trials per level a per-level covariance would be mostly noise; pooling assumes
  the trial-to-trial spread (which includes the fit error) is alike at every level, and it
  keeps the correlation of alpha and tau that the fits show.
- Without a fits file the config gives ``mu_level`` (the paper's values, sec. 4.2: alpha_1
  evenly spaced over [1365, 2280] by level, tau_1 ~ 0.3 s, alpha_2 ~ 1615, tau_2 ~ 0.325 s)
  and a diagonal ``Sigma`` of the configured relative spreads.

The press length T is part of the press group when the fits fitted it; otherwise (T known
to the fits, or no fits) it is drawn uniformly from ``fos.press_duration_s``.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import InputError
from ..fos.regions import label_int
from ..fos.table import GROUP_NAMES, read_fit_group
from ..store.trials import TactileFile
from .config import SynthConfig

PRESS_NAMES = ("alpha_press", "tau_press_s", "press_duration_s")
SLIP_NAMES = ("alpha_slip", "tau_slip_s")


@dataclass(frozen=True)
class LevelDistribution:
    """Log-normal parameters per force level.

    names: the parameters, in column order. levels: (n_levels,) force levels.
    log_mean: (n_levels, n_params) mean of log(parameter) per level.
    log_cov: (n_params, n_params) covariance of the logs within a level.
    n_fits: (n_levels,) fits behind each level's mean (0: interpolated, or from the config).
    source: where it came from (a fits group, or ``"config"``).
    """

    names: tuple[str, ...]
    levels: np.ndarray
    log_mean: np.ndarray
    log_cov: np.ndarray
    n_fits: np.ndarray
    source: str

    def sample(self, level: int, rng: np.random.Generator) -> dict[str, float]:
        """One draw of every parameter for force ``level``."""
        idx = np.flatnonzero(self.levels == level)
        if idx.size != 1:
            raise ValueError(f"`level` (={level}) is not one of {self.levels.tolist()}")
        z = rng.standard_normal(len(self.names))
        draw = self.log_mean[idx[0]] + _sqrt_psd(self.log_cov) @ z
        return {name: float(np.exp(v)) for name, v in zip(self.names, draw, strict=True)}

    def summary(self) -> dict[str, Any]:
        """JSON-ready description (per-level medians, log sds, fit counts), for provenance."""
        sd = np.sqrt(np.diag(self.log_cov))
        return {
            "source": self.source, "model": "log-normal per force level, pooled covariance",
            "names": list(self.names), "levels": self.levels.tolist(),
            "median": {n: np.exp(self.log_mean[:, j]).round(6).tolist()
                       for j, n in enumerate(self.names)},
            "log_sd": {n: round(float(s), 6) for n, s in zip(self.names, sd, strict=True)},
            "log_corr": _corr(self.log_cov).round(4).tolist(),
            "n_fits": self.n_fits.tolist(),
        }


def _sqrt_psd(cov: np.ndarray) -> np.ndarray:
    """A matrix square root ``L`` with ``L L^T = cov`` for a covariance that may be singular
    (a parameter with no spread)."""
    w, v = np.linalg.eigh(cov)
    return v * np.sqrt(np.clip(w, 0.0, None))


def _corr(cov: np.ndarray) -> np.ndarray:
    sd = np.sqrt(np.diag(cov))
    with np.errstate(invalid="ignore", divide="ignore"):
        corr = cov / np.outer(sd, sd)
    return np.where(np.isfinite(corr), corr, 0.0)


def from_config(config: SynthConfig) -> tuple[LevelDistribution, LevelDistribution]:
    """Press ``(alpha_press, tau_press_s)`` and slip distributions from the config's
    ``fos`` section (the paper's values by default)."""
    fos = config.fos
    levels = np.array(config.levels.selected)
    n = config.levels.n_levels
    frac = (levels - 1) / (n - 1) if n > 1 else np.zeros(len(levels))
    lo, hi = fos.alpha_press_range
    press_mean = np.stack([np.log(lo + (hi - lo) * frac),
                           np.full(len(levels), np.log(fos.tau_press_s))], axis=1)
    slip_mean = np.tile([np.log(fos.alpha_slip), np.log(fos.tau_slip_s)], (len(levels), 1))
    zeros = np.zeros(len(levels), dtype=np.int64)
    press = LevelDistribution(
        PRESS_NAMES[:2], levels, press_mean,
        np.diag([fos.alpha_press_jitter_rel ** 2, fos.tau_press_jitter_rel ** 2]), zeros,
        "config")
    slip = LevelDistribution(
        SLIP_NAMES, levels, slip_mean,
        np.diag([fos.alpha_slip_jitter_rel ** 2, fos.tau_slip_jitter_rel ** 2]), zeros,
        "config")
    return press, slip


def _trial_labels(file: TactileFile, trials: np.ndarray) -> tuple[np.ndarray, list[str | None]]:
    """force_level (int) and force_grade (or None) of each trial named in a fits group."""
    levels, grades = [], []
    path = file.path
    for name in map(str, trials):
        if name not in file.trial_names:
            raise InputError(f"the fits name trial {name!r}, which the file does not have; "
                             "re-run `tactile fit-fos --overwrite`", path=path)
        trial = file.trial(name)
        level = label_int(trial.labels.get("force_level"))
        if level is None:
            raise InputError("no integer force_level label; synth draws parameters per "
                             "force level (label the trials, e.g. `tactile ingest "
                             "--trial-labels FILE`)",
                             path=path, where=f"{trial.where}/labels")
        grade = trial.labels.get("force_grade")
        levels.append(level)
        grades.append(None if grade is None else str(grade))
    return np.array(levels, dtype=np.int64), grades


def _level_distribution(
    path: Path, group: str, names: tuple[str, ...], columns: list[np.ndarray],
    levels_of_fit: np.ndarray, config: SynthConfig,
) -> LevelDistribution:
    where = f"/derived/fits/{group}"
    logs = np.log(np.stack(columns, axis=1))
    levels = np.array(config.levels.selected)
    outside = sorted(set(levels_of_fit.tolist()) - set(range(1, config.levels.n_levels + 1)))
    if outside:
        raise InputError(f"the fits have force_level {outside[0]}, outside "
                         f"1..{config.levels.n_levels} of the config; set levels.n_levels in "
                         "the synth config",
                         path=path, where=where)
    fit_levels, counts = np.unique(levels_of_fit, return_counts=True)
    means = np.array([logs[levels_of_fit == k].mean(axis=0) for k in fit_levels])
    usable = counts >= config.fits.min_fits_per_level
    if not usable.any():
        raise InputError(f"no force level has {config.fits.min_fits_per_level} converged fits; "
                         "lower fits.min_fits_per_level in the synth config",
                         path=path, where=where)
    log_mean = np.stack([np.interp(levels, fit_levels[usable], means[usable, j])
                         for j in range(len(names))], axis=1)
    n_fits = np.array([int(counts[fit_levels == k].sum()) if k in fit_levels[usable] else 0
                       for k in levels], dtype=np.int64)
    # pooled within-level covariance of the logs
    multi = fit_levels[counts >= 2]
    if multi.size == 0:
        raise InputError("no force level has two converged fits, so the spread within a level "
                         "cannot be estimated; fit more trials", path=path, where=where)
    resid = np.concatenate([logs[levels_of_fit == k] - means[fit_levels == k]
                            for k in multi])
    dof = len(resid) - len(multi)
    log_cov = resid.T @ resid / dof
    return LevelDistribution(names, levels, log_mean, log_cov, n_fits, where)


def from_fits(
    path: str | Path, config: SynthConfig
) -> tuple[LevelDistribution, LevelDistribution, dict[int, str]]:
    """Press and slip distributions from the converged fits in ``/derived/fits/fos_press``
    and ``fos_slip`` of a tactile file and its trials' ``force_level`` labels; plus the
    force grade of each level found in the trials' ``force_grade`` labels."""
    path = Path(path)
    press = read_fit_group(path, GROUP_NAMES["press"])
    slip = read_fit_group(path, GROUP_NAMES["slip"])
    with TactileFile(path) as f:
        duration_fitted = bool(f.derived("fits", GROUP_NAMES["press"], columns=[]).attrs.get(
            "duration_fitted", False))
        trial_labels = {region: _trial_labels(f, cols["trial"])
                        for region, cols in (("press", press), ("slip", slip))}
    grades: dict[int, str] = {}
    out = []
    for region, cols, names in (("press", press, PRESS_NAMES), ("slip", slip, SLIP_NAMES)):
        levels, trial_grades = trial_labels[region]
        for level, grade in zip(levels, trial_grades, strict=True):
            if grade is not None and grades.setdefault(int(level), grade) != grade:
                raise InputError(f"force_level {level} has two force_grade labels "
                                 f"({grades[int(level)]!r} and {grade!r})", path=path)
        keep = cols["status"] == "converged"
        if config.fits.exclude_second_order:
            keep &= ~np.isin(cols["order_verdict"], ("second_order", "relaxation"))
        params = [cols["alpha"], cols["tau_s"]]
        if region == "press" and duration_fitted:
            params.append(cols["duration_s"])
        else:
            names = names[:2]
        for p in params:
            keep &= np.isfinite(p) & (p > 0)
        if not keep.any():
            raise InputError(f"no converged {region} fit to draw parameters from",
                             path=path, where=f"/derived/fits/{GROUP_NAMES[region]}")
        out.append(_level_distribution(path, GROUP_NAMES[region], names,
                                       [p[keep] for p in params], levels[keep], config))
    return out[0], out[1], grades


__all__ = ["PRESS_NAMES", "SLIP_NAMES", "LevelDistribution", "from_config", "from_fits"]
