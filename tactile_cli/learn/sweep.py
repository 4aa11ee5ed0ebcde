"""``tactile sweep``: a grid of model x window x channel set, each trained and evaluated.

Issue 14, item 4 (paper 001, Fig. 8 and the speed-versus-accuracy comparison). A sweep
file (``configs/sweep_vibro.yaml`` documents every key)::

    version: 1
    name: vibro
    train_data: [prepared0.h5]            # relative to the current folder
    eval: {data: [prepared1.h5], split: test}
    models:
      cnn2d:
        config: configs/train_cnn2d_vibro.yaml
        by_window: {400: {model.n_fft: 40, model.hop: 20}, 50: {model.n_fft: 10, model.hop: 5}}
      fnn: {config: configs/train_fnn_vibro.yaml, overrides: {model.hidden: [256, 128]}}
    windows: [{window: 400, stride: 200}, {window: 50, stride: 25}]
    channel_sets: {L3R3: [L_x, L_y, L_z, R_x, R_y, R_z], Lx: [L_x]}
    overrides: {optim.epochs: 10}         # dotted keys of the training configs
    targets: {motion: 0.948, speed_cm_s: 3.4}   # accuracy (fraction) at least, MAE at most
    score_head: motion                    # the accuracy of the speed-accuracy chart
    margin_pp: 0.5                        # without targets: compare's margin rule

Each run's training config is the model's config file with, in this order, the sweep's
``overrides``, the model's ``overrides``, its ``by_window`` entry for the window, and the
window, stride and channels applied to the raw YAML mapping, then validated as
``tactile train`` validates it (a bad key is one error naming the sweep file and the run,
before any work). A model with ``by_window`` has no run for a window it does not list: that
run is ``n/a`` (paper 001 has no spectrogram CNN for windows of 25 and 10 samples).

The runs (:func:`run_one`: :func:`~.train.train` then :func:`~.evaluate.evaluate` on the
eval data and split) execute on Dask through :mod:`tactile_cli.batch`; each writes
``OUT/runs/<model>-w<window>-<set>/`` atomically. A run is finished when its folder holds
run.json, the evaluation of the sweep's eval data and the same resolved config and
training data (SHA-256); a restarted sweep skips finished runs and runs the others again. A
run that fails is a ``failed`` row with its one-line error; the others go on.

Outputs in ``OUT/``: ``sweep.json`` (the plan and its provenance: command, tool version,
the sweep file, model configs and data with SHA-256), ``table.csv``, ``table.md``,
``sweep_results.json`` (the table, the Pareto front and the pick), ``accuracy_vs_window.png``
(Fig. 8: accuracy against window size, a line per channel set, a panel per model and
classification head; MAE panels for regression heads) and ``speed_accuracy.png`` (score
against batch-1 latency, a marker per model, the Pareto front). The pick is the run with
the fewest parameters among those meeting every target (or, without targets, within
``margin_pp`` of the best score), ties by latency: the rule of :mod:`.compare`.
"""

from __future__ import annotations

import csv
import io
import math
import os
import platform
import re
import time
from collections.abc import Callable, Sequence
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any, Literal

import numpy as np
from pydantic import BaseModel, ConfigDict, Field, field_validator, model_validator

from .._version import __version__
from ..config_file import load_yaml_model, read_yaml
from ..errors import InputError
from ..input_guard import check_outputs
from ..store.atomic import (
    remove_stale_temporaries,
    swap_into_place,
    write_bytes,
    write_error,
    write_text,
)
from ..store.outdir import check_output_folder
from ..store.provenance import current_command, sha256_of, utc_now
from ..threads import check_threads
from ..vocabulary import CHANNEL_SETS
from . import runs
from .compare import meets_targets, pareto_front, pick_needed, within_margin
from .config import parse_config
from .data import data_files

SWEEP_FORMAT = "tactile-sweep"
SWEEP_RESULTS_FORMAT = "tactile-sweep-results"
SWEEP_FORMAT_VERSION = 1

SWEEP_JSON = "sweep.json"
TABLE_CSV = "table.csv"
TABLE_MD = "table.md"
RESULTS_JSON = "sweep_results.json"
FIG_WINDOWS = "accuracy_vs_window.png"
FIG_SPEED = "speed_accuracy.png"
RUNS_DIR = "runs"

#: Bounds of a sweep file (far above real use; a typo is an error, not a week of work).
MAX_MODELS = 50
MAX_WINDOWS = 100
MAX_CHANNEL_SETS = 100
MAX_RUNS = 5000
MAX_OVERRIDES = 200
_NAME = re.compile(r"^[A-Za-z0-9][A-Za-z0-9_.+]{0,47}$")


# -- the sweep file ---------------------------------------------------------------------------
class _Model(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True, allow_inf_nan=False)


def _check_overrides(value: dict[str, Any]) -> dict[str, Any]:
    for key in value:
        if not key or any(not part for part in key.split(".")):
            raise ValueError(f"override key {key!r} must be dotted names (optim.epochs)")
        if key.split(".")[0] in ("version",):
            raise ValueError(f"override key {key!r}: the config version cannot be overridden")
    return value


_Overrides = dict[str, Any]


