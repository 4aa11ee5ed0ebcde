"""FOS fit results as a table: columns, JSON records, CSV, and the HDF5 fits group.

The layout of ``/derived/fits/fos_press`` and ``/derived/fits/fos_slip`` (written by
``tactile fit-fos``, read by ``tactile synth``): one 1-D dataset per column of
:data:`COLUMNS`, one row per trial, in the file's trial order. Units: ``alpha`` and
``alpha_se`` in events per bin; ``tau_s``, ``tau_se``, ``duration_s``, ``duration_se``,
``region_start_s``, ``region_end_s`` in seconds (region bounds from the trial's time
origin); ``residual_std`` in events per bin and ``rss`` (the residual sum of squares) in
(events per bin)^2; ``delta_bic`` = BIC(first order) - BIC(second
order), > 0 favouring the second. Parameters of fits that did not converge are NaN and
their ``status`` says why. Group attributes: ``region``, ``model``, ``bin_s``,
``duration_fitted``, ``criterion``, ``units_json``, besides the provenance attributes every
derived group carries.
"""

from __future__ import annotations

import csv
import json
import math
from collections import Counter
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from ..errors import InputError
from ..store.atomic import atomic_file
from ..store.trials import TactileFile
from ..store.update import write_columns

if TYPE_CHECKING:  # the fitting code (and jax) is not needed to read a fits group
    from ..store.update import DerivedGroup
    from .protocol import RegionFits

#: Columns of a fits group, in order.
COLUMNS: tuple[str, ...] = (
    "trial", "alpha", "alpha_se", "tau_s", "tau_se", "duration_s", "duration_se",
    "residual_std", "rss", "pearson_r", "aic", "bic", "status", "n_steps", "n_points",
    "region_start_s", "region_end_s", "order_verdict", "delta_bic",
)
STRING_COLUMNS = frozenset({"trial", "status", "order_verdict"})
INT_COLUMNS = frozenset({"n_steps", "n_points"})
UNITS = {
    "alpha": "events/bin", "alpha_se": "events/bin", "tau_s": "s", "tau_se": "s",
    "duration_s": "s", "duration_se": "s", "residual_std": "events/bin",
    "rss": "(events/bin)^2", "region_start_s": "s", "region_end_s": "s",
}
#: Columns that groups written before they existed lack; :func:`read_fit_group` derives them.
_DERIVED_ON_READ = frozenset({"rss"})
#: Group names of the two regions under /derived/fits.
GROUP_NAMES = {"press": "fos_press", "slip": "fos_slip"}


def fit_columns(rf: RegionFits) -> dict[str, np.ndarray]:
    """The :data:`COLUMNS` of one region's fits, (n_trials,) each."""
    f = rf.fit
    return {
        "trial": np.array(rf.trials, dtype=object),
        "alpha": f.alpha, "alpha_se": f.alpha_se, "tau_s": f.tau_s, "tau_se": f.tau_se_s,
        "duration_s": f.duration_s, "duration_se": f.duration_se_s,
        "residual_std": f.residual_std, "rss": f.rss, "pearson_r": f.pearson_r, "aic": f.aic,
        "bic": f.bic,
        "status": np.array(rf.status, dtype=object),
        "n_steps": np.asarray(f.n_steps, dtype=np.int64),
        "n_points": np.asarray(f.n_points, dtype=np.int64),
        "region_start_s": np.asarray(rf.start_s, dtype=np.float64),
        "region_end_s": np.asarray(rf.end_s, dtype=np.float64),
        "order_verdict": np.array(rf.verdict, dtype=object),
        "delta_bic": np.asarray(rf.delta_bic, dtype=np.float64),
    }


def _json_value(v: Any) -> Any:
    v = v.item() if isinstance(v, np.generic) else v
    return None if isinstance(v, float) and not math.isfinite(v) else v


def fit_records(
    rf: RegionFits, labels: Sequence[Mapping[str, Any]] | None = None
) -> list[dict[str, Any]]:
    """One JSON-ready dict per trial: region, model, ``force_level``/``force_grade`` when the
    labels have them, the :data:`COLUMNS`, the unit of alpha and of the response
    (``units``) and the status message (NaN becomes None)."""
    cols = fit_columns(rf)
    out = []
    for i in range(len(rf)):
        row: dict[str, Any] = {"region": rf.region, "model": rf.model, "units": rf.unit(i)}
        lab = labels[i] if labels is not None else {}
        for key in ("force_level", "force_grade"):
            if key in lab:
                row[key] = _json_value(lab[key])
        row.update({k: _json_value(cols[k][i]) for k in COLUMNS})
        for key, values in (rf.relaxation or {}).items():
            row[key] = _json_value(values[i])
        row["status_message"] = rf.message(i)
        out.append(row)
    return out


