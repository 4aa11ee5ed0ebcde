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
import os
import shutil
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import torch
import yaml

from .._version import __version__
from ..errors import InputError
from .config import TrainConfig, parse_config
from .data import Normalisation
from .heads import HeadSpec
from .inputs import InputSpec
from .models import MultiTaskNet, build_model

RUN_FORMAT = "tactile-run"
RUN_FORMAT_VERSION = 1
EVAL_FORMAT = "tactile-eval"
EVAL_FORMAT_VERSION = 1

RUN_JSON = "run.json"
CONFIG_YAML = "config.resolved.yaml"
MODEL_PT = "model.pt"
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
    ``overwrite``; otherwise that is an error raised before anything is written)."""
    out = Path(out)
    if out.exists() and not overwrite:
        raise InputError("output folder exists; pass `overwrite=True` to replace it", path=out)
    if out.exists() and not out.is_dir():
        raise InputError("output exists and is not a folder", path=out)
    out.parent.mkdir(parents=True, exist_ok=True)
    _remove_stale(out)
    tmp = out.with_name(f".{out.name}.tmp-{os.getpid()}")
    if tmp.exists():
        shutil.rmtree(tmp)
    tmp.mkdir()
    try:
        fill(tmp)
        old = None
        if out.exists():
            old = out.with_name(f".{out.name}.old-{os.getpid()}")
            os.replace(out, old)
        os.replace(tmp, out)
        if old is not None:
            shutil.rmtree(old, ignore_errors=True)
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
        raise
    return out


def _remove_stale(out: Path) -> None:
    """Delete temporary siblings of ``out`` left by killed writers (their pid is gone)."""
    for tmp in out.parent.glob(f".{out.name}.*-*"):
        kind, _, pid = tmp.name.rpartition("-")
        if not (pid.isdigit() and kind.endswith((".tmp", ".old"))):
            continue
        try:
            os.kill(int(pid), 0)
        except ProcessLookupError:
            shutil.rmtree(tmp, ignore_errors=True)
        except PermissionError:  # alive, someone else's
            pass


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


def write_json(path: Path, obj: Any) -> None:
    path.write_text(dumps(obj) + "\n", encoding="utf-8")


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

    def load_model(self) -> MultiTaskNet:
        """The network with its trained weights (``torch.load(weights_only=True)``), in
        eval mode."""
        d = self.config.data
        model = build_model(self.config.model, window=d.window, n_channels=len(d.channels),
                            heads=self.heads)
        try:
            state = torch.load(self.path / MODEL_PT, map_location="cpu", weights_only=True)
        except FileNotFoundError:
            raise InputError("run folder has no model.pt; re-run `tactile train`",
                             path=self.path) from None
        except Exception as exc:  # a corrupt or foreign file: say which
            raise InputError(f"cannot load model.pt ({exc.__class__.__name__}: {exc})",
                             path=self.path / MODEL_PT) from None
        try:
            model.load_state_dict(state)
        except RuntimeError as exc:
            first = str(exc).splitlines()[0]
            raise InputError(f"model.pt does not fit the run's config ({first}); re-run "
                             "`tactile train`", path=self.path / MODEL_PT) from None
        return model.eval()


def load_run(path: str | Path) -> Run:
    """Read a run folder; errors name the file and the command that re-creates it."""
    path = Path(path)
    if not path.is_dir():
        raise InputError("run folder not found (give the folder `tactile train` wrote)",
                         path=path)
    info_path = path / RUN_JSON
    try:
        info = json.loads(info_path.read_text(encoding="utf-8"))
    except FileNotFoundError:
        raise InputError("not a run folder (no run.json); train one with `tactile train`",
                         path=path) from None
    except json.JSONDecodeError as exc:
        raise InputError(f"run.json is not valid JSON ({exc})", path=info_path) from None
    if info.get("format") != RUN_FORMAT:
        raise InputError(f"run.json format is {info.get('format')!r}, not {RUN_FORMAT!r}",
                         path=info_path)
    if info.get("format_version") != RUN_FORMAT_VERSION:
        raise InputError(f"run folder format version {info.get('format_version')} cannot be "
                         f"read by tactile {__version__} (reads {RUN_FORMAT_VERSION}); "
                         "re-create it with this version's `tactile train`", path=info_path)
    cfg_path = path / CONFIG_YAML
    try:
        raw = yaml.safe_load(cfg_path.read_text(encoding="utf-8"))
    except FileNotFoundError:
        raise InputError("run folder has no config.resolved.yaml", path=path) from None
    config = parse_config(raw, path=cfg_path)
    try:
        norm = Normalisation.from_dict(
            json.loads((path / NORMALISATION_JSON).read_text(encoding="utf-8")))
    except FileNotFoundError:
        raise InputError("run folder has no normalisation.json", path=path) from None
    heads = [HeadSpec.from_dict(h) for h in info["heads"]]
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


__all__ = ["CONFIG_YAML", "CURVES_PNG", "EVAL_DIR", "EVAL_FORMAT", "EVAL_FORMAT_VERSION",
           "HISTORY_CSV", "METRICS_JSON", "MODEL_PT", "NORMALISATION_JSON", "PREDICTIONS_CSV",
           "RUN_FORMAT", "RUN_FORMAT_VERSION", "RUN_JSON", "SPLIT_CSV", "Run", "dumps",
           "eval_dir_name", "json_safe", "load_run", "write_folder", "write_json"]
