"""Issue 34, item 3: the classic families (logistic regression, random forest, histogram
gradient boosting, SVM) through train / evaluate / export / --cv, stored as ONNX.

Known truth: the stored graph must give scikit-learn's own probabilities (the estimator is
refitted here on the same inputs, and the conversion is checked against it), the export
must give the in-process model's outputs, and a run must not depend on thread counts.
"""

from __future__ import annotations

import json
import os

import numpy as np
import onnx
import pytest
import torch

from tactile_cli.errors import InputError
from tactile_cli.learn import classic, export
from tactile_cli.learn.classic_onnx import (
    MAX_CONVERSION_DIFF,
    classic_graph,
    inputs_graph,
    run_graph,
    session,
)
from tactile_cli.learn.config import parse_config
from tactile_cli.learn.cv import evaluate_cv, train_cv
from tactile_cli.learn.data import make_windows, read_trials, summary_features
from tactile_cli.learn.evaluate import evaluate
from tactile_cli.learn.runs import load_run
from tactile_cli.learn.train import train

from .conftest import tiny_config

MODELS = {
    "logistic": {"family": "logistic"},
    "random_forest": {"family": "random_forest", "trees": 15},
    "hist_gb": {"family": "hist_gb", "max_iter": 20},
    "svm": {"family": "svm", "kernel": "rbf", "c": 3.0},
}
RUN_FILES = {"run.json", "config.resolved.yaml", "model.onnx", "normalisation.json",
             "history.csv", "curves.png", "split.csv"}


@pytest.fixture(scope="module")
def runs(tmp_path_factory, action_file):
    root = tmp_path_factory.mktemp("classic_runs")
    out = {}
    for family, model in MODELS.items():
        train(tiny_config(model=model), [action_file], root / family, command="tests")
        out[family] = root / family
    return out


@pytest.mark.slow
def test_a_classic_run_folder_is_a_run_folder_with_onnx_and_no_pickle(runs):
    for family, run in runs.items():
        assert set(os.listdir(run)) == RUN_FILES, family
        for name in RUN_FILES:  # no pickle anywhere (pickle protocol 2+ starts with 0x80)
            assert not (run / name).read_bytes().startswith(b"\x80"), (family, name)
        onnx.checker.check_model(onnx.load(str(run / "model.onnx")))
        info = json.loads((run / "run.json").read_text())
        assert info["model"]["family"] == family and info["model"]["format"] == "onnx"
        assert 0 <= info["model"]["conversion_max_abs_diff"] <= MAX_CONVERSION_DIFF
        assert info["model"]["n_params"] > 0 and info["versions"]["skl2onnx"]
        assert info["training"]["best_epoch"] == 1
        assert load_run(run).weights_path == run / "model.onnx"


def test_the_inputs_graph_computes_the_summary_features():
    rng = np.random.default_rng(0)
    windows = rng.standard_normal((50, 7, 3)).astype(np.float32)
    names = ["mean", "std", "min", "max", "last", "slope"]
    graph = session(inputs_graph(n_samples=7, n_channels=3, input_kind="features",
                                 features=names))
    want = summary_features(windows.astype(np.float64), names)  # float32 out: compare so
    np.testing.assert_allclose(run_graph(graph, windows), want, atol=1e-6)
    raw = session(inputs_graph(n_samples=7, n_channels=3, input_kind="raw", features=[]))
    np.testing.assert_array_equal(run_graph(raw, windows), windows.reshape(50, 21))


