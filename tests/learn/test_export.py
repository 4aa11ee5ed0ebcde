"""`tactile export` (issue 19): every family's exported model gives `tactile evaluate`'s
outputs on the same windows, runs without the package, and bad input writes no file."""

from __future__ import annotations

import json
import subprocess
import sys
import textwrap

import numpy as np
import pytest
from typer.testing import CliRunner

from tactile_cli.cli import app
from tactile_cli.errors import InputError
from tactile_cli.learn import export as ex
from tactile_cli.learn.data import make_windows, read_trials
from tactile_cli.learn.evaluate import evaluate
from tactile_cli.learn.runs import load_run
from tactile_cli.learn.train import train

from .conftest import tiny_config

#: family -> (model section, data changes): each run tiny (window 20, 3 epochs), the
#: multi-head one with a regression head, a trial-level head and per-window center_scale.
RUNS = {
    "lstm": ({"family": "lstm", "hidden": 8}, {}),
    "cnn1d": ({"family": "cnn1d", "channels": [4, 4], "kernel": 3}, {}),
    "cnn2d_spectrogram": ({"family": "cnn2d_spectrogram", "n_fft": 8, "hop": 2,
                           "channels": [4]}, {}),
    "fnn": ({"family": "fnn", "hidden": [8]}, {"pad": "edge"}),
    "mlp": ({"family": "mlp", "hidden": [8]}, {}),
    # issue 34: per-trial baseline removal, per-window z-score and level-free features
    "mlp_drift": ({"family": "mlp", "hidden": [8],
                   "features": ["std", "range", "diff_std", "skew", "kurtosis"]},
                  {"window_norm": "zscore", "baseline": {"mode": "start", "duration_ms": 100}}),
    "multihead": ({"family": "cnn1d", "channels": [4], "kernel": 3}, {
        "window_norm": "center_scale", "targets": [
            {"name": "action"},
            {"name": "force_level", "source": "trial", "kind": "regression"},
            {"name": "force_grade", "source": "trial"}]}),
}


@pytest.fixture(scope="module")
def trained(tmp_path_factory, action_file):
    root = tmp_path_factory.mktemp("export_runs")
    out = {}
    for name, (model, data) in RUNS.items():
        cfg = tiny_config(model=model, data=data, optim={"epochs": 3})
        train(cfg, [action_file], root / name, command="tests")
        out[name] = root / name
    return out


@pytest.fixture(scope="module")
def exported(trained, tmp_path_factory):
    """name -> the ONNX file of each run."""
    root = tmp_path_factory.mktemp("exported")
    return {name: ex.export_run(run, root / f"{name}.onnx", command="tests").path
            for name, run in trained.items()}


def _windows(run_dir, data_file):
    """The normalised evaluation windows, the same windows raw, and the package's outputs."""
    run = load_run(run_dir)
    trials = read_trials([data_file], run.config.data, trained=True)
    ws = make_windows(trials, run.config.data, run.heads, run.normalisation)
    mine = ex.package_outputs(run.load_model(), ws, run.heads, run.normalisation.targets)
    return run, ex.raw_windows(trials, run), mine


@pytest.mark.slow
@pytest.mark.parametrize("name", list(RUNS))
def test_onnx_matches_the_package_outputs(name, trained, exported, heldout_file):
    run, raw, mine = _windows(trained[name], heldout_file)
    theirs = ex.ExportedModel(exported[name])(raw)
    assert list(theirs) == ex.output_names(run.heads)
    for key in mine:
        assert theirs[key].shape == mine[key].shape
        np.testing.assert_allclose(theirs[key], mine[key], rtol=0, atol=1e-5, err_msg=key)
    side = json.loads(ex.sidecar_path(exported[name]).read_text())
    assert side["input"]["shape"] == [None, 20, 1] and side["input"]["channels"] == ["net"]
    assert side["input"]["sample_period_s"] == pytest.approx(0.02)
    assert side["model"]["family"] == run.config.model.family
    assert side["outputs"][0]["labels"] == list(run.heads[0].classes)


def test_multihead_outputs_are_probabilities_and_label_values(trained, exported, heldout_file):
    run, raw, _ = _windows(trained["multihead"], heldout_file)
    out = ex.ExportedModel(exported["multihead"])(raw[:50])
    np.testing.assert_allclose(out["action.probabilities"].sum(axis=1), 1.0, atol=1e-6)
    assert out["force_grade.probabilities"].shape[1] == len(run.heads[2].classes)
    assert 0 < float(np.median(out["force_level.value"])) < 13  # levels 1..12, in level units


def _run_fresh(script: str, *args: str) -> None:
    proc = subprocess.run([sys.executable, "-c", textwrap.dedent(script), *args],
                          capture_output=True, text=True, timeout=120)
    assert proc.returncode == 0, proc.stderr


