"""Issue 35, item 4: a normal-network run records the unit, frame size and scale it was
calibrated on; `heightmap`, `slip-signal --source height` and `monitor` refuse another
frame size in one line and warn on another unit; `tactile info RUN` shows it."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from typer.testing import CliRunner

from tactile_cli.cli import app
from tactile_cli.store import StoreWriter
from tactile_cli.store.trials import TactileFile
from tactile_cli.visuotactile.sensor_unit import SensorCalibration, check_frames
from tests.factories.gel_frames import PX_PER_MM, make_frames_file, normal_run, shade

pytest.importorskip("torch")
runner = CliRunner()


@pytest.fixture(scope="module")
def run(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return normal_run(tmp_path_factory.getbasetemp() / "normal_runs")


def test_the_run_records_its_unit_and_info_shows_it(run: Path) -> None:
    info = json.loads((run / "run.json").read_text())
    assert info["sensor_unit"] == {"unit": "digit", "unit_from": "sensor name",
                                   "width_px": 64, "height_px": 48, "px_per_mm": PX_PER_MM}
    res = runner.invoke(app, ["info", str(run)])
    assert res.exit_code == 0, res.output
    assert "sensor unit: 'digit' (sensor name), frames 64x48 px, px_per_mm 20" in res.output
    res = runner.invoke(app, ["info", str(run), "--json"])
    assert json.loads(res.output)["sensor_unit"]["width_px"] == 64


def _frames(path: Path, shape: tuple[int, int], unit: str | None = None) -> Path:
    import numpy as np

    rng = np.random.default_rng(0)
    with StoreWriter(path, command="test") as wr:
        s = wr.add_sensor("digit", kind="visuotactile", sample_rate_hz=30.0,
                          width_px=shape[1], height_px=shape[0], px_per_mm=PX_PER_MM)
        ref = shade(np.zeros(shape), noise_std=1.0, rng=rng)
        labels = {} if unit is None else {"sensor_id": unit}
        t = wr.trial("t_00", labels=labels)
        t.write_frames(sensor=s, images=np.stack([ref] * 6), t_s=np.arange(6) / 30.0,
                       reference=ref)
        wr.commit()
    return path


def test_another_frame_size_is_refused_in_one_line(run: Path, tmp_path: Path) -> None:
    frames = _frames(tmp_path / "big.h5", (40, 64))
    want = (f"tactile: error: {frames}, /trials/t_00: frames are 64x40 px but the normal "
            f"model {run} was calibrated on 64x48 px frames (unit 'digit'); calibrate on "
            "frames of this size")
    for args in (["heightmap", str(frames), "--model", str(run), "--out",
                  str(tmp_path / "h.h5")],
                 ["slip-signal", str(frames), "--source", "height", "--model", str(run),
                  "--n-static", "2"],
                 ["monitor", str(frames), "--source", "height", "--model", str(run),
                  "--plot", str(tmp_path / "mon")]):
        res = runner.invoke(app, args)
        assert res.exit_code == 2, (args[0], res.output)
        assert res.output.strip().splitlines() == [want], args[0]
    assert not (tmp_path / "h.h5").exists() and not (tmp_path / "mon").exists()


def test_another_unit_is_a_warning(run: Path, tmp_path: Path) -> None:
    frames = _frames(tmp_path / "other.h5", (48, 64), unit="D20417")
    res = runner.invoke(app, ["heightmap", str(frames), "--model", str(run), "--out",
                              str(tmp_path / "h.h5")])
    assert res.exit_code == 0, res.output
    assert ("warning: frames come from unit 'D20417' (label sensor_id) but the normal model "
            f"{run} was calibrated on unit 'digit'") in res.output
    res = runner.invoke(app, ["slip-signal", str(frames), "--source", "height", "--model",
                              str(run), "--n-static", "2", "--json"])
    assert res.exit_code == 0, res.output
    assert "D20417" in json.loads(res.output)["warnings"][0]
    same = tmp_path / "same.h5"
    make_frames_file(same, n_trials=1, n_frames=4, onset_frame=2)
    res = runner.invoke(app, ["heightmap", str(same), "--model", str(run), "--out",
                              str(tmp_path / "h2.h5")])
    assert res.exit_code == 0 and "warning: " not in res.output


def test_check_frames_scale_and_unrecorded_runs(tmp_path: Path) -> None:
    frames = _frames(tmp_path / "f.h5", (48, 64))
    cal = SensorCalibration("digit", "sensor name", 64, 48, 10.0)
    assert SensorCalibration.from_dict(cal.as_dict()) == cal
    with TactileFile(frames) as tf:
        warn = check_frames(cal, tf, tf.trial("t_00"), run="R", px_per_mm=PX_PER_MM)
        assert warn == ["frames have px_per_mm 20 but the normal model R was calibrated at "
                        "10: heights scale with it"]
        old = check_frames(None, tf, tf.trial("t_00"), run="R", px_per_mm=PX_PER_MM)
        assert len(old) == 1 and "records no sensor unit" in old[0]