class ModelSpec(_Model):
    """One model of the grid: a training config and what changes per window."""

    config: str = Field(min_length=1)
    """The training config (YAML), relative to the current folder."""
    overrides: _Overrides = Field(default={}, max_length=MAX_OVERRIDES)
    by_window: dict[int, _Overrides] | None = Field(default=None, max_length=MAX_WINDOWS)
    """Overrides per window (``model.n_fft`` of the spectrogram CNN); when given, a window
    it does not list has no run of this model (``n/a``)."""

    _ov = field_validator("overrides")(_check_overrides)

    @field_validator("by_window")
    @classmethod
    def _by_window(cls, value: dict[int, _Overrides] | None) -> dict[int, _Overrides] | None:
        for ov in (value or {}).values():
            if len(ov) > MAX_OVERRIDES:
                raise ValueError(f"at most {MAX_OVERRIDES} overrides per window")
            _check_overrides(ov)
        return value


class WindowSpec(_Model):
    window: int = Field(ge=1, le=10_000_000)
    """Samples per window."""
    stride: int = Field(ge=1, le=10_000_000)
    """Samples between window ends (window - overlap)."""


class EvalSpec(_Model):
    data: list[str] = Field(default=[], max_length=1000)
    """Evaluation files (default: the training files, whose held-out test trials then
    make the score)."""
    split: Literal["all", "test"] = "test"


class SweepConfig(_Model):
    """A whole sweep file (see the module docstring)."""

    version: Literal[1] = 1
    name: str = Field(default="sweep", pattern=_NAME.pattern)
    train_data: list[str] = Field(default=[], max_length=1000)
    eval: EvalSpec = EvalSpec()
    models: dict[str, ModelSpec] = Field(min_length=1, max_length=MAX_MODELS)
    windows: list[WindowSpec] = Field(min_length=1, max_length=MAX_WINDOWS)
    channel_sets: dict[str, list[str]] = Field(min_length=1, max_length=MAX_CHANNEL_SETS)
    """Name -> channels; a list of names of paper 001's accelerometer configurations
    (``[L3R3, Lx]``, :data:`tactile_cli.vocabulary.CHANNEL_SETS`) stands for those sets."""

    @field_validator("channel_sets", mode="before")
    @classmethod
    def _named_sets(cls, value: Any) -> Any:
        if isinstance(value, list) and all(isinstance(v, str) for v in value):
            unknown = [v for v in value if v not in CHANNEL_SETS]
            if unknown:
                raise ValueError(f"unknown channel configuration(s) {', '.join(unknown)}: "
                                 f"name some of {', '.join(CHANNEL_SETS)} or give a mapping "
                                 "name -> channel list")
            return {v: list(CHANNEL_SETS[v]) for v in value}
        return value
    overrides: _Overrides = Field(default={}, max_length=MAX_OVERRIDES)
    targets: dict[str, float] = Field(default={}, max_length=100)
    """Head -> the accuracy (fraction, at least) or MAE (label units, at most) a run must
    reach to be picked."""
    score_head: str | None = None
    """Classification head whose accuracy the speed-accuracy chart and the margin rule
    use (default: the first classification head of the first model)."""
    margin_pp: float = Field(default=0.5, ge=0, le=100)

    _ov = field_validator("overrides")(_check_overrides)

    @model_validator(mode="after")
    def _check(self) -> SweepConfig:
        for kind, names in (("models", self.models), ("channel_sets", self.channel_sets)):
            for name in names:
                if not _NAME.match(name):
                    raise ValueError(f"{kind} name {name!r} must be letters, digits, _ . + "
                                     "(it names the run folders)")
        for name, chans in self.channel_sets.items():
            if not 1 <= len(chans) <= 1000 or len(set(chans)) != len(chans):
                raise ValueError(f"channel set {name!r} must list 1 to 1000 distinct channels")
        windows = [w.window for w in self.windows]
        if len(set(windows)) != len(windows):
            raise ValueError(f"windows repeat: {windows}")
        n = len(self.models) * len(self.windows) * len(self.channel_sets)
        if n > MAX_RUNS:
            raise ValueError(f"the grid has {n} runs (at most {MAX_RUNS})")
        return self


def load_sweep(path: str | Path) -> SweepConfig:
    """Read and validate a sweep file; any problem is one InputError naming the file, the
    line and the key."""
    hint = ("a sweep file is a YAML mapping with keys models, windows, channel_sets (see "
            "configs/sweep_vibro.yaml)")
    return load_yaml_model(path, SweepConfig, not_a_mapping=hint, empty=hint,
                           what="sweep file")


# -- the grid ---------------------------------------------------------------------------------
@dataclass
class PlannedRun:
    """One cell of the grid. ``status``: ``todo``, ``finished`` (a complete folder from
    before) or ``n/a`` (``reason`` says why); ``config``: the validated training config as
    a JSON mapping (None for n/a)."""

    name: str
    model: str
    family: str
    window: int
    stride: int
    channel_set: str
    channels: list[str]
    config_file: str
    status: str = "todo"
    reason: str | None = None
    config: dict[str, Any] | None = None

    def as_dict(self) -> dict[str, Any]:
        return asdict(self)


def run_name(model: str, window: int, channel_set: str) -> str:
    """The folder of a run: ``cnn2d-w400-L3R3``."""
    return f"{model}-w{window}-{channel_set}"


def apply_overrides(raw: dict[str, Any], overrides: dict[str, Any], *, where: str
                    ) -> dict[str, Any]:
    """``raw`` (a parsed training config, changed in place and returned) with each dotted
    key set (``optim.epochs: 3``); a key through a value that is not a mapping is an
    error naming ``where``. A key the config does not know becomes an unknown key that the
    config's validation then refuses."""
    for key, value in overrides.items():
        node = raw
        parts = key.split(".")
        for i, part in enumerate(parts[:-1]):
            nxt = node.setdefault(part, {})
            if not isinstance(nxt, dict):
                raise InputError(f"{where}: override `{key}`: `{'.'.join(parts[:i + 1])}` is "
                                 "not a mapping")
            node = nxt
        node[parts[-1]] = value
    return raw


