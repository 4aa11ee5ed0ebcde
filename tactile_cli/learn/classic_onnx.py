"""The classic families as ONNX graphs: window features, standardisation and the fitted
scikit-learn estimator in one graph (issue 34, item 3).

The stored model of a classic run (``RUN/model.onnx``) and its export are ONNX, so a run
folder holds no pickle and the model runs where onnxruntime runs. One graph takes the
normalised window ``(B, W, C)`` float32, as every network of :mod:`.models` does, and
returns ``probabilities`` ``(B, n_classes)`` float64:

1. the inputs in float64: the summary features of each channel (:func:`feature_nodes`:
   mean, population std, min, max, last, least-squares slope; feature-major, as
   :func:`.data.summary_features`) or the window flattened (sample-major);
2. the standardisation of the training windows (``(f - mean) / scale``);
3. the estimator. Logistic regression and the random forest are converted by skl2onnx
   (exact: the forest's float32 comparisons are scikit-learn's, which casts its input to
   float32 too). Gradient boosting and the SVM are written here: skl2onnx 1.20's converter
   of HistGradientBoostingClassifier fails with onnx >= 1.18 (it passes a Python bool into
   an integer-list attribute) and stores thresholds in float32, where scikit-learn
   compares float64; its SVC converter keeps the support vectors and coefficients in
   float32 (a 6e-6 probability error on a 20-feature toy problem, growing with the
   number of support vectors). Here both are float64: the boosted trees as one
   ``TreeEnsembleRegressor`` (ai.onnx.ml 3, float64 thresholds and leaves) followed by the
   logistic or softmax link; the SVM as matrix products (kernel, one-against-one decision
   values, scikit-learn's one-against-rest votes and confidences) and Platt's sigmoids.

:func:`classic_graph` assembles the graph, :func:`run_graph` runs it with onnxruntime on
one thread (results do not depend on the machine's core count).
"""

from __future__ import annotations

import contextlib
import io
import warnings
from collections.abc import Iterator, Sequence
from typing import Any

import numpy as np

#: Opsets of every graph written here (skl2onnx's converters are asked for the same).
OPSET = 17
ML_OPSET = 3
#: Largest difference of the stored graph's probabilities from scikit-learn's allowed at
#: training time (:func:`.classic.train_classic` refuses a conversion beyond it).
MAX_CONVERSION_DIFF = 1e-5


@contextlib.contextmanager
def quiet() -> Iterator[None]:
    """skl2onnx's deprecation warnings (scikit-learn 1.9 deprecates SVC attributes it
    reads) and prints kept off the terminal; pytest turns warnings into errors."""
    with warnings.catch_warnings(), contextlib.redirect_stdout(io.StringIO()):
        warnings.simplefilter("ignore")
        yield


class _Graph:
    """Nodes, initialisers and the opsets of one ONNX graph under construction."""

    def __init__(self) -> None:
        self.nodes: list[Any] = []
        self.inits: list[Any] = []
        self._n = 0

    def name(self, stem: str) -> str:
        self._n += 1
        return f"{stem}_{self._n}"

    def const(self, stem: str, value: np.ndarray) -> str:
        from onnx import numpy_helper

        name = self.name(stem)
        self.inits.append(numpy_helper.from_array(np.asarray(value), name))
        return name

    def op(self, op_type: str, inputs: Sequence[str], stem: str | None = None,
           domain: str = "", **attrs: Any) -> str:
        from onnx import helper

        out = self.name(stem or op_type.lower())
        self.nodes.append(helper.make_node(op_type, list(inputs), [out], domain=domain,
                                           name=out, **attrs))
        return out


