"""The run folder of ``tactile train`` and the evaluations inside it: layout, writing, loading.

A run folder (format ``tactile-run`` version 1)::

    RUN/
      run.json               format, versions (tactile, torch, numpy, python), command,
                             config file, data files with SHA-256, seed, heads, class
                             weights, split counts, training summary (epochs, best epoch,
                             wall time, threads), model (family, parameters, size), input
                             (stream, sensor, sample period and rate, channels, units:
                             see inputs.py; absent in runs trained before issue 10)
      config.resolved.yaml   the validated config with every default filled in
      model.pt               torch.save(state_dict); load with torch.load(weights_only=True)
                             (model.onnx instead for a classic family: the estimator as
                             ONNX, read by onnxruntime; see classic.py)
      normalisation.json     per-channel mean/std (training split only), regression-target
                             and summary-feature statistics
      history.csv            one row per epoch: train/val loss, val accuracy, seconds
      curves.png             loss and validation accuracy against epoch
      split.csv              file, trial, split of every training-data trial
      eval/<name>/           one folder per `tactile evaluate` (see evaluate.py):
        metrics.json, confusion_<head>.png, confusion_<head>.json, predictions.csv

Both the run folder and each evaluation folder are written into a temporary sibling and
renamed into place, so a folder either is complete or does not exist.
"""

from __future__ import annotations

import json
import math
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from .._version import __version__
from ..config_file import missing_file_error, parse_yaml, read_text
from ..errors import InputError
from ..input_guard import note_input
from ..store.atomic import write_text
from ..store.outdir import output_folder
from .config import CLASSIC_FAMILIES, TrainConfig, parse_config
from .data import Normalisation
from .heads import HeadSpec
from .inputs import InputSpec

if TYPE_CHECKING:  # torch is imported where a model is loaded: reading a run's records
    from .models import MultiTaskNet  # (info, compare, report) does not need it

RUN_FORMAT = "tactile-run"
RUN_FORMAT_VERSION = 1
EVAL_FORMAT = "tactile-eval"
EVAL_FORMAT_VERSION = 1

RUN_JSON = "run.json"
CONFIG_YAML = "config.resolved.yaml"
MODEL_PT = "model.pt"
MODEL_ONNX = "model.onnx"  # the stored model of a classic family (learn/classic.py)
NORMALISATION_JSON = "normalisation.json"
HISTORY_CSV = "history.csv"
CURVES_PNG = "curves.png"
SPLIT_CSV = "split.csv"
EVAL_DIR = "eval"
METRICS_JSON = "metrics.json"
PREDICTIONS_CSV = "predictions.csv"


def write_folder(out: Path, fill: Callable[[Path], None], *, overwrite: bool) -> Path:
    """Create folder ``out`` atomically: ``fill(tmp)`` writes into a temporary sibling,
    which is then renamed to ``out`` (an existing ``out`` is replaced only when
    ``overwrite``; otherwise that is an error raised before anything is written; a file at
    ``out`` or at one of its parents is an error either way). See
    :func:`tactile_cli.store.outdir.output_folder`."""
    out = Path(out)
    if out.exists() and out.is_dir() and not overwrite:
        raise InputError("output folder exists; pass `overwrite=True` to replace it", path=out)
    with output_folder(out, overwrite=overwrite) as tmp:
        fill(tmp)
    return out


def json_safe(obj: Any) -> Any:
    """``obj`` with every non-finite float replaced by None (strict JSON has no NaN)."""
    if isinstance(obj, float):
        return obj if math.isfinite(obj) else None
    if isinstance(obj, dict):
        return {k: json_safe(v) for k, v in obj.items()}
    if isinstance(obj, list | tuple):
        return [json_safe(v) for v in obj]
    return obj


def dumps(obj: Any) -> str:
    """Strict JSON (NaN and infinities as null), indented."""
    return json.dumps(json_safe(obj), indent=2, allow_nan=False)


def write_json(path: Path, obj: Any, *, overwrite: bool = False) -> None:
    """``obj`` as :func:`dumps` JSON in file ``path``, written atomically."""
    write_text(path, dumps(obj) + "\n", overwrite=overwrite)


