"""`tactile fit-fos FILE...`: several HDF5 files fitted one task per file on Dask (issue 18):
the same fits as one file at a time, a damaged file named on one line while the others are
written, a restart that skips what is done."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import h5py
import numpy as np
import pytest
from typer.testing import CliRunner

from tactile_cli.cli import app

from ..factories.fos_counts import use_test_compilation_cache, write_counts_file

runner = CliRunner()


@pytest.fixture(scope="module", autouse=True)
def _compilation_cache():
    use_test_compilation_cache()


@pytest.fixture()
def files(tmp_path: Path) -> list[Path]:
    paths = []
    for seed in (3, 4):
        path = tmp_path / f"rec{seed}.h5"
        write_counts_file(path, n_trials=6, seed=seed)
        paths.append(path)
    return paths


def _columns(path: Path, group: str) -> dict[str, np.ndarray]:
    with h5py.File(path, "r") as f:
        g = f[f"/derived/fits/{group}"]
        return {k: g[k][()] for k in g if isinstance(g[k], h5py.Dataset)}


@pytest.mark.slow
def test_many_files_on_a_worker_equal_one_at_a_time_and_restart_skips(files, tmp_path):
    # the reference: each file fitted on its own, in this process
    single = []
    for path in files:
        copy = tmp_path / "single" / path.name
        copy.parent.mkdir(exist_ok=True)
        shutil.copyfile(path, copy)
        res = runner.invoke(app, ["fit-fos", str(copy)])
        assert res.exit_code == 0, res.output
        single.append(copy)
    bad = tmp_path / "broken.h5"
    bad.write_bytes(b"not an HDF5 file\n")

    res = runner.invoke(app, ["fit-fos", *map(str, files), str(bad), "--workers", "1",
                              "--json"])
    assert res.exit_code == 2, res.output
    out = json.loads(res.stdout)
    assert out["counts"] == {"ok": 2, "skipped": 0, "failed": 1}
    failed = [i for i in out["items"] if i["status"] == "failed"]
    assert failed[0]["input"] == str(bad) and "broken.h5" in failed[0]["error"]
    assert "\n" not in failed[0]["error"]
    assert f"{bad}: failed: " in res.stderr
    for item in out["items"][:2]:
        assert item["value"]["summary"]["press"]["n_trials"] == 6
        assert len(item["value"]["records"]["press"]) == 6
    for path, ref in zip(files, single, strict=True):
        for group in ("fos_press", "fos_slip"):
            got, want = _columns(path, group), _columns(ref, group)
            assert sorted(got) == sorted(want)
            for key in want:
                np.testing.assert_array_equal(got[key], want[key], err_msg=f"{group}/{key}")

    # started again: the fitted files are skipped, the damaged one fails again
    res = runner.invoke(app, ["fit-fos", *map(str, files), str(bad), "--workers", "0"])
    assert res.exit_code == 2, res.output
    assert "0 ok, 2 skipped (up to date), 1 failed" in res.stdout
    assert "1 to fit, 2 up to date (skipped)" in res.stderr
    # other settings are not "up to date": the existing groups are refused without
    # --overwrite, one line per file, and replaced with it
    res = runner.invoke(app, ["fit-fos", *map(str, files), "--workers", "0", "--no-order"])
    assert res.exit_code == 2, res.output
    assert res.stderr.count("--overwrite") == 2
    res = runner.invoke(app, ["fit-fos", *map(str, files), "--workers", "0", "--no-order",
                              "--overwrite"])
    assert res.exit_code == 0, res.output
    assert "2 ok, 0 skipped (up to date), 0 failed" in res.stdout


@pytest.mark.slow
def test_many_files_refuse_single_file_options(files, tmp_path):
    res = runner.invoke(app, ["fit-fos", *map(str, files), "--csv", str(tmp_path / "t.csv")])
    assert res.exit_code == 2
    assert "--csv goes with one HDF5 file" in res.stderr
    # a glob that matched one file: a batch of one
    res = runner.invoke(app, ["fit-fos", str(files[0]), "--workers", "0", "--no-order",
                              "--overwrite"])
    assert res.exit_code == 0, res.output
    assert "1 ok, 0 skipped (up to date), 0 failed" in res.stdout
    curve = tmp_path / "c.csv"
    curve.write_text("t_s,x\n0,0\n0.1,1\n0.2,1.5\n0.3,1.8\n0.4,1.9\n")
    res = runner.invoke(app, ["fit-fos", str(curve), "--model", "step", "--workers", "2"])
    assert res.exit_code == 2
    assert "--scheduler and --workers go with tactile HDF5 files" in res.stderr
    res = runner.invoke(app, ["fit-fos", str(files[0]), str(files[0])])
    assert res.exit_code == 2
    assert "given twice" in res.stderr
