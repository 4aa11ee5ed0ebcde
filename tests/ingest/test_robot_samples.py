"""The shipped robot samples (`tactile samples`) and the worked mapping in configs/: the
sample recordings of every container ingest with configs/rosbag_tactile_rig.yaml into the
same streams, and the press they simulate comes out."""

from __future__ import annotations

from pathlib import Path

import h5py
import numpy as np
import pytest

from tactile_cli.ingest import ingest
from tactile_cli.samples.robot import (
    HEADER_LAG_NS,
    RIG_MAPPING,
    press_force_n,
    write_mcap,
    write_ros1_bag,
    write_ros2_bag,
)

CONFIG = Path(__file__).resolve().parents[2] / "configs" / "rosbag_tactile_rig.yaml"


def test_the_config_is_the_samples_mapping():
    assert CONFIG.read_text() == RIG_MAPPING


@pytest.mark.parametrize("container", ["ros1", "ros2", "mcap"])
def test_samples_ingest_with_the_worked_mapping(tmp_path, container):
    kw = {"seconds": 0.5, "n_trials": 2, "array_hz": 100.0, "size_hw": (12, 16)}
    path = {"ros1": lambda: write_ros1_bag(tmp_path / "p.bag", **kw),
            "ros2": lambda: write_ros2_bag(tmp_path / "p2", **kw),
            "mcap": lambda: write_mcap(tmp_path / "p.mcap", **kw)}[container]()
    out = ingest([path], tmp_path / "o.h5", options={"mapping": CONFIG})
    with h5py.File(out) as h5:
        assert list(h5["trials"]) == ["press_1", "press_2"]
        trial = h5["trials/press_1"]
        assert dict(trial["labels"].attrs) == {"origin": "synthetic",
                                              "dataset": "tactile-samples"}
        assert trial["frames/images"].shape == (15, 12, 16, 3)
        assert trial["signals/taxels/data"].shape == (50, 16)
        wrench = trial["signals/wrench"]
        # header stamps: log time (1.2 ms after each 10 ms tick) - the 1 ms lag
        np.testing.assert_allclose(wrench["t_s"][:], np.arange(50) * 0.01 + 0.0002, atol=1e-12)
        log_s = wrench["t_s"][:] + HEADER_LAG_NS / 1e9
        np.testing.assert_allclose(-wrench["data"][:, 2], press_force_n(log_s), atol=0.1)
        assert h5["sensors/wrench"].attrs["serial"] == "FT-SIM-0001"
