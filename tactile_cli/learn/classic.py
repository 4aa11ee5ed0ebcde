"""Classic model families in ``tactile train``: logistic regression, random forest,
histogram gradient boosting and an SVM (issue 34, item 3).

"Would a logistic regression do?" is the first question about any model that a scene
needs. These families go through the same path as the networks: the same config (only
``model`` differs: :class:`~.config.LogisticConfig`, :class:`~.config.RandomForestConfig`,
:class:`~.config.HistGbConfig`, :class:`~.config.SvmConfig`), the same data, splits,
normalisation and windows (:func:`.train.prepare`), the same run folder, ``tactile
evaluate`` (metrics, intervals, latency), ``--cv``, ``tactile compare`` and ``tactile
export``. What a window becomes is ``model.input``: its summary features per channel (as
the MLP's) or its raw samples.

The stored model is ONNX (``RUN/model.onnx``; :mod:`.classic_onnx`), not a pickle:
unpickling runs code from the file, and the brief of this toolkit loads no pickle a user
did not make. One format for the four families (a JSON of coefficients would do for the
logistic regression alone, and would need a second reader and a second exporter), read by
onnxruntime, which the export path needs anyway. At training time the graph is checked
against scikit-learn's ``predict_proba`` on every training and validation window
(largest difference recorded in ``run.json``, ``model.conversion_max_abs_diff``; more than
:data:`.classic_onnx.MAX_CONVERSION_DIFF` is an error), so what is evaluated later is
what was fitted.

Determinism: seeded (``seed``: the forest's bootstraps, the boosting's binning), and
independent of the machine's cores: BLAS and OpenMP run on one thread while fitting
(threadpoolctl), the forest's trees on ``optim.threads`` joblib workers (each tree's seed
is drawn before the trees are built, so the forest does not depend on the worker count),
and inference on one onnxruntime thread.
"""

from __future__ import annotations

import csv
import math
import platform
import time
import warnings
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
import torch
from torch import Tensor, nn

from .._version import __version__
from ..errors import InputError
from ..store.outdir import check_output_folder
from ..store.writer import current_command, sha256_of, utc_now
from . import runs
from .classic_onnx import (
    MAX_CONVERSION_DIFF,
    classic_graph,
    inputs_graph,
    quiet,
    run_graph,
    session,
)
from .config import CLASSIC_FAMILIES, TrainConfig
from .data import class_weights, data_files, resolve_channels
from .figures import plot_curves
from .heads import HeadSpec

if TYPE_CHECKING:
    from .train import EpochRecord, GivenSplits, Prepared, TrainResult

#: The stored model's file in a classic run folder (a network's is ``model.pt``).
MODEL_ONNX = runs.MODEL_ONNX
#: Probabilities are floored here before their log is taken as the head's "logits".
_TINY = 1e-300


def is_classic(family: str) -> bool:
    return family in CLASSIC_FAMILIES


# -- the estimator ----------------------------------------------------------------------------
def build_estimator(config: TrainConfig) -> Any:
    """The unfitted scikit-learn estimator of ``config.model`` (seeded by ``config.seed``)."""
    m = config.model
    seed = int(config.seed % 2**32)
    if m.family == "logistic":
        from sklearn.linear_model import LogisticRegression

        return LogisticRegression(C=m.c, max_iter=m.max_iter)
    if m.family == "random_forest":
        from sklearn.ensemble import RandomForestClassifier

        return RandomForestClassifier(
            n_estimators=m.trees, max_depth=m.max_depth, min_samples_leaf=m.min_samples_leaf,
            max_features=None if m.max_features == "all" else m.max_features,
            random_state=seed, n_jobs=config.optim.threads)
    if m.family == "hist_gb":
        from sklearn.ensemble import HistGradientBoostingClassifier

        return HistGradientBoostingClassifier(
            max_iter=m.max_iter, learning_rate=m.learning_rate,
            max_leaf_nodes=m.max_leaf_nodes, max_depth=m.max_depth,
            min_samples_leaf=m.min_samples_leaf, l2_regularization=m.l2_regularization,
            early_stopping=False, random_state=seed)
    if m.family == "svm":
        from sklearn.calibration import CalibratedClassifierCV
        from sklearn.model_selection import StratifiedKFold
        from sklearn.svm import SVC

        return CalibratedClassifierCV(
            SVC(kernel=m.kernel, C=m.c, gamma=m.gamma), method="sigmoid", ensemble=False,
            cv=StratifiedKFold(m.calibration_folds))
    raise ValueError(f"`family` (={m.family!r}) is not a classic family")