def write_csv(path: str | Path, records: Sequence[Mapping[str, Any]], *,
              overwrite: bool = False) -> Path:
    """Write records (from :func:`fit_records`) as a CSV with a header; empty cells for None.
    Written through the store's atomic writer (an existing ``path`` only with
    ``overwrite``, replaced when the table is complete)."""
    keys: list[str] = []
    for rec in records:
        keys.extend(k for k in rec if k not in keys)
    with atomic_file(path, overwrite=overwrite) as tmp, \
            open(tmp, "w", newline="", encoding="utf-8") as f:
        writer = csv.DictWriter(f, fieldnames=keys, restval="")
        writer.writeheader()
        for rec in records:
            writer.writerow({k: "" if v is None else v for k, v in rec.items()})
    return Path(path)


def fit_summary(records: Sequence[Mapping[str, Any]]) -> dict[str, Any]:
    """Counts of a region's fits (from :func:`fit_records`): ``n_trials``, ``n_converged``,
    ``n_failed``, the median and lowest Pearson R of the converged ones (None when there
    is none), and how many rows have each status and each order verdict."""
    ok = [r for r in records if r["status"] == "converged"]
    r_values = [r["pearson_r"] for r in ok if r["pearson_r"] is not None]
    return {
        "n_trials": len(records),
        "n_converged": len(ok),
        "n_failed": len(records) - len(ok),
        "median_pearson_r": float(np.median(r_values)) if r_values else None,
        "min_pearson_r": float(np.min(r_values)) if r_values else None,
        "status_counts": dict(Counter(r["status"] for r in records)),
        "verdict_counts": dict(Counter(r["order_verdict"] for r in records)),
    }


def write_fit_group(group: DerivedGroup, rf: RegionFits, *, bin_s: float | None) -> None:
    """Write one region's fits into ``group`` (an empty group of a writable file, from
    :meth:`tactile_cli.store.update.DerivedUpdate.group`)."""
    attrs: dict[str, Any] = {
        "region": rf.region,
        "model": rf.model,
        "duration_fitted": bool(rf.fit.duration_fitted),
        "criterion": "bic",
        "units_json": json.dumps(UNITS, sort_keys=True),
    }
    if bin_s is not None:
        attrs["bin_s"] = float(bin_s)
    write_columns(group, fit_columns(rf), strings=STRING_COLUMNS, attrs=attrs)


def read_fit_group(source: str | Path | TactileFile, name: str) -> dict[str, np.ndarray]:
    """The columns of ``/derived/fits/{name}`` of a tactile file (a path, or an open
    :class:`~tactile_cli.store.trials.TactileFile`), strings decoded.

    Raises :class:`InputError` naming the file and the HDF5 path when the group or one of
    its columns is missing, with the command that writes it.
    """
    if not isinstance(source, TactileFile):
        with TactileFile(source) as tf:
            return read_fit_group(tf, name)
    path = source.path
    if not source.has_derived("fits", name):
        raise InputError(f"no /derived/fits/{name}; write it with `tactile fit-fos {path}`",
                         path=path)
    group = source.derived("fits", name, strings=STRING_COLUMNS)
    missing = [c for c in COLUMNS if c not in group.columns and c not in _DERIVED_ON_READ]
    if missing:
        raise InputError(f"column {missing[0]!r} is missing; re-run `tactile fit-fos "
                         f"{path} --overwrite`", path=path, where=group.where)
    out = {c: group.columns[c] for c in COLUMNS if c in group.columns}
    if "rss" not in out:  # written before rss was stored: s^2 (n - p)
        n_params = 3 if bool(group.attrs.get("duration_fitted", False)) else 2
        dof = np.asarray(out["n_points"], dtype=np.float64) - n_params
        out["rss"] = np.asarray(out["residual_std"], dtype=np.float64) ** 2 * dof
    return {c: out[c] for c in COLUMNS}


__all__ = ["COLUMNS", "GROUP_NAMES", "UNITS", "fit_columns", "fit_records", "fit_summary",
           "read_fit_group", "write_csv", "write_fit_group"]