def feature_nodes(g: _Graph, window: str, *, n_samples: int, n_channels: int,
                  input_kind: str, features: Sequence[str]) -> str:
    """Nodes from ``window`` (B, W, C) float32 to the (B, F) float64 inputs: the summary
    features (feature-major) or the flattened window (sample-major)."""
    from onnx import TensorProto

    x = g.op("Cast", [window], "window64", to=TensorProto.DOUBLE)
    if input_kind == "raw":
        return g.op("Reshape", [x, g.const("flat", np.array([-1, n_samples * n_channels]))],
                    "inputs")
    axis = g.const("axis1", np.array([1], dtype=np.int64))
    parts = []
    for name in features:
        if name == "mean":
            parts.append(g.op("ReduceMean", [x], "mean", axes=[1], keepdims=0))
        elif name == "std":
            centred = g.op("Sub", [x, g.op("ReduceMean", [x], "mean_k", axes=[1], keepdims=1)])
            var = g.op("ReduceMean", [g.op("Mul", [centred, centred])], "var", axes=[1],
                       keepdims=0)
            parts.append(g.op("Sqrt", [var], "std"))
        elif name == "min":
            parts.append(g.op("ReduceMin", [x], "min", axes=[1], keepdims=0))
        elif name == "max":
            parts.append(g.op("ReduceMax", [x], "max", axes=[1], keepdims=0))
        elif name == "last":
            parts.append(g.op("Gather", [x, g.const("last_i", np.array(n_samples - 1))],
                              "last", axis=1))
        elif name == "slope":
            idx = np.arange(n_samples, dtype=np.float64) - (n_samples - 1) / 2
            denom = float((idx ** 2).sum()) or 1.0
            weights = g.const("slope_w", (idx / denom).reshape(1, n_samples, 1))
            parts.append(g.op("ReduceSum", [g.op("Mul", [x, weights]), axis], "slope",
                              keepdims=0))
        else:
            raise ValueError(f"`features` has unknown name {name!r}")
    return g.op("Concat", parts, "inputs", axis=1) if len(parts) > 1 else parts[0]


def standardise_nodes(g: _Graph, inputs: str, mean: np.ndarray, scale: np.ndarray) -> str:
    """``(inputs - mean) / scale`` in float64."""
    centred = g.op("Sub", [inputs, g.const("input_mean", mean.astype(np.float64))])
    return g.op("Div", [centred, g.const("input_scale", scale.astype(np.float64))], "z")


def _skl2onnx_model(estimator: Any, n_inputs: int, *, float32: bool) -> Any:
    """skl2onnx's graph of ``estimator`` (input ``X``, outputs label and probabilities,
    no ZipMap)."""
    from skl2onnx import to_onnx
    from skl2onnx.common.data_types import DoubleTensorType, FloatTensorType

    kind = FloatTensorType if float32 else DoubleTensorType
    with quiet():
        return to_onnx(estimator, initial_types=[("X", kind([None, n_inputs]))],
                       target_opset={"": OPSET, "ai.onnx.ml": ML_OPSET},
                       options={id(estimator): {"zipmap": False}})


def _append_model(g: _Graph, model: Any, z: str, prefix: str) -> str:
    """The nodes of ``model`` (one input, outputs ``label`` and ``probabilities``) fed by
    ``z``; returns the name of its probabilities."""
    from onnx import compose

    model = compose.add_prefix(model, prefix)
    (inp,) = [i.name for i in model.graph.input]
    g.nodes.append(_identity(z, inp))
    g.nodes.extend(model.graph.node)
    g.inits.extend(model.graph.initializer)
    probs = next(o.name for o in model.graph.output if o.name.endswith("probabilities"))
    return probs


def _identity(src: str, dst: str) -> Any:
    from onnx import helper

    return helper.make_node("Identity", [src], [dst], name=f"{dst}_from_{src}")