def count_stored(estimator: Any, family: str) -> int:
    """The numbers a fitted estimator stores (its "parameters" in ``tactile compare``):
    coefficients and intercepts; a tree's split features and thresholds and its leaves'
    values; support vectors, their weights, intercepts and Platt's two numbers per class."""
    if family == "logistic":
        return int(estimator.coef_.size + estimator.intercept_.size)
    if family == "random_forest":
        total = 0
        for tree in estimator.estimators_:
            leaves = int((tree.tree_.children_left < 0).sum())
            total += 2 * (tree.tree_.node_count - leaves) + leaves * tree.tree_.value.shape[-1]
        return total
    if family == "hist_gb":
        total = int(np.size(estimator._baseline_prediction))
        for iteration in estimator._predictors:
            for predictor in iteration:
                leaves = int(predictor.nodes["is_leaf"].sum())
                total += 2 * (predictor.nodes.shape[0] - leaves) + leaves
        return total
    (cc,) = estimator.calibrated_classifiers_
    svc = cc.estimator
    return int(svc.support_vectors_.size + svc.dual_coef_.size + svc.intercept_.size
               + 2 * len(cc.calibrators))


def _fit(estimator: Any, x: np.ndarray, y: np.ndarray, weights: np.ndarray | None,
         family: str) -> list[str]:
    """Fit on one BLAS/OpenMP thread; returns scikit-learn's convergence warnings as
    sentences (a refused fit is an InputError)."""
    from sklearn.exceptions import ConvergenceWarning
    from threadpoolctl import threadpool_limits

    with warnings.catch_warnings(record=True) as caught, threadpool_limits(limits=1):
        warnings.simplefilter("always")
        try:
            estimator.fit(x, y, sample_weight=weights)
        except ValueError as exc:
            raise InputError(f"the {family} model cannot be fitted to the training windows "
                             f"({' '.join(str(exc).split())[:240]}); check data.split and "
                             "the classes of the training trials") from None
    out = []
    for w in caught:
        if issubclass(w.category, ConvergenceWarning):
            hint = "raise model.max_iter or lower model.c" if family in ("logistic", "svm") \
                else "check the inputs"
            out.append(f"{family}: the solver did not converge ({hint})")
    stump = _no_split_note(estimator, family, len(y))
    return sorted(set(out)) + ([stump] if stump else [])


def _no_split_note(estimator: Any, family: str, n_windows: int) -> str | None:
    """A sentence when no tree of a fitted forest or boosting made a single split, else
    None. Such a model predicts the same probabilities for every window (the classes'
    share in the training windows): with boosting's default ``min_samples_leaf`` of 20, a
    fold of under 40 training windows cannot split at all, and nothing else says so."""
    if family == "random_forest":
        trees = [t.tree_.node_count for t in estimator.estimators_]
    elif family == "hist_gb":
        trees = [pred.nodes.shape[0] for it in estimator._predictors for pred in it]
    else:
        return None
    if any(n > 1 for n in trees):
        return None
    leaf = getattr(estimator, "min_samples_leaf", None)
    return (f"{family}: no tree made a split on the {n_windows} training windows "
            f"(each leaf needs model.min_samples_leaf = {leaf} windows): the model gives "
            "every window the same probabilities; lower model.min_samples_leaf or train on "
            "more windows")