@dataclass
class Run:
    """A trained run read back from its folder. ``input``: the stream, sample period,
    channels and units it was trained on (None for runs whose run.json predates them)."""

    path: Path
    info: dict[str, Any]
    config: TrainConfig
    heads: list[HeadSpec]
    normalisation: Normalisation
    input: InputSpec | None = None

    @property
    def weights_path(self) -> Path:
        """The file of the trained model: ``model.pt``, or ``model.onnx`` for a classic
        family (:mod:`.classic`)."""
        if self.config.model.family in CLASSIC_FAMILIES:
            return self.path / MODEL_ONNX
        return self.path / MODEL_PT

    def load_model(self) -> MultiTaskNet:
        """The network with its trained weights (``torch.load(weights_only=True)``), in
        eval mode; for a classic family its stored ONNX model as a
        :class:`.classic.ClassicNet` (which evaluation uses as it uses a network)."""
        if self.config.model.family in CLASSIC_FAMILIES:
            from .classic import load_classic

            return load_classic(self)  # type: ignore[return-value]
        import torch

        from .models import build_model

        d = self.config.data
        model = build_model(self.config.model, window=d.window, n_channels=len(d.channels),
                            heads=self.heads, frames=d.frames)
        weights = self.path / MODEL_PT
        try:
            state = torch.load(weights, map_location="cpu", weights_only=True)
        except FileNotFoundError:
            raise InputError(f"run folder has no model.pt; {_RETRAIN}", path=self.path) from None
        except Exception as exc:  # random bytes, a cut file, a foreign pickle: say which
            raise InputError(f"model.pt cannot be loaded ({_first_line(exc)}); the file is "
                             f"damaged: {_RETRAIN}", path=weights) from None
        if not isinstance(state, dict) or not all(
                isinstance(k, str) and isinstance(v, torch.Tensor) for k, v in state.items()):
            raise InputError(f"model.pt holds no state dict of named tensors; {_RETRAIN}",
                             path=weights)
        bad = next((k for k, v in state.items()
                    if v.is_floating_point() and not bool(torch.isfinite(v).all())), None)
        if bad is not None:
            raise InputError(f"weight {bad!r} holds NaN or infinite values; {_RETRAIN}",
                             path=weights)
        try:
            model.load_state_dict(state)
        except (RuntimeError, TypeError, ValueError, KeyError) as exc:
            raise InputError(f"model.pt does not fit the run's config ({_first_line(exc)}); "
                             f"{_RETRAIN}", path=weights) from None
        return model.eval()


#: What to do about a damaged run folder.
_RETRAIN = "re-create the run with `tactile train`"


def _first_line(exc: BaseException) -> str:
    """The exception's first sentence (torch's load errors go on with advice that does not
    apply here, such as `weights_only=False`)."""
    text = " ".join(str(exc).split("\n")[0].split()).split(". ")[0].rstrip(".")
    return f"{exc.__class__.__name__}: {text}" if text else exc.__class__.__name__


def _read_json(path: Path, run: Path) -> Any:
    """The parsed JSON of a run folder's file; a missing, unreadable or cut file is one
    InputError naming it."""
    if not path.exists():
        if path.is_symlink() or not run.joinpath(RUN_JSON).exists():
            raise missing_file_error(path)
        raise InputError(f"run folder has no {path.name}; {_RETRAIN}", path=run)
    return _parse_json(path, _RETRAIN)


def _parse_json(path: Path, redo: str) -> Any:
    """The parsed JSON of ``path``; text that is not UTF-8 or not JSON is one InputError
    naming the file (and line) that ends with ``redo``, what re-creates it."""
    try:
        return json.loads(read_text(path, advice=f"the file is damaged: {redo}"))
    except json.JSONDecodeError as exc:
        raise InputError(f"not valid JSON ({exc.msg}): the file is damaged or cut; {redo}",
                         path=path, where=f"line {exc.lineno}, column {exc.colno}") from None
    except (ValueError, RecursionError) as exc:
        raise InputError(f"not valid JSON ({_first_line(exc)}); {redo}", path=path) from None


