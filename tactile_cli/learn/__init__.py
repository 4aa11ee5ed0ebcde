"""Learning from tactile recordings: datasets, the model registry, training, evaluation.

Issue 4, items 1-4 (and the latency part of 8): windows of any tactile HDF5 stream
(:mod:`.data`), five network families with multi-task heads and paper 001's eq.-3 loss
(:mod:`.models`), ``tactile train`` (:mod:`.train`, run folders: :mod:`.runs`) and
``tactile evaluate`` (:mod:`.evaluate`, latency: :mod:`.latency`); ``tactile export``
(:mod:`.export`: a run as one ONNX or TorchScript file). First applied to the
temporal LSTM action classifier of paper 000 (sec. 5, Table I).

The verbs of the commands are :func:`train_run`, :func:`evaluate_run` (:mod:`.pipeline`),
:func:`compare_runs`, :func:`perturb_runs`, :func:`export_run` and, for reports,
``tactile_cli.learn.report.build_report``. ``tactile_cli.learn.train`` and
``tactile_cli.learn.evaluate`` are the modules (one name, one meaning; their functions are
``train.train`` and ``evaluate.evaluate``).

The names below are loaded on first use (module ``__getattr__``): importing the package or
a light submodule (``tactile_cli.learn.splits``, ``.config``) does not import torch; using
a name from a torch module (``build_model``, ``train``, ...) does. The CLI imports them
only inside the commands.
"""

from __future__ import annotations

import importlib
import importlib.util
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
    "EvaluateRunResult": "pipeline",
    "evaluate_run": "pipeline",
    "train_run": "pipeline",
    "compare_runs": "compare",
    "perturb_runs": "perturb",
}

__all__ = sorted(_SOURCES)

if TYPE_CHECKING:  # the names for type checkers and IDEs; no import at run time
    from .compare import compare_runs as compare_runs
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
    from .perturb import perturb_runs as perturb_runs
    from .pipeline import EvaluateRunResult as EvaluateRunResult
    from .pipeline import evaluate_run as evaluate_run
    from .pipeline import train_run as train_run
    from .runs import Run as Run
    from .runs import load_run as load_run
    from .train import EpochRecord as EpochRecord
    from .train import TrainResult as TrainResult
    from .train import predict as predict
    from .train import prepare as prepare


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
