"""The built wheel carries its schema: install it alone and run `tactile validate`.

A peer's wheel once shipped without its schema files and its validator crashed; this
builds the wheel, installs it (without dependencies, which come from the test
environment) into a fresh folder and runs the installed console script from there.
"""

from __future__ import annotations

import os
import subprocess
import sys
import zipfile
from pathlib import Path

import numpy as np
import pytest

from tactile_cli.store import StoreWriter

REPO = Path(__file__).resolve().parents[1]


@pytest.mark.slow
def test_installed_wheel_validates_a_file(tmp_path):
    wheels = tmp_path / "wheels"
    subprocess.run(
        [
            sys.executable,
            "-m",
            "pip",
            "wheel",
            str(REPO),
            "--no-deps",
            "--no-build-isolation",
            "-w",
            str(wheels),
            "-q",
        ],
        check=True,
        capture_output=True,
    )
    (wheel,) = wheels.glob("tactile_cli-*.whl")
    names = zipfile.ZipFile(wheel).namelist()
    assert "tactile_cli/data_schemas/tactile-h5-v1.json" in names

    site = tmp_path / "site"
    subprocess.run(
        [
            sys.executable,
            "-m",
            "pip",
            "install",
            "--no-deps",
            "--target",
            str(site),
            str(wheel),
            "-q",
        ],
        check=True,
        capture_output=True,
    )
    f = tmp_path / "a.h5"
    with StoreWriter(f, command="test") as w:
        s = w.add_sensor(
            "acc", kind="accelerometer", sample_rate_hz=10, channel_names=["a"], channel_units="g"
        )
        w.trial("t").write_signal("acc", sensor=s, data=np.zeros((5, 1)), t_s=np.arange(5) / 10)
        w.commit()
    env = {**os.environ, "PYTHONPATH": str(site)}
    where = subprocess.run(
        [sys.executable, "-c", "import tactile_cli; print(tactile_cli.__file__)"],
        env=env,
        capture_output=True,
        text=True,
        check=True,
        cwd=tmp_path,
    )
    assert where.stdout.strip().startswith(str(site)), (
        "the wheel's package must be the one imported"
    )
    result = subprocess.run(
        [str(site / "bin" / "tactile"), "validate", str(f)],
        env=env,
        capture_output=True,
        text=True,
        cwd=tmp_path,
    )
    assert result.returncode == 0, result.stderr
    from tactile_cli.store import load_spec

    assert f"valid (schema {load_spec().version})" in result.stdout
