"""NormalModel: numpy inference from a `tactile train` run equals the torch model."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from tactile_cli.errors import InputError
from tactile_cli.visuotactile.normals import NormalModel
from tests.factories.gel_frames import normal_run, shade, sphere_cap

torch = pytest.importorskip("torch")


@pytest.fixture(scope="module")
def runs(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    folder = tmp_path_factory.getbasetemp() / "normal_runs"
    return {"difference": normal_run(folder),
            "absolute": normal_run(folder, channels="x, y, R, G, B")}


def _torch_normals(run_dir: Path, table: np.ndarray) -> np.ndarray:
    """The trained torch model on (n, 5) raw inputs, de-standardised and made unit."""
    from tactile_cli.learn import load_run

    run = load_run(run_dir)
    net = run.load_model()
    x = torch.from_numpy(run.normalisation.apply(table))[:, None, :]
    with torch.inference_mode():
        out = net(x)
    cols = []
    for head in ("nx", "ny", "nz"):
        mean, std = run.normalisation.targets[head]
        cols.append(out[head].double().numpy() * std + mean)
    raw = np.stack(cols, axis=1)
    return raw / np.linalg.norm(raw, axis=1, keepdims=True)


@pytest.mark.parametrize("kind", ["difference", "absolute"])
def test_predict_pixels_equals_torch(runs: dict[str, Path], kind: str) -> None:
    model = NormalModel.from_run(runs[kind])
    assert model.input_kind == kind
    rng = np.random.default_rng(1)
    colour = rng.normal(0, 40, (2000, 3)) if kind == "difference" else rng.uniform(0, 255,
                                                                                 (2000, 3))
    table = np.c_[rng.uniform(0, 64, (2000, 1)), rng.uniform(0, 48, (2000, 1)),
                  colour].astype(np.float32)
    got = model.predict_pixels(table)
    assert got.dtype == np.float32 and got.shape == (2000, 3)
    np.testing.assert_allclose(got, _torch_normals(runs[kind], table), atol=1e-5)


def test_predict_frame_equals_torch_and_threads_agree(runs: dict[str, Path]) -> None:
    model = NormalModel.from_run(runs["difference"])
    rng = np.random.default_rng(2)
    h = sphere_cap((48, 64), (30.0, 25.0), 2.0, 0.5)
    ref = shade(np.zeros((48, 64)), noise_std=1.0, rng=rng)
    frame = shade(h, noise_std=1.0, rng=rng)
    one = model.predict(frame, ref, workers=1)
    two = model.predict(frame, ref, workers=2)
    np.testing.assert_array_equal(one, two)
    yy, xx = np.mgrid[0:48, 0:64]
    diff = frame.astype(np.float32) - ref.astype(np.float32)
    table = np.c_[xx.ravel(), yy.ravel(), diff.reshape(-1, 3)].astype(np.float32)
    np.testing.assert_allclose(one.reshape(-1, 3), _torch_normals(runs["difference"], table),
                               atol=1e-5)
    np.testing.assert_allclose(np.linalg.norm(one, axis=-1), 1.0, atol=1e-6)


def test_normals_are_the_same_bits_for_any_worker_count(runs: dict[str, Path]) -> None:
    """Issue 30: with OPENBLAS_CORETYPE=Haswell, 1,557 of 9,216 normals differed by up to
    1.2e-7 between workers=1 (BLAS on its own two threads) and workers=2 (one-threaded
    BLAS per tile). Tiles are now fixed and every one runs one-threaded BLAS, whatever
    ``workers`` and whatever the caller's BLAS thread count."""
    from threadpoolctl import threadpool_limits

    from tactile_cli.visuotactile.normals import TILE_PX

    model = NormalModel.from_run(runs["difference"])
    rng = np.random.default_rng(5)
    shape = (160, 80)  # 12,800 px: three full tiles and a part tile
    assert 3 * TILE_PX < shape[0] * shape[1] < 4 * TILE_PX
    ref = shade(np.zeros(shape), noise_std=1.0, rng=rng)
    frame = shade(sphere_cap(shape, (40.0, 80.0), 2.5, 0.6), noise_std=1.0, rng=rng)
    active = np.abs(frame.astype(np.int16) - ref).max(axis=-1) >= 2
    assert TILE_PX < active.sum() < shape[0] * shape[1]
    with threadpool_limits(limits=2, user_api="blas"):  # the caller's BLAS has threads
        one = model.predict(frame, ref, workers=1)
        part = model.predict(frame, ref, workers=1, active=active)
    for workers in (2, 3, 4):
        np.testing.assert_array_equal(model.predict(frame, ref, workers=workers), one)
        np.testing.assert_array_equal(model.predict(frame, ref, workers=workers,
                                                    active=active), part)
    np.testing.assert_array_equal(model.predict_pixels(np.c_[
        np.mgrid[0:160, 0:80][::-1].reshape(2, -1).T,
        (frame.astype(np.float32) - ref).reshape(-1, 3)]), one.reshape(-1, 3))