def test_onnx_runs_in_a_fresh_process_without_tactile(trained, exported, heldout_file,
                                                      tmp_path):
    _, raw, mine = _windows(trained["multihead"], heldout_file)
    np.save(tmp_path / "raw.npy", raw)
    _run_fresh("""
        import json, sys
        import numpy as np
        import onnxruntime as ort
        model, raw, out = sys.argv[1:]
        side = json.load(open(model + ".json"))
        sess = ort.InferenceSession(model, providers=["CPUExecutionProvider"])
        ys = sess.run(None, {side["input"]["name"]: np.load(raw)})
        np.savez(out, **{o["name"]: y for o, y in zip(side["outputs"], ys)})
        assert not any(m.startswith("tactile_cli") for m in sys.modules)
    """, str(exported["multihead"]), str(tmp_path / "raw.npy"), str(tmp_path / "out.npz"))
    theirs = np.load(tmp_path / "out.npz")
    for key in mine:
        np.testing.assert_allclose(theirs[key], mine[key], rtol=0, atol=1e-5, err_msg=key)


@pytest.mark.slow
def test_torchscript_runs_in_a_fresh_process_without_tactile(trained, heldout_file, tmp_path):
    res = ex.export_run(trained["multihead"], tmp_path / "m.pt", format="torchscript",
                        command="tests")
    _, raw, mine = _windows(trained["multihead"], heldout_file)
    np.save(tmp_path / "raw.npy", raw)
    _run_fresh("""
        import sys, warnings
        import numpy as np
        import torch
        warnings.simplefilter("ignore")
        model, raw, out = sys.argv[1:]
        m = torch.jit.load(model)
        with torch.inference_mode():
            ys = m(torch.from_numpy(np.load(raw)))
        np.savez(out, *[y.numpy() for y in ys])
        assert not any(m.startswith("tactile_cli") for m in sys.modules)
    """, str(res.path), str(tmp_path / "raw.npy"), str(tmp_path / "out.npz"))
    theirs = np.load(tmp_path / "out.npz")
    for i, key in enumerate(mine):
        np.testing.assert_allclose(theirs[f"arr_{i}"], mine[key], rtol=0, atol=1e-5)


def test_existing_output_is_refused_unless_overwrite(trained, exported):
    before = exported["lstm"].read_bytes()
    with pytest.raises(InputError, match="overwrite=True") as err:
        ex.export_run(trained["lstm"], exported["lstm"])
    assert str(exported["lstm"]) in str(err.value)
    assert exported["lstm"].read_bytes() == before


def test_existing_sidecar_alone_is_refused(trained, tmp_path):
    ex.sidecar_path(tmp_path / "m.onnx").write_text("{}")
    with pytest.raises(InputError, match="m.onnx.json"):
        ex.export_run(trained["fnn"], tmp_path / "m.onnx")
    assert not (tmp_path / "m.onnx").exists()


def test_damaged_or_foreign_run_folder_writes_nothing(trained, tmp_path):
    import shutil

    run = tmp_path / "run"
    shutil.copytree(trained["fnn"], run)
    info = json.loads((run / "run.json").read_text())
    (run / "run.json").write_text(json.dumps({**info, "format_version": 99}))
    with pytest.raises(InputError, match="format version 99"):
        ex.export_run(run, tmp_path / "m.onnx")
    (run / "run.json").write_text(json.dumps(info))
    (run / "model.pt").write_bytes(b"not a model")
    with pytest.raises(InputError, match="model.pt"):
        ex.export_run(run, tmp_path / "m.onnx")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["run"]


def test_family_the_format_cannot_carry_is_refused_by_name(trained, tmp_path, monkeypatch):
    monkeypatch.setitem(ex.EXPORTABLE, "onnx", frozenset({"fnn"}))
    with pytest.raises(InputError, match="the lstm family cannot be exported to onnx"):
        ex.export_run(trained["lstm"], tmp_path / "m.onnx")
    assert list(tmp_path.iterdir()) == []


def test_exporter_failure_is_one_line_and_leaves_no_file(trained, tmp_path, monkeypatch):
    def broken(*args, **kwargs):
        raise RuntimeError("unsupported operator aten::weird\nlong traceback")

    monkeypatch.setattr("torch.onnx.export", broken)
    with pytest.raises(InputError, match="fnn family could not be exported") as err:
        ex.export_run(trained["fnn"], tmp_path / "m.onnx")
    assert "\n" not in str(err.value)
    assert list(tmp_path.iterdir()) == []


def test_evaluate_with_exported_records_its_latency_and_difference(trained, exported,
                                                                   heldout_file, tmp_path):
    from tactile_cli.learn.runs import read_metrics

    res = evaluate(trained["mlp"], [heldout_file], exported=exported["mlp"], name="exp",
                   command="tests")
    rec = read_metrics(res.out_dir / "metrics.json")["exported"]
    assert rec["format"] == "onnx" and rec["max_abs_diff"] <= 1e-5
    assert rec["latency"]["batch1_ms_median"] > 0
    with pytest.raises(InputError, match="another run"):
        evaluate(trained["fnn"], [heldout_file], exported=exported["mlp"], name="exp2",
                 latency=False)
    lone = tmp_path / "lone.onnx"
    lone.write_bytes(exported["mlp"].read_bytes())
    with pytest.raises(InputError, match="no sidecar lone.onnx.json"):
        evaluate(trained["mlp"], [heldout_file], exported=lone, name="exp3", latency=False)
    assert not (trained["mlp"] / "eval" / "exp3").exists()


