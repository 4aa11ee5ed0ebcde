"""Fit every trial of a tactile file and store the results in it: the core of ``tactile fit-fos``.

:func:`fit_fos_file` reads the net counts and regions of each trial
(:mod:`tactile_cli.fos.regions`), fits them by the protocol of
:mod:`tactile_cli.fos.protocol`, and writes ``/derived/fits/fos_press`` and/or
``fos_slip`` (layout: :mod:`tactile_cli.fos.table`) through
:class:`tactile_cli.store.update.DerivedUpdate`: a validated copy renamed over the file, so
the file is never half-written. The targets are checked before anything is fitted, so a
refused write fails fast.
"""

from __future__ import annotations

from collections import Counter
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from ..errors import InputError
from ..store.trials import TactileFile
from ..store.update import DerivedUpdate, check_derived_targets
from .fit import FitOptions
from .protocol import RegionFits, fit_regions
from .regions import RegionsMode, TrialRegions, read_trial_regions
from .table import GROUP_NAMES, write_fit_group


@dataclass(frozen=True)
class FileFits:
    """The fits of one file: per region (``"press"``, ``"slip"``) a :class:`RegionFits`;
    the trials they came from; the HDF5 groups written (empty with ``write=False``)."""

    path: Path
    bin_s: float
    trials: list[TrialRegions]
    fits: dict[str, RegionFits]
    written: dict[str, str] = field(default_factory=dict)

    @property
    def labels(self) -> list[dict[str, Any]]:
        return [t.labels for t in self.trials]


def fit_fos_file(
    path: str | Path,
    *,
    regions: Sequence[str] = ("press", "slip"),
    region_source: RegionsMode = "auto",
    bin_s: float | None = None,
    press_duration_s: float | None = None,
    order: bool = True,
    options: FitOptions | None = None,
    write: bool = True,
    overwrite: bool = False,
    config: Mapping[str, Any] | None = None,
    command: str | None = None,
) -> FileFits:
    """Fit the ``regions`` of every trial of ``path`` and (with ``write``) store them.

    ``region_source``, ``bin_s``: see :func:`tactile_cli.fos.regions.read_trial_regions`;
    ``press_duration_s``, ``order``, ``options``: see
    :func:`tactile_cli.fos.protocol.fit_regions`. ``config`` and ``command`` are recorded on
    the groups written (``config_json``, ``command``; the command defaults to this
    process's command line). An existing group without ``overwrite`` raises
    :class:`InputError` before any fitting.
    """
    path = Path(path)
    targets = [("fits", GROUP_NAMES[r]) for r in regions if r in GROUP_NAMES]
    if write:
        check_derived_targets(path, targets, overwrite=overwrite)
    with TactileFile(path) as tf:  # read once, closed before the update copies the file
        trials = read_trial_regions(tf, bin_s=bin_s, regions=region_source)
    widths = sorted({tr.bin_s for tr in trials})
    if len(widths) > 1:
        raise InputError(f"the trials' count streams have different bin widths "
                         f"({', '.join(f'{w * 1e3:g} ms' for w in widths)}); alpha in events "
                         "per bin would not compare", path=path)
    fits = fit_regions(trials, regions=regions, press_duration_s=press_duration_s, order=order,
                       options=options)
    written: dict[str, str] = {}
    if write:
        inputs = {
            "file": str(path), "n_trials": len(trials),
            "counts_from": dict(Counter(tr.counts_from for tr in trials)),
            "regions_from": dict(Counter(tr.regions_from for tr in trials)),
        }
        with DerivedUpdate(path, targets, command=command, config=config, inputs=inputs,
                           overwrite=overwrite) as update:
            for region in regions:
                write_fit_group(update.group("fits", GROUP_NAMES[region]), fits[region],
                                bin_s=widths[0])
            update.commit()
        written = {r: f"/derived/fits/{GROUP_NAMES[r]}" for r in regions}
    return FileFits(path=path, bin_s=widths[0], trials=trials, fits=fits, written=written)


__all__ = ["FileFits", "fit_fos_file"]