def hist_gb_nodes(g: _Graph, z: str, est: Any) -> str:
    """A fitted HistGradientBoostingClassifier as a float64 ``TreeEnsembleRegressor`` (one
    target per tree of an iteration) plus its baseline and link: probabilities (B, k)."""
    from onnx import TensorProto, numpy_helper

    k = int(est.n_trees_per_iteration_)
    tree_ids, node_ids, feat, modes, values, true_ids, false_ids, missing = \
        [], [], [], [], [], [], [], []
    t_tree, t_node, t_target, t_weight = [], [], [], []
    for i, iteration in enumerate(est._predictors):
        for j, predictor in enumerate(iteration):
            nodes = predictor.nodes
            if np.any(nodes["is_categorical"]):
                raise ValueError("categorical splits cannot be exported")
            tree = i * k + j
            leaf = nodes["is_leaf"].astype(bool)
            n = nodes.shape[0]
            tree_ids += [tree] * n
            node_ids += list(range(n))
            feat += np.where(leaf, 0, nodes["feature_idx"]).astype(int).tolist()
            modes += ["LEAF" if lf else "BRANCH_LEQ" for lf in leaf]
            values.append(np.where(leaf, 0.0, nodes["num_threshold"]))
            true_ids += np.where(leaf, 0, nodes["left"]).astype(int).tolist()
            false_ids += np.where(leaf, 0, nodes["right"]).astype(int).tolist()
            missing += np.where(leaf, 0, nodes["missing_go_to_left"]).astype(int).tolist()
            leaves = np.flatnonzero(leaf)
            t_tree += [tree] * leaves.size
            t_node += leaves.tolist()
            t_target += [j] * leaves.size
            t_weight.append(nodes["value"][leaves])
    attrs = {
        "n_targets": k, "aggregate_function": "SUM", "post_transform": "NONE",
        "nodes_treeids": tree_ids, "nodes_nodeids": node_ids, "nodes_featureids": feat,
        "nodes_modes": modes, "nodes_truenodeids": true_ids, "nodes_falsenodeids": false_ids,
        "nodes_missing_value_tracks_true": missing,
        "nodes_values_as_tensor": numpy_helper.from_array(
            np.concatenate(values).astype(np.float64), "nodes_values"),
        "target_treeids": t_tree, "target_nodeids": t_node, "target_ids": t_target,
        "target_weights_as_tensor": numpy_helper.from_array(
            np.concatenate(t_weight).astype(np.float64), "target_weights"),
    }
    raw32 = g.op("TreeEnsembleRegressor", [z], "trees", domain="ai.onnx.ml", **attrs)
    raw = g.op("Add", [g.op("Cast", [raw32], "trees64", to=TensorProto.DOUBLE),
                       g.const("baseline", np.asarray(est._baseline_prediction,
                                                      np.float64).reshape(1, k))], "raw")
    if k == 1:  # binary: P(class 1) = expit(raw)
        p1 = g.op("Sigmoid", [raw], "p1")
        p0 = g.op("Sub", [g.const("one", np.ones((1, 1))), p1], "p0")
        return g.op("Concat", [p0, p1], "probabilities", axis=1)
    return g.op("Softmax", [raw], "probabilities", axis=1)


def _ovo_coefficients(dual_coef: np.ndarray, n_support: np.ndarray) -> np.ndarray:
    """(n_sv, n_pairs) weights of the support vectors in each one-against-one decision
    value (libsvm's pairing: for classes i < j, the vectors of class i weigh with row j - 1
    of ``dual_coef``, those of class j with row i)."""
    k = n_support.shape[0]
    starts = np.concatenate([[0], np.cumsum(n_support)])
    pairs = [(i, j) for i in range(k) for j in range(i + 1, k)]
    out = np.zeros((dual_coef.shape[1], len(pairs)))
    for p, (i, j) in enumerate(pairs):
        si, sj = slice(starts[i], starts[i + 1]), slice(starts[j], starts[j + 1])
        out[si, p] = dual_coef[j - 1, si]
        out[sj, p] = dual_coef[i, sj]
    return out


