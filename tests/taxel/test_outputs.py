"""`tactile slip-interface` and `features spectral` on damaged or absurd input (issue 33):
a taxel trial whose preset label was lost is refused by name (it was silently dropped, with
divide-by-zero warnings and another verdict); a hop below one sample is refused before the
windows are cut (1e-6 s asked for 2.9 GiB); outputs are never inputs."""

from __future__ import annotations

import shutil
from pathlib import Path

import h5py
import pytest
from typer.testing import CliRunner

from tactile_cli.cli import app

runner = CliRunner()


def _one_error_line(res, *words: str) -> str:
    assert res.exit_code == 2, res.output
    lines = res.stderr.strip().splitlines()
    assert len(lines) == 1 and "Traceback" not in res.output, res.output
    for word in words:
        assert word in lines[0], lines[0]
    return lines[0]


def test_a_trial_without_its_preset_label_is_refused_by_name(taxel_file: Path, tmp_path: Path):
    damaged = tmp_path / "damaged.h5"
    shutil.copyfile(taxel_file, damaged)
    with h5py.File(damaged, "r+") as f:
        name = sorted(f["trials"])[0]
        del f["trials"][name]["labels"].attrs["preset"]
    for args in (["slip-interface", str(damaged), "--folds", "2"],
                 ["features", "spectral", str(damaged), "--out", str(tmp_path / "f.h5")]):
        res = runner.invoke(app, [*args, "--no-progress"])
        _one_error_line(res, f"trial {name!r}", "no trial label preset")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["damaged.h5"]


@pytest.mark.parametrize("hop", ["1e-6", "0.0001"])
def test_a_hop_below_one_sample_is_refused_before_any_window(taxel_file: Path, tmp_path: Path,
                                                            hop: str):
    res = runner.invoke(app, ["features", "spectral", str(taxel_file), "--stream", "pvdf_f0",
                              "--hop-s", hop, "--out", str(tmp_path / "f.h5"),
                              "--no-progress"])
    _one_error_line(res, f"--hop-s (={float(hop):g}) is shorter than one sample of 'pvdf_f0'")
    assert list(tmp_path.iterdir()) == []


def test_windows_beyond_memory_are_refused_with_the_estimate(taxel_file: Path, tmp_path: Path,
                                                            monkeypatch):
    from tactile_cli import config_file

    monkeypatch.setattr(config_file, "machine_memory_bytes", lambda: 1 << 20)
    res = runner.invoke(app, ["features", "spectral", str(taxel_file), "--stream", "pvdf_f0",
                              "--out", str(tmp_path / "f.h5"), "--no-progress"])
    line = _one_error_line(res, "--hop-s (=0.25) with --window-s (=1) needs about")
    assert "this machine has" in line


@pytest.mark.parametrize("args", [
    ["slip-interface", "{f}", "--out", "{f}", "--overwrite"],
    ["slip-interface", "{f}", "--plot", "{f}", "--overwrite"],
    ["slip-interface", "{f}", "--config", "{c}", "--out", "{c}", "--overwrite"],
    ["features", "spectral", "{f}", "--out", "{f}", "--overwrite"],
    ["features", "spectral", "{f}", "--config", "{c}", "--out", "{c}", "--overwrite"],
])
def test_outputs_are_never_inputs(taxel_file: Path, tmp_path: Path, args):
    f = tmp_path / "scene.h5"
    shutil.copyfile(taxel_file, f)
    c = tmp_path / "features.yaml"
    c.write_text("folds: 2\n")
    before = (f.read_bytes(), c.read_bytes())
    res = runner.invoke(app, [a.format(f=f, c=c) for a in args] + ["--no-progress"])
    _one_error_line(res, "is the input")
    assert (f.read_bytes(), c.read_bytes()) == before