def expand_grid(config: SweepConfig, *, path: str | Path | None = None) -> list[PlannedRun]:
    """Every run of the grid, in the sweep file's order (model, then window, then channel
    set), each config resolved and validated; errors name the sweep file and the run."""
    planned = []
    for model, spec in config.models.items():
        cfg_path = Path(spec.config)
        text, base = read_yaml(cfg_path)
        if not isinstance(base, dict):
            raise InputError(f"models.{model}.config is not a training config (a YAML "
                             "mapping)", path=cfg_path)
        family = str((base.get("model") or {}).get("family", "?")) \
            if isinstance(base.get("model"), dict) else "?"
        for w in config.windows:
            for set_name, chans in config.channel_sets.items():
                name = run_name(model, w.window, set_name)
                run = PlannedRun(name, model, family, w.window, w.stride, set_name,
                                 list(chans), str(cfg_path))
                planned.append(run)
                if spec.by_window is not None and w.window not in spec.by_window:
                    run.status = "n/a"
                    run.reason = (f"models.{model}.by_window lists no window {w.window} "
                                  f"(it has {', '.join(map(str, spec.by_window)) or 'none'})")
                    continue
                raw = _copy(base)
                where = f"run {name}"
                apply_overrides(raw, config.overrides, where=where)
                apply_overrides(raw, spec.overrides, where=where)
                apply_overrides(raw, (spec.by_window or {}).get(w.window, {}), where=where)
                apply_overrides(raw, {"data.window": w.window, "data.stride": w.stride,
                                      "data.channels": list(chans)}, where=where)
                try:
                    cfg = parse_config(raw, path=cfg_path)
                except InputError as exc:
                    raise InputError(f"run {name}: {exc.message} (in {cfg_path} with the "
                                     "sweep's overrides)", path=path) from None
                run.family = cfg.model.family
                run.config = cfg.model_dump(mode="json")
    return planned


def _copy(obj: Any) -> Any:
    if isinstance(obj, dict):
        return {k: _copy(v) for k, v in obj.items()}
    if isinstance(obj, list):
        return [_copy(v) for v in obj]
    return obj


def _heads(planned: Sequence[PlannedRun]) -> dict[str, str]:
    """Head name -> kind over every run, in first-seen order."""
    out: dict[str, str] = {}
    for r in planned:
        for t in (r.config or {}).get("data", {}).get("targets", []):
            out.setdefault(t["name"], t["kind"])
    return out


def _check_targets(config: SweepConfig, heads: dict[str, str], path: str | Path | None
                   ) -> str | None:
    """Check ``targets`` and ``score_head`` against the runs' heads; the score head."""
    for head, value in config.targets.items():
        if head not in heads:
            raise InputError(f"`targets.{head}`: no run has a head {head!r} (heads: "
                             f"{', '.join(heads)})", path=path)
        if heads[head] == "classification" and not 0 < value <= 1:
            raise InputError(f"`targets.{head}` (={value}) is an accuracy: a fraction in "
                             "(0, 1]", path=path)
        if heads[head] == "regression" and not value > 0:
            raise InputError(f"`targets.{head}` (={value}) is an MAE: a number > 0", path=path)
    score = config.score_head
    if score is not None and heads.get(score) != "classification":
        raise InputError(f"`score_head` (={score!r}) must be a classification head (heads: "
                         f"{', '.join(h for h, k in heads.items() if k == 'classification')})",
                         path=path)
    if score is None:
        score = next((h for h, k in heads.items() if k == "classification"), None)
    return score


# -- one run (on a worker) --------------------------------------------------------------------
def run_one(spec: dict[str, Any]) -> dict[str, Any]:
    """Train and evaluate one run of a sweep (the task the workers execute); ``spec`` is a
    plain mapping (:func:`task_spec`). Returns a short summary; raises on any failure."""
    from .config import parse_config as _parse
    from .evaluate import evaluate
    from .train import train

    cfg = _parse(spec["config"])
    device = spec.get("device", "auto")
    result = train(cfg, spec["train_data"], spec["run_dir"], config_path=spec["config_file"],
                   overwrite=True, command=spec["command"], device=device)
    ev = evaluate(spec["run_dir"], spec["eval_data"], split=spec["split"],
                  name=spec["eval_name"], threads=1, command=spec["command"], overwrite=True,
                  device=device)
    return {"run_dir": spec["run_dir"], "train_time_s": result.train_time_s,
            "epochs_run": len(result.history), "n_windows": ev.n_windows}


def task_spec(run: PlannedRun, *, out: Path, train_data: Sequence[Path],
              eval_data: Sequence[Path], split: str, eval_name: str, command: str,
              device: str = "auto") -> dict[str, Any]:
    """The picklable task of one run: absolute paths and plain values only (``device``
    is resolved on the worker that runs it: :mod:`.device`)."""
    return {"name": run.name, "config": run.config, "config_file": run.config_file,
            "train_data": [str(p.resolve()) for p in train_data],
            "eval_data": [str(p.resolve()) for p in eval_data], "split": split,
            "eval_name": eval_name, "run_dir": str((out / RUNS_DIR / run.name).resolve()),
            "command": command, "device": device}


