"""`tactile ingest INPUT... --out-dir DIR`: one output per input, on Dask (issue 18)."""

from __future__ import annotations

import os
from pathlib import Path

import h5py
import numpy as np
import pytest
from typer.testing import CliRunner

from tactile_cli.cli import app
from tactile_cli.samples import write_events_csv

runner = CliRunner()
GEOMETRY = ["--width", "64", "--height", "48"]
#: root attributes that record how and when a file was made, not its content
PROVENANCE = {"created_utc", "command"}


def h5_differences(a: Path, b: Path, ignore_attrs: set[str] = PROVENANCE) -> list[str]:
    """Where two HDF5 files differ: datasets (dtype, shape, values), groups, attributes."""
    out: list[str] = []
    with h5py.File(a, "r") as fa, h5py.File(b, "r") as fb:
        def walk(ga, gb, path: str) -> None:
            for k in sorted(set(ga.attrs) | set(gb.attrs)):
                if k in ignore_attrs:
                    continue
                if k not in ga.attrs or k not in gb.attrs:
                    out.append(f"{path}@{k} missing")
                elif not np.array_equal(np.asarray(ga.attrs[k]), np.asarray(gb.attrs[k])):
                    out.append(f"{path}@{k}")
            if isinstance(ga, h5py.Dataset):
                if (ga.dtype, ga.shape) != (gb.dtype, gb.shape) or not np.array_equal(ga[()],
                                                                                      gb[()]):
                    out.append(f"{path} data")
                return
            for k in sorted(set(ga) | set(gb)):
                if k not in ga or k not in gb:
                    out.append(f"{path}/{k} missing")
                else:
                    walk(ga[k], gb[k], f"{path.rstrip('/')}/{k}")

        walk(fa, fb, "/")
    return out


@pytest.fixture()
def recordings(tmp_path: Path) -> list[Path]:
    folder = tmp_path / "raw"
    folder.mkdir()
    paths = [folder / f"rec{i}.csv" for i in range(3)]
    for i, path in enumerate(paths):
        write_events_csv(path, 3000, width=64, height=48, seed=i)
    return paths


def _ingest(*args: str | Path):
    return runner.invoke(app, ["ingest", *map(str, args), *GEOMETRY, "--no-progress"])


@pytest.mark.slow
def test_out_dir_on_one_worker_equals_serial_and_restart_skips(recordings, tmp_path: Path):
    serial, dask = tmp_path / "serial", tmp_path / "dask"
    res = _ingest(*recordings, "--out-dir", serial, "--workers", "0")
    assert res.exit_code == 0, res.output
    assert "3 ok, 0 skipped (up to date), 0 failed" in res.stdout
    res = _ingest(*recordings, "--out-dir", dask, "--workers", "1")
    assert res.exit_code == 0, res.output
    names = sorted(p.name for p in dask.iterdir())
    assert names == ["rec0.h5", "rec1.h5", "rec2.h5"]  # no temporaries left
    assert sorted(p.name for p in serial.iterdir()) == names
    for name in names:
        assert h5_differences(serial / name, dask / name) == [], name
    # a restart skips what is up to date, ingests an input that changed since
    os.utime(recordings[1], (os.path.getmtime(dask / "rec1.h5") + 10,) * 2)
    res = _ingest(*recordings, "--out-dir", dask, "--workers", "0")
    assert res.exit_code == 0, res.output
    assert "1 to ingest, 2 up to date (skipped)" in res.stderr
    assert "1 ok, 2 skipped (up to date), 0 failed" in res.stdout
    res = _ingest(*recordings, "--out-dir", dask, "--workers", "0", "--overwrite")
    assert "3 ok, 0 skipped" in res.stdout


@pytest.mark.slow
def test_a_damaged_input_fails_on_one_line_and_the_others_are_written(recordings,
                                                                       tmp_path: Path):
    bad = recordings[0].parent / "bad.csv"
    bad.write_bytes(recordings[0].read_bytes()[:120])  # cut inside a row
    out = tmp_path / "out"
    res = _ingest(*recordings, bad, "--out-dir", out, "--workers", "1")
    assert res.exit_code == 2, res.output
    failed = [line for line in res.stderr.splitlines() if "failed:" in line]
    assert len(failed) == 1 and str(bad) in failed[0] and "line" in failed[0], res.stderr
    assert "3 ok, 0 skipped (up to date), 1 failed" in res.stdout
    assert sorted(p.name for p in out.iterdir()) == ["rec0.h5", "rec1.h5", "rec2.h5"]


@pytest.mark.slow
def test_same_stems_and_out_with_out_dir_are_refused_before_any_work(recordings,
                                                                      tmp_path: Path):
    other = tmp_path / "other"
    other.mkdir()
    twin = other / "rec0.csv"
    twin.write_bytes(recordings[0].read_bytes())
    out = tmp_path / "out"
    res = _ingest(recordings[0], twin, "--out-dir", out, "--workers", "0")
    assert res.exit_code == 2
    assert "rec0.h5" in res.stderr and "--out-dir" in res.stderr and "out_dir" not in res.stderr
    assert not out.exists()
    res = _ingest(*recordings, "--out", tmp_path / "one.h5", "--out-dir", out)
    assert res.exit_code == 2
    assert "--out" in res.stderr and "--out-dir" in res.stderr and "not both" in res.stderr
    res = _ingest(*recordings, "--out", tmp_path / "one.h5", "--workers", "1")
    assert res.exit_code == 2 and "--workers" in res.stderr
    assert not out.exists() and not (tmp_path / "one.h5").exists()
    res = _ingest(*recordings)
    assert res.exit_code == 2 and "--out-dir" in res.stderr
    # --out keeps its meaning: every input into one file
    res = _ingest(*recordings, "--out", tmp_path / "one.h5")
    assert res.exit_code == 0, res.output
    with h5py.File(tmp_path / "one.h5", "r") as f:
        assert sorted(f["trials"]) == ["rec0", "rec1", "rec2"]
