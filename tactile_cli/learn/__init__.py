"""Learning from tactile recordings: datasets, the model registry, training, evaluation.

Issue 4, items 1-4 (and the latency part of 8): windows of any tactile HDF5 stream
(:mod:`.data`), five network families with multi-task heads and paper 001's eq.-3 loss
(:mod:`.models`), ``tactile train`` (:mod:`.train`, run folders: :mod:`.runs`) and
``tactile evaluate`` (:mod:`.evaluate`, latency: :mod:`.latency`); ``tactile export``
(:mod:`.export`: a run as one ONNX or TorchScript file). First applied to the
temporal LSTM action classifier of paper 000 (sec. 5, Table I).

The names below are loaded on first use (module ``__getattr__``): importing the package or
a light submodule (``tactile_cli.learn.splits``, ``.config``) does not import torch; using
a name from a torch module (``build_model``, ``train``, ...) does. The CLI imports them
only inside the commands.
"""

from __future__ import annotations

import importlib
import importlib.util
import sys
import types
from typing import TYPE_CHECKING, Any

#: public name -> the submodule that defines it (imported on first use)
_SOURCES: dict[str, str] = {
    "FAMILIES": "config",
    "TrainConfig": "config",
    "load_config": "config",
    "parse_config": "config",
    "Normalisation": "data",
    "TrialSeries": "data",
    "WindowSet": "data",
    "assign_splits": "data",
    "fit_normalisation": "data",
    "make_windows": "data",
    "read_trials": "data",
    "summary_features": "data",
    "ClassificationMetrics": "evaluate",
    "EvalResult": "evaluate",
    "RegressionMetrics": "evaluate",
    "classification_metrics": "evaluate",
    "evaluate": "evaluate",
    "DeployedModel": "export",
    "ExportedModel": "export",
    "export_run": "export",
    "HeadSpec": "heads",
    "LatencyStats": "latency",
    "measure_latency": "latency",
    "REGISTRY": "models",
    "MultiTaskNet": "models",
    "build_model": "models",
    "multitask_loss": "models",
    "Run": "runs",
    "load_run": "runs",
    "EpochRecord": "train",
    "TrainResult": "train",
    "predict": "train",
    "prepare": "train",
    "train": "train",
}

__all__ = sorted(_SOURCES)

if TYPE_CHECKING:  # the names for type checkers and IDEs; no import at run time
    from .config import FAMILIES as FAMILIES
    from .config import TrainConfig as TrainConfig
    from .config import load_config as load_config
    from .config import parse_config as parse_config
    from .data import Normalisation as Normalisation
    from .data import TrialSeries as TrialSeries
    from .data import WindowSet as WindowSet
    from .data import assign_splits as assign_splits
    from .data import fit_normalisation as fit_normalisation
    from .data import make_windows as make_windows
    from .data import read_trials as read_trials
    from .data import summary_features as summary_features
    from .evaluate import ClassificationMetrics as ClassificationMetrics
    from .evaluate import EvalResult as EvalResult
    from .evaluate import RegressionMetrics as RegressionMetrics
    from .evaluate import classification_metrics as classification_metrics
    from .evaluate import evaluate as evaluate
    from .export import DeployedModel as DeployedModel
    from .export import ExportedModel as ExportedModel
    from .export import export_run as export_run
    from .heads import HeadSpec as HeadSpec
    from .latency import LatencyStats as LatencyStats
    from .latency import measure_latency as measure_latency
    from .models import REGISTRY as REGISTRY
    from .models import MultiTaskNet as MultiTaskNet
    from .models import build_model as build_model
    from .models import multitask_loss as multitask_loss
    from .runs import Run as Run
    from .runs import load_run as load_run
    from .train import EpochRecord as EpochRecord
    from .train import TrainResult as TrainResult
    from .train import predict as predict
    from .train import prepare as prepare
    from .train import train as train


def __getattr__(name: str) -> Any:
    """Import the submodule that defines ``name`` on first use (PEP 562)."""
    module = _SOURCES.get(name)
    if module is None:
        # a submodule used as an attribute without its own import (``learn.models.X``),
        # as when the package imported them all
        if not name.startswith("_") and importlib.util.find_spec(f"{__name__}.{name}"):
            return importlib.import_module(f".{name}", __name__)
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    value = getattr(importlib.import_module(f".{module}", __name__), name)
    globals()[name] = value                                      # next time: no lookup
    return value


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(_SOURCES))


class _Package(types.ModuleType):
    """This package's module type: importing the submodules ``evaluate`` and ``train``
    does not bind them over the functions of the same name (as the eager imports did)."""

    def __setattr__(self, name: str, value: Any) -> None:
        if _SOURCES.get(name) == name and isinstance(value, types.ModuleType):
            return
        super().__setattr__(name, value)


sys.modules[__name__].__class__ = _Package
