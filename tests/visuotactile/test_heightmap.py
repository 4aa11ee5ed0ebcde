"""Height maps of a frames file: `tactile heightmap`, RMSE against the truth, the stream."""

from __future__ import annotations

import json
from pathlib import Path

import h5py
import numpy as np
import pytest
from typer.testing import CliRunner

from tactile_cli.cli import app
from tactile_cli.errors import InputError
from tactile_cli.store.trials import TactileFile
from tactile_cli.visuotactile.heightmap import (
    HeightMapper,
    heightmap_file,
    read_height_maps,
)
from tactile_cli.visuotactile.normals import NormalModel
from tactile_cli.visuotactile.slip import slip_signal_file
from tests.factories.gel_frames import make_frames_file, normal_run

pytest.importorskip("torch")
runner = CliRunner()


@pytest.fixture(scope="module")
def scene(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    base = tmp_path_factory.mktemp("heightmap")
    frames = base / "frames.h5"
    truth = make_frames_file(frames, n_trials=2, n_frames=40)
    tdir = base / "truth"
    tdir.mkdir()
    for name, h in truth.items():
        np.savez_compressed(tdir / f"{name}.npz", height_mm=h)
    no_scale = base / "no_scale.h5"
    make_frames_file(no_scale, n_trials=1, n_frames=3, onset_frame=1, px_per_mm=None)
    run = normal_run(tmp_path_factory.getbasetemp() / "normal_runs")
    return {"frames": frames, "truth": tdir, "run": run, "no_scale": no_scale, "base": base}


def test_heightmap_file_rmse_and_stream(scene: dict[str, Path], tmp_path: Path) -> None:
    out = tmp_path / "h.h5"
    keep: dict[str, np.ndarray] = {}
    res = heightmap_file(scene["frames"], scene["run"], out, truth_dir=scene["truth"],
                         keep=keep)
    # a 3-epoch network: peaks within 10 % of 0.4 mm, RMSE a few hundredths of a mm
    assert res.rmse_mm is not None and res.rmse_mm < 0.04
    for t in res.trials:
        assert t.peak_mm == pytest.approx(0.4, rel=0.1)
    with TactileFile(out) as tf:
        assert tf.trial_names == ["t_00", "t_01"]
        h, t_s, ppm = read_height_maps(tf.trial("t_00"))
        assert h.shape == (40, 48, 64) and ppm == 20.0
        np.testing.assert_array_equal(h, keep["t_00"])
        assert tf.trial("t_00").labels["slip"] == "slip"
        assert [s.path for s in tf.sources][1].endswith("model.pt")
    # the stream feeds the slip signal
    slip = slip_signal_file(out, mesh=(16, 12))
    assert slip.trials[0].source == "height" and slip.rates["height"].detection_rate == 1.0


def test_both_sources_side_by_side_from_frames(scene: dict[str, Path]) -> None:
    res = slip_signal_file(scene["frames"], source="both", run_dir=scene["run"], mesh=(16, 12))
    assert [(t.trial, t.source) for t in res.trials] == [
        ("t_00", "height"), ("t_00", "intensity"), ("t_01", "height"), ("t_01", "intensity")]
    assert set(res.rates) == {"height", "intensity"}
    assert res.rates["height"].detection_rate == 1.0
    assert res.as_dict(with_signal=False)["summary"]["height"]["n_slip"] == 1


def test_heights_and_slip_signal_are_the_same_bits_for_any_worker_count(
        scene: dict[str, Path], tmp_path: Path) -> None:
    """Issue 30: the network's tiles and the FFTs give the same bits for any ``workers``,
    so the stored heights and the slip signal on them do too."""
    heights = {}
    for workers in (1, 2, 3):
        keep: dict[str, np.ndarray] = {}
        heightmap_file(scene["frames"], scene["run"], tmp_path / f"h{workers}.h5",
                       trials=["t_00"], workers=workers, keep=keep)
        heights[workers] = keep["t_00"]
    np.testing.assert_array_equal(heights[2], heights[1])
    np.testing.assert_array_equal(heights[3], heights[1])
    signals = [slip_signal_file(scene["frames"], source="height", run_dir=scene["run"],
                                mesh=(16, 12), trials=["t_01"], workers=workers
                                ).trials[0].detection.signal for workers in (1, 2)]
    np.testing.assert_array_equal(signals[1], signals[0])
    assert np.isfinite(signals[0][1:]).all() and signals[0][1:].max() > 0
    blocks = slip_signal_file(scene["frames"], source="height", run_dir=scene["run"],
                              mesh=(16, 12), trials=["t_01"], stride=2
                              ).trials[0].detection.signal
    assert blocks.shape == signals[0].shape and np.isfinite(blocks[1:]).all()
    assert np.corrcoef(blocks[1:], signals[0][1:])[0, 1] > 0.9
    with pytest.raises(InputError, match="`stride`"):
        slip_signal_file(scene["frames"], source="height", run_dir=scene["run"], stride=0)


def test_mapper_skip_below_zero_is_exact(scene: dict[str, Path]) -> None:
    model = NormalModel.from_run(scene["run"])
    with TactileFile(scene["frames"]) as tf:
        fr = tf.trial("t_00").frames()
        frame, ref = fr[10], fr.reference
    full = HeightMapper(model, 20.0)(frame, ref)
    skip0 = HeightMapper(model, 20.0, skip_below=0.0)(frame, ref)
    np.testing.assert_allclose(skip0, full, atol=1e-5)
    flat = HeightMapper(model, 20.0, skip_below=256.0)(frame, ref)
    assert np.abs(flat).max() == 0.0


@pytest.mark.slow
def test_cli(scene: dict[str, Path], tmp_path: Path) -> None:
    out = tmp_path / "h.h5"
    res = runner.invoke(app, ["heightmap", str(scene["frames"]), "--model", str(scene["run"]),
                              "--out", str(out), "--truth", str(scene["truth"]), "--json",
                              "--trial", "t_01", "--plot", str(tmp_path / "fig")])
    assert res.exit_code == 0, res.output
    d = json.loads(res.output)
    assert [t["trial"] for t in d["trials"]] == ["t_01"] and d["rmse_mm"] < 0.04
    assert (tmp_path / "fig" / "height_t_01.png").stat().st_size > 0
    assert runner.invoke(app, ["validate", str(out)]).exit_code == 0
    again = runner.invoke(app, ["heightmap", str(scene["frames"]), "--model",
                                str(scene["run"]), "--out", str(out)])
    assert again.exit_code == 2 and "--overwrite" in again.output
    assert runner.invoke(app, ["heightmap", "--help"]).exit_code == 0


def test_errors(scene: dict[str, Path], tmp_path: Path) -> None:
    res = runner.invoke(app, ["heightmap", str(scene["no_scale"]), "--model",
                              str(scene["run"]), "--out", str(tmp_path / "x.h5")])
    assert res.exit_code == 2 and "--px-per-mm" in res.output
    assert not (tmp_path / "x.h5").exists()
    bad_truth = tmp_path / "truth"
    bad_truth.mkdir()
    np.savez_compressed(bad_truth / "t_00.npz", height_mm=np.zeros((3, 4, 5), np.float32))
    with pytest.raises(InputError, match="shape"):
        heightmap_file(scene["frames"], scene["run"], tmp_path / "y.h5", truth_dir=bad_truth)
    assert not (tmp_path / "y.h5").exists()
    with pytest.raises(InputError, match="not a run folder"):
        heightmap_file(scene["frames"], tmp_path, tmp_path / "z.h5")


@pytest.mark.parametrize("damage", ["empty", "truncated", "nan"])
def test_a_damaged_truth_file_is_one_input_error(scene: dict[str, Path], tmp_path: Path,
                                                 damage: str) -> None:
    """Found by the damaged-input corpus: an empty .npz gave click's `Aborted.` (EOFError),
    a cut one a BadZipFile traceback, NaN heights a TypeError when the RMSE was printed."""
    from tactile_cli.visuotactile.heightmap import load_truth

    src = scene["truth"] / "t_00.npz"
    bad = tmp_path / "t_00.npz"
    with np.load(src) as z:
        heights = z["height_mm"]
    if damage == "empty":
        bad.write_bytes(b"")
    elif damage == "truncated":
        bad.write_bytes(src.read_bytes()[: src.stat().st_size // 2])
    else:
        np.savez(bad, height_mm=heights * np.nan)
    with pytest.raises(InputError) as err:
        load_truth(tmp_path, "t_00", heights.shape)
    assert str(bad) in str(err.value) and "\n" not in str(err.value)


def test_a_text_px_per_mm_attribute_is_one_input_error(scene: dict[str, Path],
                                                       tmp_path: Path) -> None:
    """Found by the damaged-input corpus: px_per_mm = 'wide' ended in a ValueError."""
    import shutil

    import h5py

    from tactile_cli.visuotactile.heightmap import frames_px_per_mm

    bad = tmp_path / "f.h5"
    shutil.copyfile(scene["frames"], bad)
    with h5py.File(bad, "r+") as f:
        f["sensors/digit"].attrs["px_per_mm"] = "wide"
    with TactileFile(bad) as tf, pytest.raises(InputError, match="px_per_mm is 'wide'"):
        frames_px_per_mm(tf, tf.trial("t_00"), None)


def test_blocks_average_the_colour_and_interpolate_the_heights(scene: dict[str, Path]) -> None:
    """Issue 35, item 6 (camera rate): ``stride`` k runs the network on k x k block means
    at the blocks' centres, solves on the block grid and interpolates back to every pixel;
    a size that is not a multiple of k is extended by its last row and column."""
    model = NormalModel.from_run(scene["run"])
    rng = np.random.default_rng(4)
    frame = rng.integers(0, 256, (7, 10, 3), dtype=np.uint8)
    ref = rng.integers(0, 256, (7, 10, 3), dtype=np.uint8)
    colour, grid = model._block_colour(frame, ref, 3)
    assert grid == (3, 4)
    d = np.pad(frame.astype(np.float64) - ref, ((0, 2), (0, 2), (0, 0)), mode="edge")
    want = d.reshape(3, 3, 4, 3, 3).mean(axis=(1, 3)).reshape(-1, 3)
    np.testing.assert_allclose(colour, want, atol=1e-5)
    pos = model._positions(3, 4, 3)
    np.testing.assert_array_equal(pos[:5], [[1, 1, 1], [4, 1, 1], [7, 1, 1], [10, 1, 1],
                                            [1, 4, 1]])
    # back to pixels: bilinear between block centres, exact on a plane, held at the edges
    mapper = HeightMapper(model, 20.0, stride=2)
    yy, xx = np.mgrid[0:5, 0:6].astype(np.float32)
    plane = 0.5 * yy + 2.0 * xx  # heights at the block centres (2 r + 0.5, 2 c + 0.5)
    fine = mapper._to_pixels(plane, (10, 12))
    py, px = np.mgrid[0:10, 0:12]
    cy = np.clip((py + 0.5) / 2 - 0.5, 0, 4)
    cx = np.clip((px + 0.5) / 2 - 0.5, 0, 5)
    np.testing.assert_allclose(fine, 0.5 * cy + 2.0 * cx, atol=1e-5)
    assert fine.dtype == np.float32


def test_block_heights_follow_every_pixel_heights(scene: dict[str, Path]) -> None:
    """On the factory's ball presses, heights from 2 x 2 blocks stay close to those of
    every pixel (the press is many blocks wide), and the solve runs on the block grid."""
    model = NormalModel.from_run(scene["run"])
    with TactileFile(scene["frames"]) as tf:
        fr = tf.trial("t_00").frames()
        frames, ref = [fr[k] for k in (10, 20, 30)], fr.reference
    full = HeightMapper(model, 20.0)
    blocks = HeightMapper(model, 20.0, stride=2)
    for frame in frames:
        a, b = full(frame, ref), blocks(frame, ref)
        assert b.shape == a.shape == frame.shape[:2]
        assert np.sqrt(np.mean((a - b) ** 2)) < 0.1 * np.abs(a).max()
        assert abs(float(b.max()) - float(a.max())) < 0.15 * float(a.max())
    assert set(blocks._solvers) == {(-(-frame.shape[0] // 2), -(-frame.shape[1] // 2))}
    with pytest.raises(InputError, match="`stride`"):
        HeightMapper(model, 20.0, stride=0)
    with pytest.raises(InputError, match="cannot be combined"):
        HeightMapper(model, 20.0, stride=2, skip_below=2.0)


def test_cli_stride_is_recorded_and_checked(scene: dict[str, Path], tmp_path: Path) -> None:
    out = tmp_path / "h2.h5"
    res = runner.invoke(app, ["heightmap", str(scene["frames"]), "--model", str(scene["run"]),
                              "--out", str(out), "--trial", "t_01", "--stride", "2",
                              "--no-progress"])
    assert res.exit_code == 0, res.output
    with h5py.File(out, "r") as f:
        assert json.loads(f.attrs["config_json"])["stride"] == 2
    with TactileFile(out) as tf:
        maps, _, _ = read_height_maps(tf.trial("t_01"))
    assert maps.shape[1:] == (48, 64)
    bad = runner.invoke(app, ["heightmap", str(scene["frames"]), "--model", str(scene["run"]),
                              "--out", str(tmp_path / "h3.h5"), "--stride", "2",
                              "--skip-below", "2"])
    assert bad.exit_code == 2
    assert "--skip-below and --stride > 1 cannot be combined" in bad.output
    assert not (tmp_path / "h3.h5").exists()
    wide = runner.invoke(app, ["heightmap", str(scene["frames"]), "--model", str(scene["run"]),
                               "--out", str(tmp_path / "h4.h5"), "--stride", "40"])
    assert wide.exit_code == 2
    assert "--stride (=40) must be a whole number of pixels from 1 to 16" in wide.output
    assert "Traceback" not in wide.output and not (tmp_path / "h4.h5").exists()