def is_finished(run_dir: Path, run: PlannedRun, eval_name: str,
                train_sha: Sequence[str]) -> bool:
    """Whether ``run_dir`` holds this run complete: run.json, the evaluation ``eval_name``,
    the same resolved config and the same training data (SHA-256)."""
    import yaml

    if not (run_dir / runs.RUN_JSON).is_file() or not (
            run_dir / runs.EVAL_DIR / eval_name / runs.METRICS_JSON).is_file():
        return False
    try:
        info = runs.read_run_info(run_dir)
        saved = yaml.safe_load((run_dir / runs.CONFIG_YAML).read_text(encoding="utf-8"))
    except (InputError, OSError, yaml.YAMLError, UnicodeDecodeError):
        return False
    return saved == run.config and [d["sha256"] for d in info["data"]] == list(train_sha)


# -- the sweep --------------------------------------------------------------------------------
@dataclass
class SweepCounts:
    """Progress of a sweep: runs ``done`` (ok), ``failed``, ``running`` and ``total`` to
    run now; ``skipped``: finished before; ``na``: not applicable."""

    total: int
    done: int
    running: int
    failed: int
    skipped: int
    na: int

    def text(self) -> str:
        return f"{self.done}/{self.total} done, {self.running} running, {self.failed} failed"


@dataclass
class SweepResult:
    """What ``tactile sweep`` reports; OUT holds the rest (see the module docstring)."""

    out_dir: Path
    name: str
    rows: list[dict[str, Any]]
    heads: dict[str, str]
    score_head: str | None
    pick: dict[str, Any] | None
    pareto: list[str]
    files: dict[str, str]
    where: str
    wall_time_s: float
    n_ok: int = 0
    n_failed: int = 0
    n_na: int = 0
    n_skipped: int = 0
    notes: list[str] = field(default_factory=list)

    def as_dict(self) -> dict[str, Any]:
        out = asdict(self)
        out["out_dir"] = str(self.out_dir)
        return out

    def text(self) -> str:
        """What ``tactile sweep`` prints: the table (markdown, as in table.md), the summary
        line, the notes and the files written."""
        notes = "".join(f"note: {note}\n" for note in self.notes)
        return (table_markdown(self.rows, self.heads) + self.summary() + "\n" + notes
                + f"wrote {self.out_dir}: sweep.json, table.csv, table.md, "
                "sweep_results.json, accuracy_vs_window.png, speed_accuracy.png, runs/\n")

    def summary(self) -> str:
        text = (f"{self.name}: {self.n_ok} ok ({self.n_skipped} finished before), "
                f"{self.n_failed} failed, {self.n_na} n/a in {self.wall_time_s:.1f} s "
                f"({self.where})")
        if self.pick is not None:
            text += f"; pick: {self.pick['run']} ({self.pick['why']})"
        return text


def _file_record(path: Path) -> dict[str, Any]:
    return {"path": str(path), "sha256": sha256_of(path), "size_bytes": path.stat().st_size}


def plan_sweep(config: SweepConfig, *, path: str | Path | None = None,
               train_data: Sequence[str | Path] | None = None,
               eval_data: Sequence[str | Path] | None = None
               ) -> tuple[list[PlannedRun], list[Path], list[Path]]:
    """The grid with every config validated and the data files checked, before any
    work: (runs, training files, evaluation files). ``train_data``/``eval_data`` replace
    the sweep file's (the CLI's ``--data`` and ``--eval-data``)."""
    train = list(train_data) if train_data else list(config.train_data)
    if not train:
        raise InputError("no training data: the sweep file lists no train_data; add it "
                         "there or give `train_data`", path=path)
    train_paths = data_files(train)
    ev = list(eval_data) if eval_data else list(config.eval.data)
    eval_paths = data_files(ev) if ev else list(train_paths)
    planned = expand_grid(config, path=path)
    _check_channel_sets(config, planned, train_paths[0])
    return planned, train_paths, eval_paths


def _check_channel_sets(config: SweepConfig, planned: list[PlannedRun], path: Path) -> None:
    """Refuse before any work a grid in which no run could train because every run to do
    names channels the training data lacks (the first such error, naming its channel set).
    A grid where some runs can train runs them and lists the others as failed."""
    from .config import DataConfig
    from .data import check_channels

    todo = [r for r in planned if r.status == "todo" and r.config is not None]
    first: InputError | None = None
    for run in todo:
        try:
            check_channels(DataConfig.model_validate(run.config["data"]), path,
                           what=f"channel_sets.{run.channel_set}")
        except InputError as exc:
            first = first or exc
            continue
        return  # this run can train: the grid runs
    if first is not None:
        raise first


def partial_dir(out: Path) -> Path:
    """Where a sweep with ``overwrite`` builds its result beside an earlier one at ``out``
    (kept when stopped, resumed by the next such sweep, put in place when complete)."""
    return out.with_name(f".{out.name}.sweep-partial")


def _declare(config: SweepConfig, out: Path, config_path: str | Path | None,
             train_paths: Sequence[Path], eval_paths: Sequence[Path]) -> None:
    """Refuse an output folder that is, contains or lies inside an input (the sweep file,
    the model configs, the data)."""
    inputs = [Path(spec.config) for spec in config.models.values()]
    inputs += [*train_paths, *eval_paths] + ([] if config_path is None else [Path(config_path)])
    check_outputs({"out": out}, inputs)
    check_outputs({"out": partial_dir(out)}, inputs)


def _remove_task_leftovers(work: Path, names: Sequence[str], eval_name: str) -> None:
    """After a stop: the temporary folders of tasks whose worker processes were killed
    (their own clean-up never ran), each only once its process is gone."""
    for name in names:
        run_dir = work / RUNS_DIR / name
        remove_stale_temporaries(run_dir)
        remove_stale_temporaries(run_dir / runs.EVAL_DIR / eval_name)