@pytest.mark.parametrize("n_classes", [2, 3])
@pytest.mark.parametrize("family", list(MODELS))
def test_the_stored_graph_gives_scikit_learns_probabilities(family, n_classes):
    rng = np.random.default_rng(n_classes)
    w, c = 4, 3
    windows = np.round(rng.standard_normal((400, w, c)), 1).astype(np.float32)  # ties
    names = ["mean", "std", "last"]
    x = run_graph(session(inputs_graph(n_samples=w, n_channels=c, input_kind="features",
                                       features=names)), windows)
    mean, scale = x[:300].mean(axis=0), x[:300].std(axis=0)
    z = (x - mean) / scale
    y = np.digitize(z[:, 0] + 0.5 * z[:, 4] ** 2, [0.5] if n_classes == 2 else [0.0, 1.0])
    cfg = parse_config({"data": {"stream": "s", "channels": ["a", "b", "c"], "window": w,
                                 "targets": [{"name": "y"}]},
                        "model": {**MODELS[family], "features": names}})
    est = classic.build_estimator(cfg)
    classic._fit(est, z[:300], y[:300], None, family)  # on one thread, as training does
    graph = classic_graph(est, family, n_samples=w, n_channels=c, input_kind="features",
                          features=names, mean=mean, scale=scale, n_inputs=x.shape[1])
    p = run_graph(session(graph), windows)
    np.testing.assert_allclose(p, est.predict_proba(z), atol=MAX_CONVERSION_DIFF, rtol=0)
    np.testing.assert_array_equal(p.argmax(axis=1), est.predict_proba(z).argmax(axis=1))


@pytest.mark.slow
def test_export_gives_the_in_process_outputs_on_held_out_windows(runs, heldout_file,
                                                                 tmp_path):
    for family, run in runs.items():
        out = export.export_run(run, tmp_path / f"{family}.onnx", command="tests")
        assert out.outputs == ["action.probabilities"]
        result = evaluate(run, [heldout_file], command="tests", exported=out.path,
                          name="exported")
        record = result.extra["exported"]
        assert record["max_abs_diff"] <= 1e-5, family
        assert record["n_windows"] == result.n_windows > 0
        assert record["latency"]["batch1_ms_median"] > 0
        assert result.n_params == json.loads((run / "run.json").read_text())["model"]["n_params"]
        assert result.latency is not None and result.file_size_bytes == \
            (run / "model.onnx").stat().st_size


def test_torchscript_cannot_carry_a_classic_family(runs, tmp_path):
    with pytest.raises(InputError, match="the logistic family cannot be exported to "
                                         "torchscript"):
        export.export_run(runs["logistic"], tmp_path / "m.pt", format="torchscript")
    assert not list(tmp_path.iterdir())


def test_same_seed_same_model_whatever_the_thread_counts(action_file, runs, tmp_path):
    cfg = tiny_config(model=MODELS["random_forest"], optim={"threads": 2})
    train(cfg, [action_file], tmp_path / "rf2", command="tests")
    assert (tmp_path / "rf2" / "model.onnx").read_bytes() == \
        (runs["random_forest"] / "model.onnx").read_bytes()
    run = load_run(runs["hist_gb"])
    trials = read_trials([action_file], run.config.data, trained=True)
    ws = make_windows(trials, run.config.data, run.heads, run.normalisation)
    net = run.load_model()
    previous = torch.get_num_threads()
    try:
        outs = []
        for n in (1, 2):
            torch.set_num_threads(n)
            outs.append(net.probabilities(ws.windows()))
    finally:
        torch.set_num_threads(previous)
    np.testing.assert_array_equal(outs[0], outs[1])


@pytest.mark.slow
def test_cross_validation_of_a_classic_family(action_file, tmp_path):
    cfg = tiny_config(model=MODELS["logistic"], data={"split": {"mode": "random",
                                                                "val_fraction": 0.0}})
    result = train_cv(cfg, [action_file], tmp_path / "cv", k=3, jobs=1, command="tests")
    assert result.n_folds == 3
    metrics = evaluate_cv(tmp_path / "cv", None, latency=False, command="tests")
    assert metrics.family == "logistic" and metrics.cv["n_folds"] == 3
    assert sum(metrics.heads[0].confusion_matrix[i][j] for i in range(4) for j in range(4)) \
        == metrics.n_windows