def svm_nodes(g: _Graph, z: str, calibrated: Any) -> str:
    """A fitted ``CalibratedClassifierCV(SVC, method="sigmoid", ensemble=False)`` in float64:
    kernel values, one-against-one decision values, scikit-learn's one-against-rest
    transform (more than 2 classes), Platt's sigmoid per class and the normalisation."""
    (cc,) = calibrated.calibrated_classifiers_
    svc = cc.estimator
    sv = np.asarray(svc.support_vectors_, np.float64)
    if svc.kernel == "linear":
        kernel = g.op("MatMul", [z, g.const("sv_t", sv.T.copy())], "kernel")
    else:  # exp(-gamma |z - sv|^2) = exp(-gamma (|z|^2 - 2 z.sv + |sv|^2))
        zz = g.op("ReduceSum", [g.op("Mul", [z, z]),
                                g.const("axis1", np.array([1], np.int64))], "zz", keepdims=1)
        cross = g.op("MatMul", [z, g.const("sv_t", (-2.0 * sv).T.copy())], "cross")
        d2 = g.op("Add", [g.op("Add", [zz, cross]),
                          g.const("sv_sq", (sv ** 2).sum(axis=1)[None, :])], "d2")
        d2 = g.op("Max", [d2, g.const("zero", np.zeros((1, 1)))], "d2_pos")
        kernel = g.op("Exp", [g.op("Mul", [d2, g.const("neg_gamma",
                                                       np.array([[-svc._gamma]]))])],
                      "kernel")
    coef = _ovo_coefficients(np.asarray(svc.dual_coef_, np.float64),
                             np.asarray(svc.n_support_))
    dec = g.op("Add", [g.op("MatMul", [kernel, g.const("ovo_coef", coef)]),
                       g.const("ovo_intercept", np.asarray(svc.intercept_,
                                                           np.float64)[None, :])], "ovo")
    k = len(svc.classes_)
    if k > 2:  # sklearn's _ovr_decision_function(dec < 0, -dec, k)
        pairs = [(i, j) for i in range(k) for j in range(i + 1, k)]
        to_i, to_j = np.zeros((len(pairs), k)), np.zeros((len(pairs), k))
        for p, (i, j) in enumerate(pairs):
            to_i[p, i], to_j[p, j] = 1.0, 1.0
        from onnx import TensorProto

        neg = g.op("Cast", [g.op("Less", [dec, g.const("zero_d", np.zeros((1, 1)))])],
                   "neg", to=TensorProto.DOUBLE)
        pos = g.op("Sub", [g.const("one_d", np.ones((1, 1))), neg], "pos")
        votes = g.op("Add", [g.op("MatMul", [pos, g.const("to_i", to_i)]),
                             g.op("MatMul", [neg, g.const("to_j", to_j)])], "votes")
        conf = g.op("MatMul", [dec, g.const("conf", to_i - to_j)], "conf")
        denom = g.op("Mul", [g.op("Add", [g.op("Abs", [conf]),
                                          g.const("one_c", np.ones((1, 1)))]),
                             g.const("three", np.full((1, 1), 3.0))])
        dec = g.op("Add", [votes, g.op("Div", [conf, denom])], "ovr")
    a = np.array([c.a_ for c in cc.calibrators], np.float64)[None, :]
    b = np.array([c.b_ for c in cc.calibrators], np.float64)[None, :]
    calib = g.op("Sigmoid", [g.op("Neg", [g.op("Add", [g.op("Mul", [dec, g.const("platt_a", a)]),
                                                       g.const("platt_b", b)])])], "platt")
    if k == 2:
        p0 = g.op("Sub", [g.const("one_p", np.ones((1, 1))), calib], "p0")
        return g.op("Concat", [p0, calib], "probabilities", axis=1)
    total = g.op("ReduceSum", [calib, g.const("axis1_p", np.array([1], np.int64))], "total",
                 keepdims=1)
    # the all-zero case (every sigmoid underflows) is uniform in scikit-learn
    zero = g.op("Equal", [total, g.const("zero_t", np.zeros((1, 1)))], "all_zero")
    safe = g.op("Where", [zero, g.const("one_t", np.ones((1, 1))), total], "total_safe")
    return g.op("Where", [zero, g.const("uniform", np.full((1, k), 1.0 / k)),
                          g.op("Div", [calib, safe])], "probabilities")