def run_sweep(
    config: SweepConfig | str | Path,
    out: str | Path,
    *,
    config_path: str | Path | None = None,
    train_data: Sequence[str | Path] | None = None,
    eval_data: Sequence[str | Path] | None = None,
    scheduler: str | None = None,
    workers: int | None = None,
    overwrite: bool = False,
    command: str | None = None,
    on_plan: Callable[[list[PlannedRun]], None] | None = None,
    on_progress: Callable[[SweepCounts], None] | None = None,
    on_run: Callable[[str, bool, str | None], None] | None = None,
    on_line: Callable[[str], None] | None = None,
    device: str = "auto",
) -> SweepResult:
    """Plan, run (on Dask: see :func:`tactile_cli.batch.map_tasks` for ``scheduler`` and
    ``workers``), collect and chart a sweep into folder ``out``.

    ``out`` may hold an earlier run of the sweep (its finished runs are skipped); another
    non-empty folder is an error unless ``overwrite``. With ``overwrite``, every run runs
    again in a folder beside ``out`` (:func:`partial_dir`), which replaces ``out`` only
    when the sweep is complete: a stopped sweep leaves ``out`` as it was, and the next
    sweep with ``overwrite`` resumes there, skipping the runs it finished. ``on_plan`` gets
    the grid once planned, ``on_progress`` the counts, ``on_run`` each run's name, success
    and error as it ends, ``on_line`` the same as lines for people. ``config``: the sweep
    file (its path then stands for ``config_path``) or a loaded one. A failed run is a row
    of the result (``n_failed``), never an exception. ``device``: where each run trains
    and predicts (``auto``, ``cpu``, ``cuda``; resolved on the worker, :mod:`.device`);
    ``cuda`` is refused here when torch sees no GPU and no scheduler is given.
    """
    from ..batch import SCHEDULER_ENV, default_workers, map_tasks
    from .device import DEVICES, resolve_device

    started = time.perf_counter()
    if device not in DEVICES or (scheduler is None and not os.environ.get(SCHEDULER_ENV)):
        resolve_device(device)
    if workers:  # 0: in this process
        check_threads(workers, "workers")
    if not isinstance(config, SweepConfig):
        config_path = config
        config = load_sweep(config)
    out = Path(out)
    check_output_folder(out, merge=True)
    occupied = out.is_dir() and any(out.iterdir())
    if occupied and not (out / SWEEP_JSON).is_file() and not overwrite:
        raise InputError("output folder exists, is not empty and holds no sweep.json; give "
                         "an empty or new folder, or pass `overwrite=True`", path=out)
    planned, train_paths, eval_paths = plan_sweep(config, path=config_path,
                                                  train_data=train_data, eval_data=eval_data)
    _declare(config, out, config_path, train_paths, eval_paths)
    work = partial_dir(out) if overwrite and occupied else out
    notes = []
    if work == out and partial_dir(out).exists():
        notes.append(f"{partial_dir(out)} holds a stopped sweep with `overwrite=True`; run "
                     "that again to finish it, or delete it")
    heads = _heads(planned)
    score_head = _check_targets(config, heads, config_path)
    command = command if command is not None else current_command()
    train_records = [_file_record(p) for p in train_paths]
    eval_records = [_file_record(p) for p in eval_paths]
    eval_name = runs.eval_dir_name(eval_paths, config.eval.split)
    train_sha = [r["sha256"] for r in train_records]
    for run in planned:  # with `overwrite`, only the runs of the stopped sweep beside `out`
        if run.status == "todo" and (work != out or not overwrite) and is_finished(
                work / RUNS_DIR / run.name, run, eval_name, train_sha):
            run.status = "finished"
    address = scheduler or os.environ.get(SCHEDULER_ENV) or None
    todo = [r for r in planned if r.status == "todo"]
    n_workers = workers if workers is not None else min(default_workers(), max(1, len(todo)))
    where = f"Dask scheduler {address}" if address else (
        "in this process" if n_workers == 0 else f"local Dask cluster of {n_workers} "
        "worker process(es)")
    model_records = {}
    for model, spec in config.models.items():
        model_records[model] = _file_record(Path(spec.config))
    plan = {
        "format": SWEEP_FORMAT, "format_version": SWEEP_FORMAT_VERSION,
        "created_utc": utc_now(), "command": command,
        "versions": {"tactile": __version__, "python": platform.python_version()},
        "sweep_file": None if config_path is None else _file_record(Path(config_path)),
        "config": config.model_dump(mode="json"), "train_data": train_records,
        "eval_data": eval_records, "eval_split": config.eval.split, "eval_name": eval_name,
        "model_configs": model_records, "where": where,
        "runs": [r.as_dict() for r in planned],
    }
    try:
        (work / RUNS_DIR).mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise write_error(exc, work) from None
    write_text(work / SWEEP_JSON, runs.dumps(plan) + "\n", overwrite=True)
    if on_plan is not None:
        on_plan(planned)
    if on_line is not None:
        n = {st: sum(r.status == st for r in planned) for st in ("todo", "finished", "n/a")}
        on_line(f"sweep {config.name}: {len(planned)} runs in the grid: {n['todo']} to run, "
                f"{n['finished']} finished before (skipped), {n['n/a']} n/a")
    n_skipped = sum(r.status == "finished" for r in planned)
    n_na = sum(r.status == "n/a" for r in planned)
    errors: dict[str, str] = {}

    def progress(c: Any) -> None:
        if on_progress is not None:
            on_progress(SweepCounts(c.total, c.done, c.running, c.failed, n_skipped, n_na))

    specs = [task_spec(r, out=work, train_data=train_paths, eval_data=eval_paths,
                       split=config.eval.split, eval_name=eval_name, command=command,
                       device=device)
             for r in todo]
    if not todo:
        progress(_Counts(0, 0, 0, 0))
    try:
        for res in map_tasks(run_one, specs, keys=[r.name for r in todo], scheduler=address,
                             workers=n_workers, on_progress=progress):
            run = todo[res.index]
            run.status = "ok" if res.ok else "failed"
            if not res.ok:
                errors[run.name] = res.error or "failed"
            if on_run is not None:
                on_run(run.name, res.ok, res.error)
            if on_line is not None:
                on_line(f"{run.name}: ok" if res.ok else f"{run.name}: failed: {res.error}")
    except BaseException:
        _remove_task_leftovers(work, [r.name for r in todo], eval_name)
        raise
    if work != out:  # each evaluation names where its run will be after the swap
        for run in planned:
            run_dir = work / RUNS_DIR / run.name
            if (run_dir / runs.EVAL_DIR / eval_name / runs.METRICS_JSON).is_file():
                runs.name_final_run(run_dir, eval_name, out.resolve() / RUNS_DIR / run.name)
    result = collect(config, planned, work, heads=heads, score_head=score_head,
                     eval_name=eval_name, errors=errors, where=where, command=command,
                     plan=plan, started=started, out_dir=out)
    result.notes = notes + result.notes
    if work != out:
        swap_into_place(work, out)  # the earlier sweep is replaced only now
    return result