def checked_record(obj: Any, path: Path, *, fmt: str, version: int | None, redo: str,
                   what_version: str | None = None, redo_version: str | None = None
                   ) -> dict[str, Any]:
    """``obj`` (parsed JSON of file ``path``) if it is an object of format ``fmt`` and, unless
    ``version`` is None, of ``format_version`` ``version``; else one InputError naming the
    file that ends with ``redo`` (``redo_version`` for a version this tool cannot read)."""
    name = path.name
    if not isinstance(obj, dict):
        raise InputError(f"{name} is not a JSON object; {redo}", path=path)
    if obj.get("format") != fmt:
        raise InputError(f"{name} format is {obj.get('format')!r}, not {fmt!r}; {redo}",
                         path=path)
    if version is not None and obj.get("format_version") != version:
        raise InputError(f"{what_version or name} format version {obj.get('format_version')} "
                         f"cannot be read by tactile {__version__} (reads {version}); "
                         f"{redo_version or redo}", path=path)
    return obj


def _finite_list(value: Any, key: str, n: int | None, path: Path, *,
                 positive: bool = False) -> np.ndarray:
    """``value`` as a (n,) float64 array of finite numbers (> 0 with ``positive``)."""
    if not isinstance(value, list) or not all(
            isinstance(v, int | float) and not isinstance(v, bool) for v in value):
        raise InputError(f"`{key}` must be a list of numbers; {_RETRAIN}", path=path)
    arr = np.asarray(value, dtype=np.float64)
    if n is not None and len(arr) != n:
        raise InputError(f"`{key}` holds {len(arr)} values for {n} channels; {_RETRAIN}",
                         path=path)
    bad = np.flatnonzero(~np.isfinite(arr) | ((arr <= 0) if positive else False))
    if len(bad):
        need = "finite and positive" if positive else "finite"
        raise InputError(f"`{key}[{int(bad[0])}]` (={arr[bad[0]]}) must be {need} (a zero "
                         f"std would divide by zero); {_RETRAIN}" if positive else
                         f"`{key}[{int(bad[0])}]` (={arr[bad[0]]}) must be {need}; {_RETRAIN}",
                         path=path)
    return arr


def _normalisation(raw: Any, channels: list[str], path: Path) -> Normalisation:
    """normalisation.json checked: a record per channel of the config, finite means and
    positive finite stds (evaluation divides by them)."""
    if not isinstance(raw, dict):
        raise InputError(f"not a normalisation record (a JSON object); {_RETRAIN}", path=path)
    missing = [k for k in ("channels", "mean", "std", "n_samples", "enabled", "transform",
                           "targets") if k not in raw]
    if missing:
        raise InputError(f"key `{missing[0]}` is missing; {_RETRAIN}", path=path)
    if raw["channels"] != list(channels):
        raise InputError(f"`channels` (={raw['channels']!r}) differ from the config's "
                         f"data.channels {list(channels)!r}; {_RETRAIN}", path=path)
    mean = _finite_list(raw["mean"], "mean", len(channels), path)
    std = _finite_list(raw["std"], "std", len(channels), path, positive=True)
    if not isinstance(raw["enabled"], bool):
        raise InputError(f"`enabled` must be true or false; {_RETRAIN}", path=path)
    if raw["transform"] not in ("none", "signed_log1p"):
        raise InputError(f"`transform` (={raw['transform']!r}) must be none or signed_log1p; "
                         f"{_RETRAIN}", path=path)
    n = raw["n_samples"]
    if not isinstance(n, int) or isinstance(n, bool) or n < 0:
        raise InputError(f"`n_samples` (={n!r}) must be a non-negative integer; {_RETRAIN}",
                         path=path)
    targets = raw["targets"]
    if not isinstance(targets, dict) or not all(
            isinstance(v, dict) and {"mean", "std"} <= v.keys() for v in targets.values()):
        raise InputError(f"`targets` must map each regression head to its mean and std; "
                         f"{_RETRAIN}", path=path)
    checked = {}
    for name, v in targets.items():
        m = _finite_list([v["mean"]], f"targets.{name}.mean", 1, path)
        sd = _finite_list([v["std"]], f"targets.{name}.std", 1, path, positive=True)
        checked[name] = (float(m[0]), float(sd[0]))
    features = raw.get("features")
    if features is not None and not isinstance(features, dict):
        raise InputError(f"`features` must be a JSON object or null; {_RETRAIN}", path=path)
    return Normalisation(list(channels), mean, std, n, raw["enabled"], raw["transform"],
                         checked, features)


