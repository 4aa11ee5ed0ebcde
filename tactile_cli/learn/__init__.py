"""Learning from tactile recordings: datasets, the model registry, training, evaluation.

Issue 4, items 1-4 (and the latency part of 8): windows of any tactile HDF5 stream
(:mod:`.data`), five network families with multi-task heads and paper 001's eq.-3 loss
(:mod:`.models`), ``tactile train`` (:mod:`.train`, run folders: :mod:`.runs`) and
``tactile evaluate`` (:mod:`.evaluate`, latency: :mod:`.latency`); ``tactile export``
(:mod:`.export`: a run as one ONNX or TorchScript file). First applied to the
temporal LSTM action classifier of paper 000 (sec. 5, Table I).

Importing this package imports torch; the CLI imports it only inside the commands.
"""

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