@dataclass(frozen=True)
class _Counts:
    total: int
    done: int
    running: int
    failed: int


# -- the table, the pick and the figures ------------------------------------------------------
def _row(run: PlannedRun, out: Path, eval_name: str, heads: dict[str, str],
         error: str | None) -> dict[str, Any]:
    row: dict[str, Any] = {"run": run.name, "model": run.model, "family": run.family,
                           "window": run.window, "stride": run.stride,
                           "channels": run.channel_set, "status": run.status,
                           "error": run.reason if run.status == "n/a" else error}
    for h, kind in heads.items():
        row[f"{h}_acc_pct" if kind == "classification" else f"{h}_mae"] = None
    row.update({"n_params": None, "size_mb": None, "latency_ms": None, "train_s": None,
                "meets_targets": None})
    if run.status in ("ok", "finished"):
        run_dir = out / RUNS_DIR / run.name
        try:
            info = runs.read_run_info(run_dir)
            m = runs.read_metrics(run_dir / runs.EVAL_DIR / eval_name / runs.METRICS_JSON)
        except InputError as exc:
            row.update(status="failed", error=str(exc))
            return row
        for h, hm in m["heads"].items():
            if hm["kind"] == "classification" and hm.get("accuracy") is not None:
                row[f"{h}_acc_pct"] = 100 * hm["accuracy"]
            elif hm["kind"] == "regression":
                row[f"{h}_mae"] = hm.get("mae")
        lat = m.get("latency") or {}
        row.update(n_params=int(m["model"]["n_params"]), size_mb=m["model"]["size_mb"],
                   latency_ms=lat.get("batch1_ms_median"),
                   train_s=info["training"].get("train_time_s"), status="ok")
    return row


def _meets(row: dict[str, Any], targets: dict[str, float], heads: dict[str, str]) -> bool:
    values: dict[str, float | None] = {}
    for h in targets:
        got = row.get(f"{h}_acc_pct" if heads[h] == "classification" else f"{h}_mae")
        values[h] = None if got is None else (got / 100 if heads[h] == "classification"
                                              else got)
    return meets_targets(values, heads, targets)


def pick_run(rows: list[dict[str, Any]], *, targets: dict[str, float], heads: dict[str, str],
             score_head: str | None, margin_pp: float
             ) -> tuple[dict[str, Any] | None, list[str]]:
    """(the pick, the Pareto front's run names): among the ok runs meeting every target
    (or, without targets, within ``margin_pp`` of the best ``score_head`` accuracy) the
    one with the fewest parameters, ties by latency then name (compare's
    :func:`~.compare.pick_needed`); the front of score against latency
    (:func:`~.compare.pareto_front`)."""
    ok = [r for r in rows if r["status"] == "ok"]
    for r in rows:
        r["meets_targets"] = _meets(r, targets, heads) if (targets and r["status"] == "ok") \
            else None
    if not ok:
        return None, []
    key = None if score_head is None else f"{score_head}_acc_pct"
    score = np.array([math.nan if key is None or r.get(key) is None else r[key] / 100
                      for r in ok])
    lat = np.array([math.nan if r["latency_ms"] is None else r["latency_ms"] for r in ok])
    params = np.array([r["n_params"] for r in ok], dtype=np.int64)
    labels = [r["run"] for r in ok]
    front = pareto_front(score, lat)
    pareto = [labels[i] for i in sorted(np.flatnonzero(front), key=lambda i: lat[i])]
    if targets:
        eligible = np.array([bool(r["meets_targets"]) for r in ok])
        why = "fewest parameters meeting " + ", ".join(
            f"{h} {'>=' if heads[h] == 'classification' else '<='} {v:g}"
            for h, v in targets.items())
    else:
        eligible = within_margin(score, margin_pp)
        why = f"fewest parameters within {margin_pp:g} pp of the best {score_head} accuracy"
    if not eligible.any():
        return None, pareto
    i = pick_needed(params, lat, eligible, labels)
    return {"run": labels[i], "why": why, "n_params": int(params[i]),
            "latency_ms": None if not math.isfinite(lat[i]) else float(lat[i]),
            "score_pct": None if not math.isfinite(score[i]) else 100 * float(score[i])}, pareto