def _heads(raw: Any, path: Path) -> list[HeadSpec]:
    if not isinstance(raw, list) or not raw:
        raise InputError(f"`heads` must be a non-empty list; {_RETRAIN}", path=path)
    heads = []
    for i, h in enumerate(raw):
        try:
            head = HeadSpec.from_dict(h)
            ok = (head.kind in ("classification", "regression")
                  and head.source in ("sample", "trial") and math.isfinite(head.weight)
                  and (head.kind == "regression" or len(head.classes) >= 1))
        except (KeyError, TypeError, ValueError, AttributeError):
            ok = False
        if not ok:
            raise InputError(f"`heads[{i}]` is not a valid head record (name, kind, source, "
                             f"weight, classes); {_RETRAIN}", path=path)
        heads.append(head)
    return heads


#: Keys of the run.json `tactile train` writes and the JSON types they hold ("input" is left
#: out: runs trained before issue 10 lack it).
_RUN_KEYS: dict[str, tuple[type, ...]] = {
    "created_utc": (str,), "command": (str,), "config_file": (str, type(None)),
    "versions": (dict,), "seed": (int,), "data": (list,), "heads": (list,),
    "class_weights": (dict, type(None)), "split": (dict,), "model": (dict,),
    "training": (dict,), "wall_time_s": (int, float)}


def _run_folder(path: str | Path) -> Path:
    """``path`` if it is a folder holding run.json, else one InputError saying what it is."""
    path = Path(path)
    if not path.exists():
        if path.is_symlink():
            raise missing_file_error(path, "run folder")
        raise InputError("run folder not found (give the folder `tactile train` wrote)",
                         path=path)
    if not path.is_dir():
        raise InputError("not a run folder but a file (give the folder `tactile train` wrote)",
                         path=path)
    info_path = path / RUN_JSON
    if not info_path.exists() and not info_path.is_symlink():
        raise InputError("not a run folder (no run.json); train one with `tactile train`",
                         path=path)
    for entry in path.iterdir():  # the run's own files are inputs: no output may replace them
        if entry.is_file():
            note_input(entry, tree=False)
    return path


def read_run_info(path: str | Path) -> dict[str, Any]:
    """A run folder's run.json, checked: a JSON object of format ``tactile-run`` version 1
    with every key `tactile train` writes, of the right JSON type. Every reader of run.json
    (evaluate, perturb, compare, report) goes through here; errors name the file and the
    command that re-creates it."""
    path = _run_folder(path)
    info_path = path / RUN_JSON
    info = checked_record(_read_json(info_path, path), info_path, fmt=RUN_FORMAT,
                          version=RUN_FORMAT_VERSION, redo=_RETRAIN, what_version="run folder",
                          redo_version="re-create it with this version's `tactile train`")
    if "heads" not in info:
        raise InputError(f"run.json has no `heads`; {_RETRAIN}", path=info_path)
    data = info.get("data", [])
    if not isinstance(data, list) or not all(
            isinstance(d, dict) and isinstance(d.get("sha256"), str) for d in data):
        raise InputError(f"`data` must list the training files with their sha256; {_RETRAIN}",
                         path=info_path)
    for key, types in _RUN_KEYS.items():
        if key not in info:
            raise InputError(f"run.json has no `{key}`; {_RETRAIN}", path=info_path)
        value = info[key]
        if not isinstance(value, types) or (isinstance(value, bool) and bool not in types):
            need = " or ".join("null" if t is type(None) else _JSON_NAMES[t] for t in types)
            raise InputError(f"`{key}` must be {need}, not {type(value).__name__}; "
                             f"{_RETRAIN}", path=info_path)
    if not isinstance(info["model"].get("family"), str):
        raise InputError(f"`model.family` must be a string; {_RETRAIN}", path=info_path)
    return info