def test_layers_of_different_widths_and_gradients_straight_from_the_network(
        runs: dict[str, Path], tmp_path_factory: pytest.TempPathFactory) -> None:
    """A 5-32-16-3 run (layers of different widths; it raised a shape error before) equals
    its torch model, and eq. 9's gradients computed from the raw outputs equal those of
    the unit normals, for any worker count bit for bit."""
    from tactile_cli.visuotactile.poisson import gradients_from_normals

    run = normal_run(tmp_path_factory.getbasetemp() / "normal_runs", hidden=(32, 16))
    model = NormalModel.from_run(run)
    assert [w.shape for w, _ in model.hidden] == [(32, 16)]
    rng = np.random.default_rng(7)
    shape = (72, 96)
    ref = shade(np.zeros(shape), noise_std=1.0, rng=rng)
    frame = shade(sphere_cap(shape, (50.0, 30.0), 2.5, 0.6), noise_std=1.0, rng=rng)
    one = model.predict(frame, ref, workers=1)
    yy, xx = np.mgrid[0:72, 0:96]
    table = np.c_[xx.ravel(), yy.ravel(),
                  (frame.astype(np.float32) - ref).reshape(-1, 3)].astype(np.float32)
    np.testing.assert_allclose(one.reshape(-1, 3), _torch_normals(run, table), atol=1e-5)
    for m in (model, NormalModel.from_run(runs["difference"])):
        for floor in (0.1, 0.9):  # 0.9: the floor binds on most of the cap
            want = gradients_from_normals(m.predict(frame, ref, workers=1), nz_floor=floor)
            got = m.gradients(frame, ref, nz_floor=floor, workers=1)
            for g, w in zip(got, want, strict=True):
                assert g.shape == shape and g.dtype == np.float32
                np.testing.assert_allclose(g, w, rtol=1e-5, atol=1e-6)
            for g, g2 in zip(got, m.gradients(frame, ref, nz_floor=floor, workers=2),
                             strict=True):
                np.testing.assert_array_equal(g, g2)
    with pytest.raises(ValueError, match="nz_floor"):
        model.gradients(frame, ref, nz_floor=0.0)


def test_a_flat_frame_is_nearly_flat(runs: dict[str, Path]) -> None:
    model = NormalModel.from_run(runs["difference"])
    ref = shade(np.zeros((48, 64)))
    n = model.predict(ref, ref)
    assert np.median(n[..., 2]) > 0.99


def test_not_a_normal_run(runs: dict[str, Path], tmp_path: Path) -> None:
    with pytest.raises(InputError, match="not a run folder"):
        NormalModel.from_run(tmp_path)
    model = NormalModel.from_run(runs["difference"])
    with pytest.raises(ValueError, match="same size"):
        model.predict(np.zeros((4, 5, 3), np.uint8), np.zeros((4, 6, 3), np.uint8))
    with pytest.raises(ValueError, match="channels"):
        model.predict_pixels(np.zeros((3, 4), np.float32))


def test_run_with_wrong_heads_is_refused(runs: dict[str, Path]) -> None:
    from tactile_cli.learn.dense_weights import dense_arrays

    arrays = dense_arrays(runs["difference"])
    wrong = type(arrays)(**{**arrays.__dict__, "heads": {"nx": arrays.heads["nx"]}})
    with pytest.raises(InputError, match="heads nx, ny, nz"):
        NormalModel.from_arrays(wrong)
    wrong = type(arrays)(**{**arrays.__dict__, "channels": ("x", "y", "a", "b", "c")})
    with pytest.raises(InputError, match="x, y, dR, dG, dB"):
        NormalModel.from_arrays(wrong)


def test_run_of_another_family_is_refused(runs: dict[str, Path], tmp_path: Path) -> None:
    import yaml

    from tactile_cli.learn import parse_config
    from tactile_cli.learn.train import train
    from tests.factories.gel_frames import TRAIN_YAML

    cfg = yaml.safe_load(TRAIN_YAML)
    cfg["model"] = {"family": "fnn", "hidden": [8]}
    cfg["optim"]["epochs"] = 1
    table = runs["difference"].parent / "pixels.h5"
    train(parse_config(cfg), [table], tmp_path / "fnn")
    with pytest.raises(InputError, match="family 'fnn'.*family: mlp"):
        NormalModel.from_run(tmp_path / "fnn")