def classic_graph(estimator: Any, family: str, *, n_samples: int, n_channels: int,
                  input_kind: str, features: Sequence[str], mean: np.ndarray,
                  scale: np.ndarray, n_inputs: int, input_name: str = "window",
                  output_name: str = "probabilities") -> bytes:
    """The whole stored model (module docstring) as serialised ONNX: ``input_name`` (B, W, C)
    float32 normalised windows -> ``output_name`` (B, n_classes) float64 probabilities."""
    import onnx
    from onnx import TensorProto, helper

    g = _Graph()
    inputs = feature_nodes(g, input_name, n_samples=n_samples, n_channels=n_channels,
                           input_kind=input_kind, features=features)
    z = standardise_nodes(g, inputs, mean, scale)
    ir_version = None
    if family == "logistic":
        model = _skl2onnx_model(estimator, n_inputs, float32=False)
        probs = _append_model(g, model, z, "logistic_")
        ir_version = model.ir_version
    elif family == "random_forest":  # scikit-learn's trees compare float32 inputs
        model = _skl2onnx_model(estimator, n_inputs, float32=True)
        z32 = g.op("Cast", [z], "z32", to=TensorProto.FLOAT)
        probs = _append_model(g, model, z32, "forest_")
        ir_version = model.ir_version
    elif family == "hist_gb":
        probs = hist_gb_nodes(g, z, estimator)
    elif family == "svm":
        probs = svm_nodes(g, z, estimator)
    else:
        raise ValueError(f"`family` (={family!r}) is not a classic family")
    g.nodes.append(helper.make_node("Cast", [probs], [output_name], name=output_name,
                                    to=TensorProto.DOUBLE))
    graph = helper.make_graph(
        g.nodes, f"tactile_{family}",
        [helper.make_tensor_value_info(input_name, TensorProto.FLOAT,
                                       ["batch", n_samples, n_channels])],
        [helper.make_tensor_value_info(output_name, TensorProto.DOUBLE, ["batch", None])],
        g.inits)
    model = helper.make_model(graph, opset_imports=[helper.make_opsetid("", OPSET),
                                                    helper.make_opsetid("ai.onnx.ml",
                                                                        ML_OPSET)],
                              producer_name="tactile")
    model.ir_version = ir_version or 8
    onnx.checker.check_model(model)
    return model.SerializeToString()


def inputs_graph(*, n_samples: int, n_channels: int, input_kind: str,
                 features: Sequence[str]) -> bytes:
    """The graph of step 1 alone: ``window`` -> ``inputs`` (B, F) float64; the training
    computes the estimator's inputs with it, so that they are those the stored graph
    computes, to the last bit."""
    from onnx import TensorProto, helper

    g = _Graph()
    out = feature_nodes(g, "window", n_samples=n_samples, n_channels=n_channels,
                        input_kind=input_kind, features=features)
    g.nodes.append(_identity(out, "inputs"))
    graph = helper.make_graph(
        g.nodes, "tactile_inputs",
        [helper.make_tensor_value_info("window", TensorProto.FLOAT,
                                       ["batch", n_samples, n_channels])],
        [helper.make_tensor_value_info("inputs", TensorProto.DOUBLE, ["batch", None])],
        g.inits)
    model = helper.make_model(graph, opset_imports=[helper.make_opsetid("", OPSET)],
                              producer_name="tactile")
    model.ir_version = 8
    return model.SerializeToString()


