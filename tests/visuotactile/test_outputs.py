"""The visuotactile commands on absurd numbers and damaged frames, and their outputs
(issue 33): frame times that are all 0 (the monitor reported 12 slips) or a trial of 0
frames are one error; a gel scale of 1e308 px/mm (all-zero heights) and a ball radius of
1e308 mm (flat labels) are refused; --workers bounds the BLAS and OpenMP threads; an
interrupted --overwrite keeps the previous output byte-identical."""

from __future__ import annotations

import shutil
from pathlib import Path

import h5py
import pytest
from typer.testing import CliRunner

from tactile_cli import interrupt
from tactile_cli.cli import app
from tactile_cli.errors import InputError
from tests.factories.gel_frames import make_frames_file, normal_run

runner = CliRunner()


@pytest.fixture(autouse=True)
def _no_interrupt_left():
    yield
    interrupt.clear()


@pytest.fixture(scope="module")
def frames(tmp_path_factory) -> Path:
    path = tmp_path_factory.mktemp("frames") / "frames.h5"
    make_frames_file(path, n_trials=2, n_frames=12, onset_frame=8)
    return path


def _one_error_line(res, *words: str) -> str:
    assert res.exit_code == 2, res.output
    lines = res.stderr.strip().splitlines()
    assert len(lines) == 1 and "Traceback" not in res.output, res.output
    for word in words:
        assert word in lines[0], lines[0]
    return lines[0]


def _tree(folder: Path) -> dict[str, bytes]:
    return {str(p.relative_to(folder)): p.read_bytes() for p in folder.rglob("*")
            if p.is_file()}


def test_frame_times_all_zero_are_refused_not_replayed(frames: Path, tmp_path: Path):
    damaged = tmp_path / "zeros.h5"
    shutil.copyfile(frames, damaged)
    with h5py.File(damaged, "r+") as f:
        for name in f["trials"]:
            f["trials"][name]["frames"]["t_s"][...] = 0.0
    for args in (["monitor", str(damaged), "--n-static", "3"],
                 ["slip-signal", str(damaged), "--n-static", "3", "--source", "intensity"]):
        res = runner.invoke(app, [*args, "--no-progress"])
        line = _one_error_line(res)
        assert "frame times are not finite and strictly increasing" in line


@pytest.mark.slow
def test_monitor_interrupted_overwrite_keeps_the_earlier_plots(frames: Path, tmp_path: Path,
                                                               monkeypatch):
    from tactile_cli.visuotactile import monitor_replay

    out = tmp_path / "figs"
    args = ["monitor", str(frames), "--n-static", "3", "--plot", str(out), "--no-progress"]
    assert runner.invoke(app, args).exit_code == 0
    before = _tree(out)
    assert sorted(before) == ["t_00.png", "t_01.png"]
    real = monitor_replay.plot_trial

    def ctrl_c(*a, **k):
        interrupt.request()
        return real(*a, **k)

    monkeypatch.setattr(monitor_replay, "plot_trial", ctrl_c)
    res = runner.invoke(app, [*args, "--overwrite"])
    assert res.exit_code == 130, res.output
    assert _tree(out) == before
    assert sorted(p.name for p in tmp_path.iterdir()) == ["figs"]


def test_check_px_per_mm_bounds_the_gel_scale():
    from tactile_cli.visuotactile.heightmap import check_px_per_mm

    assert check_px_per_mm(16) == 16.0
    for bad in (1e308, 0.0, -1.0, float("nan"), float("inf"), True, "16"):
        with pytest.raises(InputError, match="gel scale from 0.001 to 10000"):
            check_px_per_mm(bad)


@pytest.fixture(scope="module")
def run(tmp_path_factory) -> Path:
    return normal_run(tmp_path_factory.getbasetemp() / "normal_runs")


def test_heightmap_refuses_an_absurd_scale_and_a_trial_of_0_frames(frames, run, tmp_path):
    res = runner.invoke(app, ["heightmap", str(frames), "--model", str(run), "--out",
                              str(tmp_path / "h.h5"), "--px-per-mm", "1e308", "--no-progress"])
    _one_error_line(res, "--px-per-mm (=1e+308) must be a gel scale")
    empty = tmp_path / "empty.h5"
    shutil.copyfile(frames, empty)
    with h5py.File(empty, "r+") as f:
        g = f["trials"]["t_00"]["frames"]
        for name in ("images", "t_s"):
            data = g[name][:0]
            del g[name]
            g.create_dataset(name, data=data, maxshape=(None, *data.shape[1:]))
    res = runner.invoke(app, ["heightmap", str(empty), "--model", str(run), "--out",
                              str(tmp_path / "h.h5"), "--no-progress"])
    _one_error_line(res, "t_00")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["empty.h5"]


@pytest.mark.parametrize("workers", [1, 2])
def test_heightmap_workers_bound_the_blas_threads(frames, run, tmp_path, monkeypatch, workers):
    from threadpoolctl import threadpool_info

    from tactile_cli.visuotactile.heightmap import HeightMapper

    seen: list[int] = []
    real = HeightMapper.__call__

    def spy(self, frame, reference):
        seen.extend(i["num_threads"] for i in threadpool_info())
        return real(self, frame, reference)

    monkeypatch.setattr(HeightMapper, "__call__", spy)
    res = runner.invoke(app, ["heightmap", str(frames), "--model", str(run), "--trial", "t_00",
                              "--workers", str(workers), "--out", str(tmp_path / "h.h5"),
                              "--no-progress"])
    assert res.exit_code == 0, res.output
    assert seen and max(seen) <= workers


def test_heightmap_interrupted_overwrite_keeps_the_earlier_file(frames, run, tmp_path,
                                                                monkeypatch):
    from tactile_cli.visuotactile import heightmap

    out = tmp_path / "h.h5"
    args = ["heightmap", str(frames), "--model", str(run), "--trial", "t_00", "--out",
            str(out), "--workers", "1", "--no-progress"]
    assert runner.invoke(app, args).exit_code == 0
    before = out.read_bytes()
    real = heightmap.trial_heights

    def ctrl_c(*a, **k):
        interrupt.request()
        return real(*a, **k)

    monkeypatch.setattr(heightmap, "trial_heights", ctrl_c)
    res = runner.invoke(app, [*args, "--overwrite"])
    assert res.exit_code == 130, res.output
    assert out.read_bytes() == before
    assert sorted(p.name for p in tmp_path.iterdir()) == ["h.h5"]


def test_a_ball_radius_of_1e308_labels_nothing(tmp_path):
    from tests.visuotactile.test_calibrate import _calibration_file

    calib = _calibration_file(tmp_path, 3, 1)
    with h5py.File(calib, "r+") as f:
        for name in f["trials"]:
            f["trials"][name]["labels"].attrs["ball_radius_mm"] = 1e308
    res = runner.invoke(app, ["normal-labels", str(calib), "--out", str(tmp_path / "p.h5"),
                              "--no-progress"])
    _one_error_line(res, "under 2 % of the ball radius 1e+308 mm")
    assert not (tmp_path / "p.h5").exists()