def _fmt(v: Any, digits: int = 2) -> str:
    if v is None:
        return ""
    if isinstance(v, bool):
        return "yes" if v else "no"
    if isinstance(v, float):
        return f"{v:.{digits}f}"
    if isinstance(v, int):
        return f"{v:,}"
    return str(v)


def table_markdown(rows: list[dict[str, Any]], heads: dict[str, str]) -> str:
    """The table as markdown: one line per run, n/a and failed runs with their reason."""
    cols = ["model", "window", "channels", "status"]
    cols += [f"{h}_acc_pct" if k == "classification" else f"{h}_mae" for h, k in heads.items()]
    cols += ["n_params", "size_mb", "latency_ms", "train_s", "error"]
    names = {f"{h}_acc_pct": f"{h} acc %" for h in heads}
    names.update({f"{h}_mae": f"{h} MAE" for h in heads})
    names.update(n_params="params", size_mb="MB", latency_ms="batch-1 ms", train_s="train s",
                 error="error / reason")
    lines = ["| " + " | ".join(names.get(c, c) for c in cols) + " |",
             "|" + "|".join("---" for _ in cols) + "|"]
    for r in rows:
        cells = []
        for c in cols:
            v = r.get(c)
            if c == "window" and v is not None:
                cells.append(str(v))
            elif c in ("size_mb", "latency_ms") and isinstance(v, float):
                cells.append(f"{v:.3f}")
            elif c == "error":
                cells.append("" if v is None else str(v).replace("|", "/"))
            else:
                cells.append(_fmt(v))
        lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines) + "\n"


def _csv(rows: list[dict[str, Any]]) -> str:
    buf = io.StringIO()
    w = csv.DictWriter(buf, fieldnames=list(rows[0]), lineterminator="\n")
    w.writeheader()
    for r in rows:
        w.writerow({k: "" if v is None else v for k, v in r.items()})
    return buf.getvalue()


def _png(fig: Any) -> bytes:
    import matplotlib.pyplot as plt

    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=100, metadata={"Software": f"tactile {__version__}"})
    plt.close(fig)
    return buf.getvalue()


def plot_windows(rows: list[dict[str, Any]], heads: dict[str, str], *, title: str) -> bytes:
    """Fig. 8 of paper 001 as PNG bytes: a panel per model (rows) and head (columns),
    accuracy (%) or MAE against window size (samples, log axis, large to small as in the
    paper), a line per channel set; n/a and failed runs are gaps."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    models = list(dict.fromkeys(r["model"] for r in rows))
    sets = list(dict.fromkeys(r["channels"] for r in rows))
    windows = sorted({r["window"] for r in rows}, reverse=True)
    cols = list(heads)
    fig, axes = plt.subplots(len(models), len(cols), squeeze=False,
                             figsize=(3.4 * len(cols) + 1.6, 2.6 * len(models) + 0.6))
    for i, model in enumerate(models):
        for j, h in enumerate(cols):
            ax = axes[i][j]
            key = f"{h}_acc_pct" if heads[h] == "classification" else f"{h}_mae"
            for k, s in enumerate(sets):
                pts = sorted(((r["window"], r[key]) for r in rows
                              if r["model"] == model and r["channels"] == s
                              and r["status"] == "ok" and r.get(key) is not None),
                             reverse=True)
                if pts:
                    ax.plot([p[0] for p in pts], [p[1] for p in pts], marker="o", ms=3.5,
                            color=f"C{k % 10}", label=s)
            ax.set_xscale("log")
            ax.set_xticks(windows)
            ax.set_xticklabels([str(w) for w in windows], fontsize=7)
            ax.minorticks_off()
            if len(windows) > 1:
                ax.set_xlim(max(windows) * 1.25, min(windows) / 1.25)
            ax.grid(alpha=0.3)
            ax.set_title(f"{model}: {h}", fontsize=9)
            if i == len(models) - 1:
                ax.set_xlabel("window (samples)", fontsize=8)
            if j == 0 or heads[h] != heads[cols[j - 1]]:
                ax.set_ylabel("accuracy (%)" if heads[h] == "classification" else "MAE",
                              fontsize=8)
            na = [r["window"] for r in rows if r["model"] == model and r["status"] == "n/a"]
            if na and not ax.lines:
                ax.text(0.5, 0.5, "n/a", transform=ax.transAxes, ha="center", color="0.5")
    handles, labels = [], []
    for ax in axes.flat:
        for hd, lb in zip(*ax.get_legend_handles_labels(), strict=True):
            if lb not in labels:
                handles.append(hd)
                labels.append(lb)
    if handles:
        fig.legend(handles, labels, title="channels", fontsize=7, title_fontsize=8,
                   loc="center right")
    fig.suptitle(title, fontsize=10)
    fig.tight_layout(rect=(0, 0, 0.88 if handles else 1, 0.97))
    return _png(fig)


def plot_speed_accuracy(rows: list[dict[str, Any]], score_head: str | None,
                        pareto: Sequence[str], pick: dict[str, Any] | None, *,
                        title: str) -> bytes:
    """Score (%) against batch-1 median latency (ms, log axis) of every ok run, a marker
    per model, the Pareto front as a dashed staircase and the pick starred."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    key = None if score_head is None else f"{score_head}_acc_pct"
    pts = [r for r in rows if r["status"] == "ok" and key and r.get(key) is not None
           and r["latency_ms"] is not None and r["latency_ms"] > 0]
    fig, ax = plt.subplots(figsize=(8.5, 5))
    markers = "osD^vP*Xh<>"
    for k, model in enumerate(dict.fromkeys(r["model"] for r in rows)):
        mine = [r for r in pts if r["model"] == model]
        if mine:
            ax.scatter([r["latency_ms"] for r in mine], [r[key] for r in mine], s=36,
                       marker=markers[k % len(markers)], color=f"C{k % 10}", label=model,
                       zorder=3)
    front = [r for name in pareto for r in pts if r["run"] == name]
    if front:
        ax.step([r["latency_ms"] for r in front], [r[key] for r in front], where="post",
                ls="--", color="0.35", lw=1.1, label="Pareto front", zorder=2)
        for r in front:
            ax.annotate(r["run"], (r["latency_ms"], r[key]), xytext=(5, 4),
                        textcoords="offset points", fontsize=7)
    chosen = [r for r in pts if pick is not None and r["run"] == pick["run"]]
    if chosen:
        ax.scatter([chosen[0]["latency_ms"]], [chosen[0][key]], marker="*", s=280,
                   color="gold", edgecolors="black", zorder=5, label=f"pick: {pick['run']}")
    if pts:
        from matplotlib.ticker import FuncFormatter

        ax.set_xscale("log")
        ax.xaxis.set_major_formatter(FuncFormatter(lambda v, _: f"{v:g}"))
        ax.xaxis.set_minor_formatter(FuncFormatter(lambda v, _: f"{v:g}"))
    ax.set_xlabel("latency per window, batch 1, median (ms)")
    ax.set_ylabel(f"{score_head} accuracy (%)")
    ax.grid(alpha=0.3, which="both")
    ax.set_title(title, fontsize=10)
    if ax.get_legend_handles_labels()[0]:
        ax.legend(fontsize=7, loc="best")
    if not pts:
        ax.text(0.5, 0.5, "no finished run with a latency", transform=ax.transAxes,
                ha="center")
    fig.tight_layout()
    return _png(fig)