def test_cross_validation_names_each_fold_whose_trees_could_not_split(action_file, tmp_path):
    cfg = tiny_config(model={"family": "hist_gb", "max_iter": 3, "min_samples_leaf": 100_000},
                      data={"split": {"mode": "random", "val_fraction": 0.0}})
    result = train_cv(cfg, [action_file], tmp_path / "cv", k=2, jobs=1, command="tests")
    said = [w for w in result.warnings if "no tree made a split" in w]
    assert [w.split(":")[0] for w in said] == ["fold 0", "fold 1"]
    assert "model.min_samples_leaf = 100000" in said[0]
    info = json.loads((tmp_path / "cv" / "run.json").read_text())
    assert [len(f["notes"]) for f in info["training"]["folds"]] == [1, 1]


def test_a_damaged_model_onnx_is_one_input_error(runs, heldout_file, tmp_path):
    import shutil

    run = tmp_path / "damaged"
    shutil.copytree(runs["logistic"], run)
    (run / "model.onnx").write_bytes(b"not a model")
    with pytest.raises(InputError, match=r"model.onnx cannot be loaded \(.*the file is "
                                         r"damaged: re-create the run"):
        evaluate(run, [heldout_file], command="tests")
    (run / "model.onnx").unlink()
    with pytest.raises(InputError, match="run folder has no model.onnx"):
        evaluate(run, [heldout_file], command="tests")


@pytest.mark.parametrize(("model", "data", "message"), [
    ({"family": "logistic"}, {"targets": [{"name": "force_level", "source": "trial",
                                           "kind": "regression"}]},
     "model.family logistic predicts one classification target"),
    ({"family": "svm", "input": "raw", "features": ["mean"]}, {},
     "`features` applies to `input: features`"),
    ({"family": "random_forest", "hidden": [8]}, {}, "unknown key `model.hidden`"),
    ({"family": "svm", "gamma": -1.0}, {}, "model.gamma"),
])
def test_config_errors_name_the_key(model, data, message):
    with pytest.raises(InputError, match=message.replace("(", r"\(")):
        tiny_config(model=model, data=data)


def test_a_training_split_of_one_class_is_refused_before_writing(tmp_path):
    est = classic.build_estimator(tiny_config(model=MODELS["logistic"]))
    with pytest.raises(InputError, match="the logistic model cannot be fitted"):
        classic._fit(est, np.zeros((5, 2)), np.zeros(5, np.int64), None, "logistic")


@pytest.mark.parametrize("family", ["hist_gb", "random_forest"])
def test_trees_that_cannot_split_are_named_in_the_fit_notes(family):
    """9 training windows of two classes: boosting's default leaf of 20 windows cannot
    split, and a forest with a leaf of 10 cannot either; both fits say so, and a leaf of 1
    says nothing."""
    rng = np.random.default_rng(0)
    z = rng.standard_normal((9, 6))
    y = np.array([0, 1] * 4 + [1])
    z[y == 1, 0] += 3.0  # separable on the first column

    def notes(extra):
        cfg = parse_config({"data": {"stream": "s", "channels": ["a", "b", "c"], "window": 2,
                                     "targets": [{"name": "y"}]},
                            "model": {**MODELS[family], **extra}})
        est = classic.build_estimator(cfg)
        return est, classic._fit(est, z, y, None, family)

    leaf = 20 if family == "hist_gb" else 10
    est, said = notes({} if family == "hist_gb" else {"min_samples_leaf": 10})
    assert said == [f"{family}: no tree made a split on the 9 training windows (each leaf "
                    f"needs model.min_samples_leaf = {leaf} windows): the model gives every "
                    "window the same probabilities; lower model.min_samples_leaf or train "
                    "on more windows"]
    p = est.predict_proba(z)
    np.testing.assert_allclose(p, p[:1].repeat(len(p), axis=0))
    est, said = notes({"min_samples_leaf": 1})
    assert said == []
    assert np.ptp(est.predict_proba(z)[:, 1]) > 0
