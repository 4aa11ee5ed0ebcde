"""The taxel commands: simulate taxel-slip, slip-interface, features spectral."""

from __future__ import annotations

import json

import pytest
from typer.testing import CliRunner

from tactile_cli.cli import app

runner = CliRunner()


def test_help_of_every_taxel_command():
    for args in (["simulate", "taxel-slip"], ["slip-interface"], ["features", "spectral"],
                 ["features"]):
        res = runner.invoke(app, [*args, "--help"])
        assert res.exit_code == 0, res.output
        assert "Usage" in res.output


@pytest.mark.slow
def test_simulate_then_classify_then_features(tmp_path):
    scene = tmp_path / "scene.h5"
    res = runner.invoke(app, ["simulate", "taxel-slip", "--out", str(scene), "--preset",
                              "capacitive", "--trials", "10", "--seed", "102", "--json"])
    assert res.exit_code == 0, res.output
    assert json.loads(res.output)["trials"] == {"capacitive": {"hand": 10, "world": 10}}
    fig, summary = tmp_path / "fig12.png", tmp_path / "si.json"
    res = runner.invoke(app, ["slip-interface", str(scene), "--folds", "5", "--json",
                              "--plot", str(fig), "--out", str(summary)])
    assert res.exit_code == 0, res.output
    table = json.loads(res.output)
    assert table["n_combinations"] == 3 and table["folds"] == 5
    assert fig.stat().st_size > 10_000
    record = json.loads(summary.read_text())["provenance"]
    assert record["command"] and record["inputs"][0]["sha256"]
    feats = tmp_path / "features.h5"
    res = runner.invoke(app, ["features", "spectral", str(scene), "--out", str(feats)])
    assert res.exit_code == 0, res.output
    assert "20 trial(s)" in res.output
    res = runner.invoke(app, ["features", "spectral", str(scene), "--out", str(feats)])
    assert res.exit_code == 2 and "--overwrite" in res.output


@pytest.mark.slow
def test_bad_inputs_are_one_line_errors(tmp_path, taxel_file):
    res = runner.invoke(app, ["slip-interface", str(tmp_path / "none.h5")])
    assert res.exit_code == 2 and "tactile: error:" in res.output
    assert len(res.output.strip().splitlines()) == 1
    res = runner.invoke(app, ["simulate", "taxel-slip", "--out", str(tmp_path / "x.h5"),
                              "--preset", "glove"])
    assert res.exit_code == 2 and "glove" in res.output
    cfg = tmp_path / "bad.yaml"
    cfg.write_text("folds: 10\nwindow: 3\n")
    res = runner.invoke(app, ["slip-interface", str(taxel_file), "--config", str(cfg)])
    assert res.exit_code == 2 and "window" in res.output
    assert len(res.output.strip().splitlines()) == 1


@pytest.mark.slow
def test_reversed_bands_and_unknown_slip_labels_are_one_line_errors(tmp_path):
    """Found by the damaged-input corpus: a band [300, 10] was accepted, and `features
    spectral` met a slip label other than hand or world as a ValueError traceback."""
    import shutil

    import h5py

    scene = tmp_path / "s.h5"
    res = runner.invoke(app, ["simulate", "taxel-slip", "--out", str(scene), "--preset",
                              "pvdf", "--trials", "2", "--no-progress"])
    assert res.exit_code == 0, res.output
    cfg = tmp_path / "bands.yaml"
    cfg.write_text("bands_hz:\n  pvdf: {low: [300.0, 10.0]}\n")
    res = runner.invoke(app, ["slip-interface", str(scene), "--config", str(cfg)])
    assert res.exit_code == 2 and "bands_hz.pvdf.low" in res.output
    assert len(res.output.strip().splitlines()) == 1
    bad = tmp_path / "bad.h5"
    shutil.copyfile(scene, bad)
    with h5py.File(bad, "r+") as f:
        f[f"trials/{sorted(f['trials'])[0]}/labels"].attrs["slip"] = "sideways"
    for argv in (["features", "spectral", str(bad), "--out", str(tmp_path / "f.h5")],
                 ["slip-interface", str(bad), "--folds", "2"]):
        res = runner.invoke(app, [*argv, "--no-progress"])
        assert res.exit_code == 2 and "sideways" in res.output, res.output
        assert len(res.output.strip().splitlines()) == 1
    assert not (tmp_path / "f.h5").exists()