# -- the model as the rest of learn/ sees it -------------------------------------------------
class ClassicNet(nn.Module):
    """A classic run's stored ONNX model where :mod:`.train`'s ``predict``, the latency
    measurement and the evaluation expect a network: normalised windows ``(B, W, C)`` in,
    ``{head: (B, k) log-probabilities}`` out (float64; their softmax is the probabilities).
    ``n_parameters`` and ``size_bytes`` (the ONNX file) stand in for a network's parameter
    count and state size. Inference runs on one onnxruntime thread, whatever torch's
    thread count, so results do not depend on it."""

    def __init__(self, model: bytes, heads: Sequence[HeadSpec], *, n_parameters: int,
                 family: str):
        super().__init__()
        self.model_bytes = bytes(model)
        self.head_specs = tuple(heads)
        self.family = family
        self.n_parameters = int(n_parameters)
        self.size_bytes = len(self.model_bytes)
        self._session = session(self.model_bytes, threads=1)
        self._input = self._session.get_inputs()[0].name

    def probabilities(self, windows: np.ndarray) -> np.ndarray:
        """(n, W, C) normalised windows -> (n, k) float64 probabilities."""
        return run_graph(self._session, windows)

    def forward(self, x: Tensor) -> dict[str, Tensor]:
        batch = np.ascontiguousarray(x.detach().cpu().numpy(), dtype=np.float32)
        p = self._session.run(None, {self._input: batch})[0]
        return {self.head_specs[0].name: torch.from_numpy(np.log(np.maximum(p, _TINY)))}


def load_classic(run: runs.Run) -> ClassicNet:
    """The stored model of classic run ``run``, checked: the file is ONNX that onnxruntime
    loads, takes (batch, window, channels) of the run's config and gives one probability
    per class of its head."""
    path = run.path / MODEL_ONNX
    redo = "re-create the run with `tactile train`"
    if not path.is_file():
        raise InputError(f"run folder has no {MODEL_ONNX}; {redo}", path=run.path)
    model = path.read_bytes()
    n_params = run.info.get("model", {}).get("n_params")
    if not isinstance(n_params, int) or isinstance(n_params, bool) or n_params < 0:
        raise InputError(f"`model.n_params` must be a non-negative integer; {redo}",
                         path=run.path / runs.RUN_JSON)
    try:
        net = ClassicNet(model, run.heads, n_parameters=n_params,
                         family=run.config.model.family)
    except Exception as exc:  # onnxruntime's refusal of a damaged file, said on one line
        text = " ".join(str(exc).split())[:200]
        raise InputError(f"{MODEL_ONNX} cannot be loaded ({exc.__class__.__name__}: {text}); "
                         f"the file is damaged: {redo}", path=path) from None
    d = run.config.data
    shape = [getattr(v, "dim_value", None) or v for v in
             net._session.get_inputs()[0].shape[1:]]
    if shape != [d.window, len(d.channels)]:
        raise InputError(f"{MODEL_ONNX} takes windows of {shape}, not the config's "
                         f"[{d.window}, {len(d.channels)}]; {redo}", path=path)
    k = len(run.heads[0].classes)
    probe = net.probabilities(np.zeros((1, d.window, len(d.channels)), np.float32))
    if probe.shape != (1, k) or not np.all(np.isfinite(probe)):
        raise InputError(f"{MODEL_ONNX} gives {probe.shape[-1]} outputs for the "
                         f"{k} classes of head {run.heads[0].name!r}; {redo}", path=path)
    return net.eval()


# -- training ---------------------------------------------------------------------------------
def _log_loss(p: np.ndarray, y: np.ndarray) -> float:
    if y.shape[0] == 0:
        return math.nan
    return float(-np.mean(np.log(np.maximum(p[np.arange(y.shape[0]), y], _TINY))))


def _accuracy(p: np.ndarray, y: np.ndarray) -> float:
    return float((p.argmax(axis=1) == y).mean()) if y.shape[0] else math.nan


def _versions() -> dict[str, str]:
    import onnx
    import onnxruntime
    import skl2onnx
    import sklearn

    return {"tactile": __version__, "torch": torch.__version__, "numpy": np.__version__,
            "scikit-learn": sklearn.__version__, "skl2onnx": skl2onnx.__version__,
            "onnx": onnx.__version__, "onnxruntime": onnxruntime.__version__,
            "python": platform.python_version(), "platform": platform.platform()}