def collect(config: SweepConfig, planned: list[PlannedRun], out: Path, *,
            heads: dict[str, str], score_head: str | None, eval_name: str,
            errors: dict[str, str], where: str, command: str, plan: dict[str, Any],
            started: float, out_dir: Path | None = None) -> SweepResult:
    """Read every finished run's evaluation in folder ``out`` into the table, pick, chart
    and write the outputs there (each file atomically); ``out_dir``: where the folder will
    be when complete (default ``out``), as the result and sweep_results.json name it."""
    final = out if out_dir is None else out_dir
    rows = [_row(r, out, eval_name, heads, errors.get(r.name)) for r in planned]
    pick, pareto = pick_run(rows, targets=dict(config.targets), heads=heads,
                            score_head=score_head, margin_pp=config.margin_pp)
    notes = []
    if config.targets and pick is None:
        notes.append("no run meets every target")
    files = {"plan": SWEEP_JSON, "csv": TABLE_CSV, "markdown": TABLE_MD,
             "results": RESULTS_JSON, "windows_png": FIG_WINDOWS, "speed_png": FIG_SPEED}
    result = SweepResult(
        out_dir=final, name=config.name, rows=rows, heads=heads, score_head=score_head,
        pick=pick, pareto=pareto, files={k: str(final / v) for k, v in files.items()},
        where=where, wall_time_s=time.perf_counter() - started,
        n_ok=sum(r["status"] == "ok" for r in rows),
        n_failed=sum(r["status"] == "failed" for r in rows),
        n_na=sum(r["status"] == "n/a" for r in rows),
        n_skipped=sum(r.status == "finished" for r in planned), notes=notes)
    write_text(out / TABLE_CSV, _csv(rows), overwrite=True)
    write_text(out / TABLE_MD, f"# Sweep {config.name}\n\n" + table_markdown(rows, heads)
               + ("" if pick is None else f"\npick: **{pick['run']}** ({pick['why']})\n"),
               overwrite=True)
    write_bytes(out / FIG_WINDOWS, plot_windows(
        rows, heads, title=f"sweep {config.name}: accuracy and MAE against window size"),
        overwrite=True)
    write_bytes(out / FIG_SPEED, plot_speed_accuracy(
        rows, score_head, pareto, pick,
        title=f"sweep {config.name}: {score_head} accuracy against latency"), overwrite=True)
    record = {
        "format": SWEEP_RESULTS_FORMAT, "format_version": SWEEP_FORMAT_VERSION,
        "created_utc": utc_now(), "command": command, "tool_version": __version__,
        "sweep_file": plan["sweep_file"], "train_data": plan["train_data"],
        "eval_data": plan["eval_data"], "eval_name": eval_name, **result.as_dict(),
    }
    write_text(out / RESULTS_JSON, runs.dumps(record) + "\n", overwrite=True)
    return result


__all__ = ["FIG_SPEED", "FIG_WINDOWS", "RESULTS_JSON", "SWEEP_JSON", "TABLE_CSV", "TABLE_MD",
           "ModelSpec", "PlannedRun", "SweepConfig", "SweepCounts", "SweepResult",
           "apply_overrides", "collect", "expand_grid", "is_finished", "load_sweep",
           "partial_dir",
           "pick_run", "plan_sweep", "plot_speed_accuracy", "plot_windows", "run_name",
           "run_one", "run_sweep", "table_markdown", "task_spec"]
