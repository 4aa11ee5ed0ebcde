"""``tactile fit-fos FILE...`` as one library verb: :func:`fit_files`.

It decides what the inputs are and fits them, all checks first:

- one tactile HDF5 file: the press (eq. 16) and slip (eq. 17) regions of every trial
  (:func:`~tactile_cli.fos.fit_file.fit_fos_file`), written into the file unless
  ``write=False``;
- one tactile HDF5 file with ``stream``: step responses of a sampled stream over annotated
  or found regions (:func:`~tactile_cli.fos.stream.read_stream_curves`), nothing written
  into the file;
- CSV curves (files or folders of them): fitted together with ``model``;
- several tactile HDF5 files (or ``scheduler``/``workers``): one task per file on Dask
  (:func:`~tactile_cli.fos.batch.fit_each`), each written into its own file.

Before any input is read, every output is checked: ``csv`` and ``plot`` may not be, hold or
lie inside an input (:func:`~tactile_cli.input_guard.check_outputs`), ``csv`` must be a
writable file name (an existing one only with ``overwrite``) and ``plot`` a folder that can
be made or added to. The table goes to ``csv`` and the figures to ``plot`` through the
store's atomic writers, so an error or interrupt leaves earlier outputs as they were.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

from ..errors import InputError
from ..input_guard import check_outputs
from ..progress import NullProgress, Progress

if TYPE_CHECKING:  # the fitting code (and jax) loads when a fit runs, not with the CLI
    from ..batch import FileBatchResult, FileCounts, FileItem
    from .fit import FitOptions
    from .protocol import RegionFits

KINDS: tuple[str, ...] = ("press", "slip", "both")
REGION_SOURCES: tuple[str, ...] = ("annotations", "detect", "auto")
CURVE_MODELS: tuple[str, ...] = ("pulse", "step", "ramp")
#: The equation each model fits, as tables and figures name it.
EQUATIONS = {"pulse": "eq. 16", "ramp": "eq. 17", "step": "eq. 16, T -> inf"}


@dataclass(frozen=True)
class RegionResult:
    """The fits of one region (``press``, ``slip``), of the CSV curves (``curve``) or of a
    stream's curves (named after the stream): ``records`` one JSON-ready row per trial or
    curve (:func:`~tactile_cli.fos.table.fit_records`), ``summary`` their counts and median
    R (:func:`~tactile_cli.fos.table.fit_summary`), ``group`` the HDF5 group written,
    ``no_step`` the curves of a stream in which no step was found (None unless a stream),
    ``not_fitted`` why each curve of a stream that was not fitted was left out
    (``trial/channel[/region]`` -> reason)."""

    region: str
    model: str
    records: list[dict[str, Any]]
    summary: dict[str, Any]
    group: str | None = None
    no_step: list[str] | None = None
    not_fitted: dict[str, str] | None = None

    def as_dict(self) -> dict[str, Any]:
        out = {"model": self.model, "group": self.group, "summary": self.summary,
               "fits": self.records}
        if self.no_step is not None:
            out["no_step"] = self.no_step
        if self.not_fitted is not None:
            out["not_fitted"] = self.not_fitted
        return out


@dataclass(frozen=True)
class FitFosResult:
    """What :func:`fit_files` did. ``input``: ``"hdf5"``, ``"stream"``, ``"csv"`` or
    ``"batch"`` (several files: ``batch`` holds each file's item, ``regions`` is empty);
    ``bin_s``: the count bins (s) of an HDF5 fit; ``config``: the settings recorded with the
    fits; ``csv``/``figures``: the table and the PNGs written."""

    input: str
    files: list[str]
    config: dict[str, Any]
    regions: dict[str, RegionResult] = field(default_factory=dict)
    bin_s: float | None = None
    csv: Path | None = None
    figures: list[Path] = field(default_factory=list)
    batch: FileBatchResult | None = None

    @property
    def ok(self) -> bool:
        """False when a file of a batch failed (a single fit raises instead)."""
        return self.batch is None or self.batch.ok

    def as_dict(self) -> dict[str, Any]:
        """The JSON of ``tactile fit-fos --json`` (a batch: its items, see
        :meth:`tactile_cli.batch.FileBatchResult.as_dict`)."""
        if self.batch is not None:
            return self.batch.as_dict()
        return {"file": self.files[0] if len(self.files) == 1 else None, "files": self.files,
                "input": self.input, "bin_s": self.bin_s, "config": self.config,
                "regions": {name: r.as_dict() for name, r in self.regions.items()},
                "csv": None if self.csv is None else str(self.csv),
                "figures": [str(p) for p in self.figures]}


def parse_p0(text: str | Mapping[str, float] | None) -> dict[str, float] | None:
    """``"alpha=2,tau=0.05"`` -> ``{"alpha": 2.0, "tau": 0.05}`` (a mapping is returned as
    a dict); one :class:`InputError` naming ``p0`` for a malformed text."""
    from .fit import P0_NAMES

    if text is None or isinstance(text, Mapping):
        return None if text is None else dict(text)
    out: dict[str, float] = {}
    for item in text.split(","):
        name, eq, value = (part.strip() for part in item.partition("="))
        if not eq or not name:
            raise InputError(f"`p0` {text!r}: expected name=value pairs separated by commas, "
                             "e.g. 'tau=0.05,T=0.3'")
        if name not in P0_NAMES:
            raise InputError(f"`p0` names {name!r}; the starting values are "
                             f"{', '.join(P0_NAMES)}")
        if name in out:
            raise InputError(f"`p0` gives {name} twice")
        try:
            out[name] = float(value)
        except ValueError:
            raise InputError(f"`p0` {name}={value!r} is not a number") from None
    return out


def fit_options(*, solver: str = "levenberg_marquardt", max_steps: int = 64,
                rtol: float | None = None, atol: float | None = None,
                p0: str | Mapping[str, float] | None = None) -> FitOptions:
    """:class:`FitOptions` from user values, every bad one an :class:`InputError` naming its
    argument (``rtol``, ``atol``: tolerances in (0, 1), default 1e-10; ``p0``: see
    :func:`parse_p0`)."""
    from .fit import FitOptions

    tols = {}
    for name, value in (("rtol", rtol), ("atol", atol)):
        if value is not None:
            if not (0 < value < 1):  # NaN fails too
                raise InputError(f"`{name}` {value:g} must be a tolerance in (0, 1), e.g. 1e-10")
            tols[name] = value
    try:
        return FitOptions(solver=solver, max_steps=max_steps, p0=parse_p0(p0), **tols)
    except ValueError as e:
        raise InputError(str(e).rstrip(".")) from None


def _choice(name: str, value: str | None, allowed: Sequence[str]) -> str | None:
    """``value`` as a plain string (an enum's value), refused unless one of ``allowed``."""
    if value is not None and value not in allowed:
        raise InputError(f"`{name}` (={value!r}) must be one of {', '.join(allowed)}")
    return None if value is None else str(value)


def _not_with(what: str, given: Mapping[str, Any], path: Path | None = None) -> None:
    """Refuse the first argument of ``given`` that is set: it does not apply ``what``."""
    for name, value in given.items():
        if value is not None:
            raise InputError(f"`{name}` {what}", path=path)


@dataclass(frozen=True)
class _Request:
    """The arguments of one :func:`fit_files` call, checked."""

    files: list[Path]
    kind: str | None
    regions: str | None
    bin_s: float | None
    model: str | None
    units: str | None
    press_duration_s: float | None
    options: FitOptions
    order: bool
    csv: Path | None
    plot: Path | None
    overwrite: bool
    write: bool
    stream: str | None
    channels: str | None
    reduce: str
    region_label: str | None
    min_snr: float | None
    max_curves: int | None = None

    @property
    def wanted(self) -> list[str]:
        return ["press", "slip"] if (self.kind or "both") == "both" else [self.kind]

    def config(self) -> dict[str, Any]:
        """The settings recorded on the fit groups (``config_json``; a batch skips a file
        fitted with the same ones)."""
        opts = self.options
        default_regions = "annotations" if self.stream is not None else "auto"
        bin_ms = None if self.bin_s is None else float(f"{self.bin_s * 1e3:.12g}")
        return {"kind": self.kind or "both", "regions": self.regions or default_regions,
                "model": self.model, "min_snr": self.min_snr, "bin_ms": bin_ms,
                "press_duration_s": self.press_duration_s, "solver": opts.solver,
                "max_steps": opts.max_steps, "rtol": opts.rtol, "atol": opts.atol,
                "p0": None if opts.p0 is None else dict(opts.p0), "order": self.order,
                "criterion": "bic", "units": self.units, "stream": self.stream,
                "channels": self.channels, "reduce": self.reduce,
                "region_label": self.region_label}


def _check_outputs(req: _Request) -> None:
    """Every output checked before any input is read (see the module docstring)."""
    from ..store.atomic import check_output_file
    from ..store.outdir import check_output_folder

    for file in req.files:
        if not (file.is_file() or file.is_dir()):
            raise InputError("file not found", path=file)
    check_outputs({"csv": req.csv, "plot": req.plot},
                  [f for f in req.files if not f.is_dir()],
                  trees=[f for f in req.files if f.is_dir()])
    if req.plot is not None:  # figures are added to an existing folder; a file there is not
        check_output_folder(req.plot, merge=True)
    if req.csv is not None:
        check_output_file(req.csv, overwrite=req.overwrite)


def _input_kind(req: _Request, *, batch: bool) -> str:
    """``"stream"``, ``"batch"``, ``"hdf5"`` or ``"csv"``; arguments that do not apply to
    the inputs are refused."""
    from ..store.trials import is_hdf5

    first = req.files[0]
    hdf5 = [f for f in req.files if f.is_file() and is_hdf5(f)]
    if req.stream is None:
        _not_with("applies with `stream` (a sampled stream of an HDF5 file)",
                  {"channels": req.channels, "region_label": req.region_label,
                   "reduce": None if req.reduce == "none" else req.reduce,
                   "min_snr": req.min_snr, "max_curves": req.max_curves})
    else:
        if not hdf5 or len(req.files) > 1:
            raise InputError("`stream` fits a sampled stream of one tactile HDF5 file",
                             path=first)
        _not_with("does not apply with `stream`: the stream's regions are fitted with "
                  "`model`, in the stream's units",
                  {"kind": req.kind, "bin_s": req.bin_s, "units": req.units}, first)
        if req.press_duration_s is not None and req.model != "pulse":
            raise InputError("`press_duration_s` applies with `model='pulse'`", path=first)
        return "stream"
    if hdf5 and (len(req.files) > 1 or batch):
        # an unreadable file among tactile files is one of them: its task says why; one
        # file with `scheduler`/`workers` (a glob that matched one) is a batch of one
        curves = [f for f in req.files if f.is_dir() or f.suffix.lower() == ".csv"]
        if curves:
            raise InputError("several inputs must all be tactile HDF5 files (fitted one "
                             "task per file) or all CSV curves (fitted together)",
                             path=curves[0])
        _not_with("goes with one HDF5 file; several files are fitted one task per file, "
                  "each written into its file",
                  {"model": req.model, "units": req.units, "csv": req.csv, "plot": req.plot,
                   "write": None if req.write else False}, first)
        return "batch"
    if batch:
        raise InputError("`scheduler` and `workers` go with tactile HDF5 files (one task "
                         "per file)", path=first)
    if hdf5:
        _not_with("applies to CSV curves; an HDF5 file's press regions are fitted with the "
                  "pulse (eq. 16), slips with the ramp (eq. 17), in events per bin",
                  {"model": req.model, "units": req.units}, hdf5[0])
        return "hdf5"
    _not_with("applies to HDF5 files; a CSV is one curve fitted with `model`",
              {"kind": req.kind, "regions": req.regions, "bin_s": req.bin_s}, first)
    if req.model is None:
        raise InputError("a CSV curve needs `model` pulse, step or ramp", path=first)
    return "csv"


def _fit_h5(req: _Request, progress: Progress) -> tuple[dict[str, RegionFits], dict, float,
                                                         list[dict[str, Any]] | None]:
    from .compile_cache import enable_compilation_cache
    from .fit_file import fit_fos_file
    from .table import fit_records, fit_summary

    enable_compilation_cache()
    progress.start(1, "fitting (the first run compiles the solvers)")
    result = fit_fos_file(
        req.files[0], regions=req.wanted, region_source=req.regions or "auto",
        bin_s=req.bin_s, press_duration_s=req.press_duration_s, order=req.order,
        options=req.options, write=req.write, overwrite=req.overwrite, config=req.config())
    progress.finish()
    fits, regions = {}, {}
    for r in req.wanted:
        fits[r] = result.fits[r]
        recs = fit_records(fits[r], result.labels)
        regions[r] = RegionResult(r, fits[r].model, recs, fit_summary(recs),
                                  result.written.get(r))
    return fits, regions, result.bin_s, result.labels


def _fit_csv(req: _Request, progress: Progress) -> tuple[RegionFits, RegionResult, list[str]]:
    from .compile_cache import enable_compilation_cache
    from .curve_csv import csv_inputs, read_curves
    from .protocol import DEFAULT_UNITS, fit_curves
    from .table import fit_records, fit_summary

    curves, where = [], {}
    for p in csv_inputs(req.files):
        for c in read_curves(p):
            if c.name in where:
                raise InputError(f"two curves are named {c.name!r} ({where[c.name]} and this "
                                 "file); rows and figures are named after the file (and "
                                 "column), so rename one", path=p)
            where[c.name] = p
            curves.append(c)
    enable_compilation_cache()
    progress.start(1, "fitting (the first run compiles the solver)")
    rf = fit_curves([(c.t_s, c.x) for c in curves], model=req.model,
                    names=[c.name for c in curves],
                    units=[req.units or c.units or DEFAULT_UNITS for c in curves],
                    press_duration_s=req.press_duration_s, order=req.order,
                    options=req.options)
    progress.finish()
    records = fit_records(rf)
    return rf, RegionResult("curve", rf.model, records, fit_summary(records)), \
        [c.quantity for c in curves]


def _fit_stream(req: _Request, progress: Progress) -> tuple[RegionFits, RegionResult]:
    from .compile_cache import enable_compilation_cache
    from .protocol import fit_curves
    from .stream import read_stream_curves
    from .table import fit_records, fit_summary

    model = req.model or "step"
    found = read_stream_curves(
        req.files[0], req.stream, channels=req.channels, reduce=req.reduce,
        region_label=req.region_label, regions=req.regions or "annotations", model=model,
        **({} if req.min_snr is None else {"min_snr": req.min_snr}),
        **({} if req.max_curves is None else {"max_curves": req.max_curves}))
    curves = found.curves
    enable_compilation_cache()
    progress.start(1, "fitting (the first run compiles the solver)")
    rf = fit_curves([(c.t_s, c.x) for c in curves], model=model,
                    names=[c.name for c in curves], units=[c.units for c in curves],
                    press_duration_s=req.press_duration_s, order=req.order,
                    options=req.options)
    progress.finish()
    records = fit_records(rf)
    for c, rec in zip(curves, records, strict=True):
        rec.update({"trial": c.trial, "channel": c.channel, "region": c.region,
                    "stream": req.stream, "baseline": c.baseline,
                    "region_start_s": c.start_s, "region_end_s": c.end_s})
    return rf, RegionResult(req.stream, rf.model, records, fit_summary(records),
                            no_step=found.no_step, not_fitted=found.not_fitted)


def _plot(req: _Request, fits: Mapping[str, RegionFits], *, labels: Any,
          quantities: list[str] | None) -> list[Path]:
    """The figures of every region into ``req.plot`` (built aside, then merged in)."""
    from ..store.outdir import output_folder
    from .plots import plot_curve_fits, plot_region_fits

    figures: list[Path] = []
    with output_folder(req.plot, merge=True) as tmp:  # in place when every page is
        for rf in fits.values():
            if quantities is not None:
                pages = plot_curve_fits(rf, tmp, quantities=quantities)
            else:
                pages = plot_region_fits(rf, tmp, labels=labels)
            figures += [req.plot / p.name for p in pages]
    return figures


def fit_files(
    files: Sequence[str | Path],
    *,
    kind: str | None = None,
    regions: str | None = None,
    bin_s: float | None = None,
    model: str | None = None,
    units: str | None = None,
    press_duration_s: float | None = None,
    solver: str = "levenberg_marquardt",
    max_steps: int = 64,
    rtol: float | None = None,
    atol: float | None = None,
    p0: str | Mapping[str, float] | None = None,
    order: bool = True,
    csv: str | Path | None = None,
    plot: str | Path | None = None,
    overwrite: bool = False,
    write: bool = True,
    stream: str | None = None,
    channels: str | None = None,
    reduce: str = "none",
    region_label: str | None = None,
    min_snr: float | None = None,
    max_curves: int | None = None,
    scheduler: str | None = None,
    workers: int | None = None,
    records: bool = False,
    progress: Progress | None = None,
    on_plan: Callable[[list[FileItem]], None] | None = None,
    on_progress: Callable[[FileCounts], None] | None = None,
    on_item: Callable[[FileItem], None] | None = None,
) -> FitFosResult:
    """Fit ``files`` (see the module docstring for what each kind of input gets).

    ``kind``: press, slip or both (default) regions of HDF5 files; ``regions``: where they
    come from (``annotations``, ``detect``, ``auto``; default auto, with ``stream``
    annotations); ``bin_s``: count bins (s); ``model``: pulse, step or ramp for CSV curves
    and streams (streams default to step); ``units``: the CSV curves' unit;
    ``press_duration_s``: a known pulse length T (s). ``solver``, ``max_steps``, ``rtol``,
    ``atol``, ``p0``: see :func:`fit_options`; ``order``: test the second-order
    alternative. ``csv``: also write the table there; ``plot``: a folder for the figures;
    ``overwrite``: replace existing fit groups and ``csv``; ``write=False``: leave the HDF5
    file alone. ``stream``, ``channels``, ``reduce``, ``region_label``, ``min_snr``,
    ``max_curves``: see
    :func:`~tactile_cli.fos.stream.read_stream_curves`. ``scheduler``, ``workers``,
    ``records`` and the ``on_*`` callbacks: see :func:`~tactile_cli.fos.batch.fit_each`.
    Raises :class:`InputError` before any work for a bad argument or output.
    """
    from ..threads import check_threads

    kind = _choice("kind", kind, KINDS)
    regions = _choice("regions", regions, REGION_SOURCES)
    model = _choice("model", model, CURVE_MODELS)
    reduce = _choice("reduce", reduce, ("none", "mean")) or "none"
    solver = _choice("solver", solver, ("levenberg_marquardt", "gauss_newton")) or solver
    if not files:
        raise InputError("no input files given")
    for name, value in (("bin_s", bin_s), ("press_duration_s", press_duration_s),
                        ("min_snr", min_snr)):
        if value is not None and not value > 0:
            raise InputError(f"`{name}` (={value:g}) must be positive")
    if bin_s is not None:
        from ..events.accumulate import MAX_BIN_S

        if bin_s > MAX_BIN_S:
            raise InputError(f"`bin_s` (={bin_s:g}) must be at most a day ({MAX_BIN_S:g} s)")
    if workers:
        check_threads(workers, "workers")
    req = _Request([Path(f) for f in files], kind, regions, bin_s, model, units,
                   press_duration_s, fit_options(solver=solver, max_steps=max_steps,
                                                 rtol=rtol, atol=atol, p0=p0),
                   order, None if csv is None else Path(csv),
                   None if plot is None else Path(plot), overwrite, write, stream, channels,
                   reduce, region_label, min_snr, max_curves)
    _check_outputs(req)
    how = _input_kind(req, batch=scheduler is not None or workers is not None)
    progress = progress or NullProgress()
    files_given = [str(f) for f in req.files]
    if how == "batch":
        from .batch import fit_each

        done = fit_each(req.files, regions=req.wanted, region_source=regions or "auto",
                        bin_s=bin_s, press_duration_s=press_duration_s, order=order,
                        options=req.options, overwrite=overwrite, config=req.config(),
                        records=records, scheduler=scheduler, workers=workers,
                        on_plan=on_plan, on_progress=on_progress, on_item=on_item)
        return FitFosResult("batch", files_given, req.config(), batch=done)
    labels = quantities = None
    bin_width = None
    if how == "hdf5":
        fits, results, bin_width, labels = _fit_h5(req, progress)
    elif how == "csv":
        from .curve_csv import csv_inputs

        rf, result, quantities = _fit_csv(req, progress)
        files_given = [str(p) for p in csv_inputs(req.files)]
        fits, results = {"curve": rf}, {"curve": result}
    else:
        rf, result = _fit_stream(req, progress)
        quantities = [stream] * len(rf)
        fits, results = {stream: rf}, {stream: result}
    figures = [] if req.plot is None else _plot(req, fits, labels=labels,
                                                quantities=quantities)
    if req.csv is not None:
        from .table import write_csv

        write_csv(req.csv, [rec for r in results.values() for rec in r.records],
                  overwrite=overwrite)
    return FitFosResult(how, files_given, req.config(), results, bin_width, req.csv, figures)


__all__ = ["CURVE_MODELS", "EQUATIONS", "KINDS", "REGION_SOURCES", "FitFosResult",
           "RegionResult", "fit_files", "fit_options", "parse_p0"]