def train_classic(
    config: TrainConfig,
    data_paths: Sequence[str | Path],
    out: str | Path,
    *,
    config_path: str | Path | None = None,
    overwrite: bool = False,
    command: str | None = None,
    on_epoch: Callable[[EpochRecord], None] | None = None,
    on_start: Callable[[Prepared], None] | None = None,
    given: GivenSplits | None = None,
) -> TrainResult:
    """:func:`.train.train` for a classic family: fit on the training windows, convert to
    ONNX, check the conversion and write the run folder (``model.onnx`` where a network
    has ``model.pt``; history.csv and curves.png hold the one fit as epoch 1, its training
    and validation log loss and validation accuracy). Arguments as :func:`.train.train`."""
    from threadpoolctl import threadpool_limits

    from .train import EpochRecord, TrainResult, prepare

    started = time.perf_counter()
    out = Path(out)
    if out.exists() and out.is_dir() and not overwrite:
        raise InputError("output folder exists; pass `overwrite=True` to replace it", path=out)
    check_output_folder(out, overwrite=overwrite)
    paths = data_files(data_paths)
    config = config.model_copy(update={"data": resolve_channels(config.data, paths)})
    d, m = config.data, config.model
    prep = prepare(config, paths, given=given)
    if on_start is not None:
        on_start(prep)
    (head,) = prep.heads
    n_classes = len(head.classes)
    w, c = d.window, len(d.channels)
    features = list(m.features) if m.input == "features" else []
    inputs = session(inputs_graph(n_samples=w, n_channels=c, input_kind=m.input,
                                  features=features))
    train_ws, val_ws = prep.windows["train"], prep.windows["val"]
    x_train = run_graph(inputs, train_ws.windows())
    y_train = train_ws.targets[head.name]
    mean = x_train.mean(axis=0)
    scale = x_train.std(axis=0)
    scale = np.where(np.isfinite(scale) & (scale > 0), scale, 1.0)
    if not m.standardise:
        mean, scale = np.zeros_like(mean), np.ones_like(scale)
    z_train = (x_train - mean) / scale
    weights = None
    if d.class_weights:
        weights = class_weights(y_train, n_classes)[y_train]
    estimator = build_estimator(config)
    t0 = time.perf_counter()
    notes = _fit(estimator, z_train, y_train, weights, m.family)
    train_time = time.perf_counter() - t0
    present = [int(v) for v in np.asarray(estimator.classes_)]
    if present != list(range(n_classes)):
        missing = [head.classes[i] for i in range(n_classes) if i not in present]
        raise InputError(f"the training windows hold no window of class(es) "
                         f"{', '.join(missing)} of head {head.name!r}; the {m.family} model "
                         "needs every class in training: change data.split")
    model = classic_graph(estimator, m.family, n_samples=w, n_channels=c,
                          input_kind=m.input, features=features, mean=mean, scale=scale,
                          n_inputs=x_train.shape[1])
    net = ClassicNet(model, prep.heads, n_parameters=count_stored(estimator, m.family),
                     family=m.family)
    checked = [train_ws] + ([val_ws] if len(val_ws) else [])
    diff = 0.0
    with quiet(), threadpool_limits(limits=1):
        for ws in checked:
            z = (run_graph(inputs, ws.windows()) - mean) / scale
            ref = estimator.predict_proba(z)
            diff = max(diff, float(np.max(np.abs(net.probabilities(ws.windows()) - ref))))
    if not diff <= MAX_CONVERSION_DIFF:
        raise InputError(f"the ONNX graph of the {m.family} model differs from scikit-learn's "
                         f"probabilities by {diff:.3g} (more than {MAX_CONVERSION_DIFF:g}); "
                         "this is a conversion bug: report it with the config")
    p_train = net.probabilities(train_ws.windows())
    p_val = net.probabilities(val_ws.windows()) if len(val_ws) else np.zeros((0, n_classes))
    y_val = val_ws.targets[head.name]
    record = EpochRecord(1, _log_loss(p_train, y_train), _log_loss(p_val, y_val),
                         _accuracy(p_val, y_val), train_time, True)
    if on_epoch is not None:
        on_epoch(record)
    prep.normalisation.features = {"names": features or ["raw"],
                                   "mean": mean.tolist(), "std": scale.tolist()}
    n_trials = prep.assignment.counts()
    n_windows = {s: len(ws) for s, ws in prep.windows.items()}
    size_mb = len(model) / 1e6
    params = {k: v for k, v in estimator.get_params(deep=False).items()
              if isinstance(v, int | float | str | bool | type(None))}
    info = {
        "format": runs.RUN_FORMAT, "format_version": runs.RUN_FORMAT_VERSION,
        "created_utc": utc_now(),
        "command": command if command is not None else current_command(),
        "config_file": None if config_path is None else str(config_path),
        "versions": _versions(), "seed": config.seed,
        "data": [{"path": str(p), "sha256": sha256_of(p), "size_bytes": p.stat().st_size,
                  "n_trials": sum(1 for t in prep.trials if t.file == str(p))} for p in paths],
        "heads": [h.as_dict() for h in prep.heads], "input": prep.input.as_dict(),
        "class_weights": None if weights is None else
        {head.name: class_weights(y_train, n_classes).tolist()},
        "split": {"mode": prep.assignment.mode, "by": prep.assignment.by,
                  "source": None if given is None else given.source,
                  "trials": n_trials, "windows": n_windows,
                  "warnings": list(prep.assignment.warnings)},
        "model": {"family": m.family, "n_params": net.n_parameters, "size_mb": size_mb,
                  "window": w, "channels": list(d.channels), "stream": d.stream,
                  "file": MODEL_ONNX, "format": "onnx", "input": m.input,
                  "n_inputs": int(x_train.shape[1]), "estimator": type(estimator).__name__,
                  "estimator_params": params, "conversion_max_abs_diff": diff,
                  "conversion_checked_windows": int(sum(len(ws) for ws in checked))},
        "training": {"epochs_run": 1, "best_epoch": 1, "stopped_early": False,
                     "monitor": "one fit", "best_val_loss": record.val_loss,
                     "best_val_accuracy": record.val_accuracy, "train_time_s": train_time,
                     "threads": config.optim.threads, "deterministic": True,
                     "device": "cpu", "notes": notes},
    }
    rows = [record.as_dict()]

    def fill(tmp: Path) -> None:
        (tmp / MODEL_ONNX).write_bytes(model)
        (tmp / runs.CONFIG_YAML).write_text(config.as_yaml(), encoding="utf-8")
        (tmp / runs.NORMALISATION_JSON).write_text(prep.normalisation.to_json() + "\n",
                                                   encoding="utf-8")
        with open(tmp / runs.HISTORY_CSV, "w", newline="", encoding="utf-8") as f:
            writer = csv.DictWriter(f, fieldnames=list(rows[0]))
            writer.writeheader()
            writer.writerows(rows)
        plot_curves(rows, tmp / runs.CURVES_PNG, best_epoch=1, title=f"{m.family}: {out.name}")
        with open(tmp / runs.SPLIT_CSV, "w", newline="", encoding="utf-8") as f:
            writer = csv.writer(f)
            writer.writerow(["file", "trial", "split"])
            for t, s in zip(prep.trials, prep.assignment.splits, strict=True):
                writer.writerow([t.file, t.trial, s])
        info["wall_time_s"] = time.perf_counter() - started
        runs.write_json(tmp / runs.RUN_JSON, info)

    runs.write_folder(out, fill, overwrite=overwrite)
    return TrainResult(
        run_dir=out, family=m.family, history=[record], best_epoch=1, stopped_early=False,
        n_params=net.n_parameters, size_mb=size_mb, wall_time_s=float(info["wall_time_s"]),
        train_time_s=train_time, threads=config.optim.threads, n_trials=n_trials,
        n_windows=n_windows, best_val_loss=record.val_loss,
        best_val_accuracy=record.val_accuracy, heads=prep.heads,
        warnings=list(prep.assignment.warnings) + notes)


__all__ = ["MODEL_ONNX", "ClassicNet", "build_estimator", "count_stored", "is_classic",
           "load_classic", "train_classic"]