_JSON_NAMES = {str: "a string", int: "a number", float: "a number", dict: "a JSON object",
               list: "a list"}


def read_run_config(path: str | Path) -> TrainConfig:
    """A run folder's config.resolved.yaml, read and validated; a missing, cut or broken file
    is one InputError naming it (and the line) and saying to re-create the run."""
    path = Path(path)
    cfg_path = path / CONFIG_YAML
    if not cfg_path.exists() and not cfg_path.is_symlink():
        raise InputError(f"run folder has no config.resolved.yaml; {_RETRAIN}", path=path)
    text = read_text(cfg_path, "config file", advice=f"the file is damaged: {_RETRAIN}")
    try:
        return parse_config(parse_yaml(text, cfg_path), path=cfg_path, text=text)
    except InputError as exc:
        raise InputError(f"{exc.message}; the run folder is damaged: {_RETRAIN}",
                         path=exc.path, where=exc.where) from None


def read_metrics(path: str | Path) -> dict[str, Any]:
    """An evaluation's metrics.json (``RUN/eval/<name>/metrics.json``), checked: a JSON object
    of format ``tactile-eval`` version 1 whose ``heads`` map each head to its metrics."""
    path = Path(path)
    redo = "re-create it with `tactile evaluate` (`overwrite=True`)"
    m = checked_record(_parse_json(path, redo), path, fmt=EVAL_FORMAT,
                       version=EVAL_FORMAT_VERSION, redo=redo)
    heads = m.get("heads")
    if not isinstance(heads, dict) or not all(
            isinstance(h, dict) and isinstance(h.get("kind"), str) for h in heads.values()):
        raise InputError(f"`heads` must map each head to its metrics; {redo}", path=path)
    primary = m.get("primary_head")
    if primary is not None and primary not in heads:
        raise InputError(f"`primary_head` (={primary!r}) is not one of `heads`; {redo}",
                         path=path)
    for name, head in heads.items():
        _check_head_metrics(name, head, path, redo)
    for key, fields in (("latency", ("batch1_ms_median", "batch1_ms_p95", "windows_per_s")),
                        ("model", ("n_params", "size_mb"))):
        value = m.get(key)
        if value is None and key == "latency":
            continue
        if not isinstance(value, dict) or not all(_number_or_null(value.get(f))
                                                  for f in fields):
            raise InputError(f"`{key}` must hold the numbers {', '.join(fields)}; {redo}",
                             path=path)
    if not isinstance(m.get("n_windows"), int) or isinstance(m.get("n_windows"), bool):
        raise InputError(f"`n_windows` must be an integer; {redo}", path=path)
    return m


def name_final_run(run_dir: Path, eval_name: str, final: Path) -> str:
    """Make the evaluation ``RUN/eval/<eval_name>/metrics.json`` of a run built in a partial
    folder (a seed spread, a sweep replacing an earlier one) name ``final``, the path the run
    will have once that folder is renamed into place, not the partial path that is gone
    after it (written atomically, before the rename). Returns ``str(final)``."""
    metrics = run_dir / EVAL_DIR / eval_name / METRICS_JSON
    record = json.loads(metrics.read_text(encoding="utf-8"))
    if record.get("run") != str(final):
        record["run"] = str(final)
        write_json(metrics, record, overwrite=True)
    return str(final)


def _number_or_null(v: Any) -> bool:
    return v is None or (isinstance(v, int | float) and not isinstance(v, bool)
                         and not (isinstance(v, float) and math.isinf(v)))


