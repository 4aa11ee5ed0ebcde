"""`tactile accel-prepare FILE... --out-dir FOLDER`: one prepared file per input on Dask
(issue 18): outputs equal to one-file runs, a bad input named while the others are written,
a restart that skips what is up to date."""

from __future__ import annotations

import json
import os
import shutil
from pathlib import Path

import pytest
from typer.testing import CliRunner

from tactile_cli.accel import VibroSceneConfig, simulate_vibro_slip
from tactile_cli.cli import app
from tactile_cli.ingest import ingest

from ..ingest.test_ingest_out_dir import h5_differences

runner = CliRunner()


@pytest.mark.slow
def test_out_dir_equals_one_file_runs_and_restart_skips(tmp_path: Path):
    cfg = VibroSceneConfig.model_validate({"orientations_deg": [0], "motor_rps": [0.16],
                                           "duration_s": 1.0})
    simulate_vibro_slip(cfg, tmp_path / "scene", seed=0)
    first = tmp_path / "a.h5"
    ingest([tmp_path / "scene"], first, format="accel-tree")
    second = tmp_path / "b.h5"
    shutil.copyfile(first, second)
    bad = tmp_path / "c.h5"
    bad.write_text("not HDF5\n")
    single = tmp_path / "single.h5"
    res = runner.invoke(app, ["accel-prepare", str(first), "--out", str(single),
                              "--segment-s", "0.5", "--no-progress"])
    assert res.exit_code == 0, res.output

    out = tmp_path / "prepared"
    res = runner.invoke(app, ["accel-prepare", str(first), str(second), str(bad), "--out-dir",
                              str(out), "--segment-s", "0.5", "--workers", "1", "--json"])
    assert res.exit_code == 2, res.output
    got = json.loads(res.stdout)
    assert got["counts"] == {"ok": 2, "skipped": 0, "failed": 1}
    assert f"{bad}: failed: " in res.stderr and "Traceback" not in res.output
    assert sorted(p.name for p in out.iterdir()) == ["a.h5", "b.h5"]  # nothing half-written
    assert got["items"][0]["value"]["n_segments"] == 6
    assert h5_differences(single, out / "a.h5", {"created_utc", "command"}) == []

    later = os.path.getmtime(out / "b.h5") + 10
    os.utime(second, (later, later))
    res = runner.invoke(app, ["accel-prepare", str(first), str(second), "--out-dir", str(out),
                              "--segment-s", "0.5", "--workers", "0"])
    assert res.exit_code == 0, res.output
    assert "1 to prepare, 1 up to date (skipped)" in res.stderr
    assert "1 ok, 1 skipped (up to date), 0 failed" in res.stdout


def test_out_or_out_dir(tmp_path: Path):
    res = runner.invoke(app, ["accel-prepare", str(tmp_path / "x.h5")])
    assert res.exit_code == 2 and "give --out FILE (one input) or --out-dir" in res.stderr
    x = tmp_path / "x.h5"
    x.write_text("")
    res = runner.invoke(app, ["accel-prepare", str(x), str(x), "--out", str(tmp_path / "o.h5")])
    assert res.exit_code == 2 and "--out takes one input" in res.stderr