def deployed_graph(stored: bytes, *, transform: str, normalise: bool, mean: np.ndarray,
                   std: np.ndarray, window_norm: str, output_name: str,
                   input_name: str = "window") -> Any:
    """The export of a classic run: the stored graph behind the preprocessing of
    :class:`.export.DeployedModel` (``signed_log1p``, the per-channel normalisation in
    float64, the cast to float32, ``center_scale``), so that it takes raw windows in sensor
    units; its output renamed ``output_name``. Returns the ModelProto."""
    import onnx
    from onnx import TensorProto, compose, helper

    model = compose.add_prefix(onnx.load_from_string(stored), "model_")
    (inner,) = model.graph.input
    (result,) = model.graph.output
    n_samples, n_channels = (d.dim_value for d in inner.type.tensor_type.shape.dim[1:])
    g = _Graph()
    y = g.op("Cast", [input_name], "raw64", to=TensorProto.DOUBLE)
    if transform == "signed_log1p":  # sign(y) log(1 + |y|); ONNX has no log1p
        log = g.op("Log", [g.op("Add", [g.op("Abs", [y]), g.const("one", np.ones(1))])])
        y = g.op("Mul", [g.op("Sign", [y]), log], "log1p")
    elif transform != "none":
        raise ValueError(f"`transform` (={transform!r}) must be none or signed_log1p")
    if normalise:
        y = g.op("Div", [g.op("Sub", [y, g.const("channel_mean", np.asarray(mean, np.float64))]),
                         g.const("channel_std", np.asarray(std, np.float64))], "normalised")
    z = g.op("Cast", [y], "normalised32", to=TensorProto.FLOAT)
    if window_norm == "center_scale":  # as .data.center_scale: a constant channel gives 0
        hi = g.op("ReduceMax", [z], "hi", axes=[1], keepdims=1)
        varies = g.op("Greater", [hi, g.op("ReduceMin", [z], "lo", axes=[1], keepdims=1)])
        zc = g.op("Sub", [z, g.op("ReduceMean", [z], "centre", axes=[1], keepdims=1)])
        peak = g.op("ReduceMax", [g.op("Abs", [zc])], "peak", axes=[1], keepdims=1)
        zero = g.const("zero32", np.zeros(1, np.float32))
        ok = g.op("And", [varies, g.op("Greater", [peak, zero])], "ok")
        safe = g.op("Where", [ok, peak, g.const("one32", np.ones(1, np.float32))])
        z = g.op("Where", [ok, g.op("Div", [zc, safe]), zero], "scaled")
    elif window_norm != "none":
        raise ValueError(f"`window_norm` (={window_norm!r}) must be none or center_scale")
    g.nodes.append(_identity(z, inner.name))
    g.nodes.extend(model.graph.node)
    g.inits.extend(model.graph.initializer)
    g.nodes.append(_identity(result.name, output_name))
    graph = helper.make_graph(
        g.nodes, model.graph.name,
        [helper.make_tensor_value_info(input_name, TensorProto.FLOAT,
                                       ["batch", n_samples, n_channels])],
        [helper.make_tensor_value_info(output_name, TensorProto.DOUBLE, ["batch", None])],
        g.inits)
    out = helper.make_model(graph, opset_imports=list(model.opset_import),
                            producer_name="tactile")
    out.ir_version = model.ir_version
    onnx.checker.check_model(out)
    return out


def session(model: bytes, *, threads: int = 1) -> Any:
    """An onnxruntime session of serialised ``model`` on the CPU, ``threads`` intra-op
    threads and one inter-op thread."""
    import onnxruntime as ort

    opts = ort.SessionOptions()
    opts.intra_op_num_threads = int(threads)
    opts.inter_op_num_threads = 1
    opts.log_severity_level = 3
    return ort.InferenceSession(model, opts, providers=["CPUExecutionProvider"])


def run_graph(sess: Any, windows: np.ndarray, *, batch_size: int = 8192) -> np.ndarray:
    """The graph's one output for (n, W, C) windows, in batches; (n, k) float64."""
    name = sess.get_inputs()[0].name
    parts = [sess.run(None, {name: np.ascontiguousarray(windows[lo:lo + batch_size],
                                                         dtype=np.float32)})[0]
             for lo in range(0, windows.shape[0], batch_size)]
    if not parts:
        return np.zeros((0, 0))
    return np.concatenate(parts).astype(np.float64)


__all__ = ["MAX_CONVERSION_DIFF", "ML_OPSET", "OPSET", "classic_graph", "deployed_graph",
           "feature_nodes",
           "hist_gb_nodes", "inputs_graph", "quiet", "run_graph", "session",
           "standardise_nodes", "svm_nodes"]