def _check_head_metrics(name: str, head: dict[str, Any], path: Path, redo: str) -> None:
    """The fields of one head's metrics that compare and report read, with their types."""
    where = f"`heads.{name}`"
    if head["kind"] == "regression":
        if not all(_number_or_null(head.get(k)) for k in ("mae", "rmse")):
            raise InputError(f"{where} must hold the numbers mae and rmse; {redo}", path=path)
        return
    if not all(_number_or_null(head.get(k)) for k in ("accuracy", "macro_f1")):
        raise InputError(f"{where}: `accuracy` and `macro_f1` must be numbers; {redo}",
                         path=path)
    per_class = head.get("per_class")
    if not isinstance(per_class, list) or not all(
            isinstance(c, dict) and isinstance(c.get("name"), str)
            and all(_number_or_null(c.get(k)) for k in ("precision", "recall", "f1"))
            and isinstance(c.get("support", 0), int) for c in per_class):
        raise InputError(f"{where}: `per_class` must list the name, f1 (and precision, "
                         f"recall, support) of every class; {redo}", path=path)
    cm = head.get("confusion_matrix")
    k = len(per_class)
    if cm is not None and (not isinstance(cm, list) or len(cm) != k or not all(
            isinstance(r, list) and len(r) == k and all(
                isinstance(v, int) and not isinstance(v, bool) and v >= 0 for v in r)
            for r in cm)):
        raise InputError(f"{where}: `confusion_matrix` must be {k} x {k} counts; {redo}",
                         path=path)

def load_run(path: str | Path) -> Run:
    """Read a run folder, checking every file before use (format and version, keys and their
    types, finite normalisation); errors name the file and the command that re-creates it."""
    path = _run_folder(path)
    info_path = path / RUN_JSON
    info = read_run_info(path)
    if info.get("cv") is not None:
        raise InputError("a cross-validated run holds one model per fold; give a fold's "
                         "folder (RUN/folds/fold_00, ...) for a single model", path=path)
    config = read_run_config(path)
    norm = _normalisation(_read_json(path / NORMALISATION_JSON, path),
                          list(config.data.channels), path / NORMALISATION_JSON)
    heads = _heads(info["heads"], info_path)
    trained = None
    if "input" in info:
        trained = InputSpec.from_dict(info["input"], path=info_path)
    return Run(path, info, config, heads, norm, trained)


def eval_dir_name(data_paths: list[Path], split: str) -> str:
    """``<stem>[+<stem>...]`` of the data files (at most three named, then ``+N``), with
    ``.test`` for the test split: RUN/eval/<name>/."""
    stems = [p.stem for p in data_paths]
    name = "+".join(stems[:3]) + (f"+{len(stems) - 3}" if len(stems) > 3 else "")
    return f"{name}.{split}" if split != "all" else name


def check_result_name(name: str | None, argument: str = "name") -> str | None:
    """``name`` of a results folder (``RUN/eval/<name>``, ``RUN/perturb/<name>``) if it is
    one plain folder name: not empty, no ``/`` or ``\\``, not ``.`` or ``..`` (which would
    put the results outside their folder); one :class:`InputError` otherwise."""
    if name is not None and (not name.strip() or name in (".", "..")
                             or any(c in name for c in "/\\\0")):
        raise InputError(f"`{argument}` (={name!r}) must be a plain folder name (no / or \\, "
                         "not . or ..)")
    return name


def run_files(path: str | Path) -> list[Path]:
    """The files directly in a run folder (run.json, model.pt, ...): the inputs no output
    may replace (``RUN/eval/`` and ``RUN/perturb/`` may be written). Empty when ``path`` is
    not a folder."""
    path = Path(path)
    return sorted(p for p in path.iterdir() if p.is_file()) if path.is_dir() else []


__all__ = ["CONFIG_YAML", "CURVES_PNG", "EVAL_DIR", "EVAL_FORMAT", "EVAL_FORMAT_VERSION",
           "HISTORY_CSV", "METRICS_JSON", "MODEL_ONNX", "MODEL_PT", "NORMALISATION_JSON",
           "PREDICTIONS_CSV",
           "RUN_FORMAT", "RUN_FORMAT_VERSION", "RUN_JSON", "SPLIT_CSV", "Run", "checked_record",
           "dumps",
           "eval_dir_name", "json_safe", "load_run", "read_metrics", "read_run_config",
           "check_result_name", "name_final_run", "read_run_info", "run_files", "write_folder",
           "write_json"]