@pytest.mark.slow
def test_cli_export_evaluate_and_compare_show_the_exported_model(trained, heldout_file,
                                                                tmp_path):
    runner = CliRunner()
    env = {"COLUMNS": "200"}
    assert runner.invoke(app, ["export", "--help"], env=env).exit_code == 0
    out = tmp_path / "model.onnx"
    res = runner.invoke(app, ["export", str(trained["fnn"]), "--out", str(out)], env=env)
    assert res.exit_code == 0, res.output
    assert "wrote" in res.output and out.is_file() and ex.sidecar_path(out).is_file()
    again = runner.invoke(app, ["export", str(trained["fnn"]), "--out", str(out)], env=env)
    assert again.exit_code == 2
    line = again.stderr.strip()
    assert line.startswith("tactile: error:") and "\n" not in line
    assert str(out) in line and "--overwrite" in line
    bad = runner.invoke(app, ["export", str(trained["fnn"]), "--out", str(tmp_path / "x.bin"),
                              "--format", "tflite"], env=env)
    assert bad.exit_code == 2 and "--format" in bad.stderr and not (tmp_path / "x.bin").exists()
    assert runner.invoke(app, ["export", str(trained["fnn"]), "--out", str(out),
                               "--overwrite", "--json"], env=env).exit_code == 0

    evaluated = runner.invoke(app, ["evaluate", str(trained["fnn"]), "--data",
                                    str(heldout_file), "--exported", str(out), "--name", "x"],
                              env=env)
    assert evaluated.exit_code == 0, evaluated.output
    assert "onnxruntime" in evaluated.output and "model.onnx" in evaluated.output
    evaluate(trained["lstm"], [heldout_file], name="x", command="tests")
    cmp = runner.invoke(app, ["compare", str(trained["fnn"]), str(trained["lstm"]),
                              "--data-name", "x", "--out", str(tmp_path / "c")], env=env)
    assert cmp.exit_code == 0, cmp.output
    assert "exported ms" in cmp.output
    rows = json.loads((tmp_path / "c" / "compare.json").read_text())["table"]
    assert [r["exported_latency_ms"] is not None for r in rows].count(True) == 1


def _readme_snippet() -> str:
    from pathlib import Path

    page = Path(__file__).resolve().parents[2] / "docs" / "how-to" / "export-onnx.md"
    text = page.read_text(encoding="utf-8")
    section = text[text.index("## On the robot"):]
    start = section.index("```python\n") + len("```python\n")
    return section[start:section.index("```", start)]


def test_readme_snippet_classifies_a_csv_window_without_tactile(trained, exported,
                                                                 heldout_file, tmp_path):
    import shutil

    snippet = _readme_snippet()
    assert len(snippet.strip().splitlines()) < 20 and "tactile" not in snippet
    run, raw, mine = _windows(trained["multihead"], heldout_file)
    shutil.copy(exported["multihead"], tmp_path / "lstm.onnx")
    shutil.copy(ex.sidecar_path(exported["multihead"]), tmp_path / "lstm.onnx.json")
    k = len(raw) // 2
    t_s = np.arange(30) * 0.02  # an extra column and 10 older rows the snippet must skip
    net = np.concatenate([np.full(10, 99.0), raw[k][:, 0]])
    np.savetxt(tmp_path / "window.csv", np.stack([t_s, net], axis=1), delimiter=",",
               header="t_s,net", comments="")
    proc = subprocess.run([sys.executable, "-c", snippet + "\nimport sys\n"
                           "assert not any(m.startswith('tactile_cli') for m in sys.modules)"],
                          capture_output=True, text=True, timeout=120, cwd=tmp_path)
    assert proc.returncode == 0, proc.stderr
    lines = dict(line.split(" ", 1) for line in proc.stdout.strip().splitlines())
    want = run.heads[0].classes[int(mine["action.probabilities"][k].argmax())]
    assert lines["action"].split()[0] == want
    assert float(lines["force_level"]) == pytest.approx(mine["force_level.value"][k], abs=1e-4)


def test_sidecar_says_what_the_caller_subtracts_for_a_baseline_run(exported):
    side = json.loads(ex.sidecar_path(exported["mlp_drift"]).read_text())
    assert side["preprocessing"]["baseline"] == {"mode": "start", "duration_ms": 100.0,
                                                 "inside_model": False}
    assert side["preprocessing"]["window_norm"] == "zscore"
    assert "subtract the mean of the trial's first 100 ms, per channel, from every sample" \
        in side["input"]["note"]
    plain = json.loads(ex.sidecar_path(exported["mlp"]).read_text())
    assert plain["preprocessing"]["baseline"]["mode"] == "none"
    assert "resting level" not in plain["input"]["note"]
