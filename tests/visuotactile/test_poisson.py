"""Eq. 9 and the DST Poisson solver: exact inversion, sphere-cap peaks, the eigenvalue grid."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.fft as sfft

from tactile_cli.visuotactile.poisson import (
    NZ_FLOOR,
    PoissonSolver,
    face_gradients,
    fast_dst1_len,
    gradients_from_normals,
    integrate_gradients,
)
from tests.factories.gel_frames import normals_of, sphere_cap, sphere_cap_gradients

PX_PER_MM = 20.0
SHAPE = (240, 320)


def test_discrete_round_trip_is_exact() -> None:
    rng = np.random.default_rng(3)
    h = rng.normal(0.0, 0.5, SHAPE)
    h[0, :] = 0.0
    h[:, 0] = 0.0
    gx, gy = face_gradients(h, PX_PER_MM)
    back = integrate_gradients(gx, gy, PX_PER_MM, sampling="face")
    assert np.abs(back - h).max() < 1e-10


@pytest.mark.parametrize(("ball_radius_mm", "depth_mm"),
                         [(0.8, 0.15), (2.0, 0.5), (4.0, 1.5), (8.0, 1.7), (12.0, 1.1)])
def test_sphere_cap_peaks_within_5_percent(ball_radius_mm: float, depth_mm: float) -> None:
    contact_px = np.sqrt(ball_radius_mm**2 - (ball_radius_mm - depth_mm) ** 2) * PX_PER_MM
    assert contact_px < 110  # inside the 240-row frame: from 9 px to 100 px (83 % of its
    # half-height)
    centre = (160.0, 120.0)
    gx, gy = sphere_cap_gradients(SHAPE, centre, ball_radius_mm, depth_mm, PX_PER_MM)
    h = PoissonSolver(*SHAPE, PX_PER_MM).integrate(gx, gy)
    assert h.max() == pytest.approx(depth_mm, rel=0.05)
    truth = sphere_cap(SHAPE, centre, ball_radius_mm, depth_mm, PX_PER_MM)
    assert np.sqrt(np.mean((h - truth) ** 2)) < 0.02 * depth_mm


def _neumann_one_based(gx: np.ndarray, gy: np.ndarray) -> np.ndarray:
    """The vendor recipe the issue warns about: DCT with its eigenvalue grid over 1..N."""
    f = np.zeros_like(gx)
    f[:, 1:] += gx[:, 1:] - gx[:, :-1]
    f[1:, :] += gy[1:, :] - gy[:-1, :]
    f /= PX_PER_MM
    rows, cols = f.shape
    ky, kx = np.arange(1, rows + 1), np.arange(1, cols + 1)
    lam = ((2 * np.cos(np.pi * ky / rows) - 2)[:, None] + (2 * np.cos(np.pi * kx / cols) - 2))
    return sfft.idctn(sfft.dctn(f, norm="ortho") / lam, norm="ortho")


def test_the_one_based_dct_grid_fails_the_same_check() -> None:
    """The 5 % check above can fail: the wrong grid loses a large share of a big cap."""
    gx, gy = sphere_cap_gradients(SHAPE, (160.0, 120.0), 8.0, 1.7, PX_PER_MM)
    wrong = _neumann_one_based(gx, gy)
    assert (wrong.max() - wrong.min()) < 0.9 * 1.7


def test_gradients_from_normals_inverts_the_normals() -> None:
    h = sphere_cap((60, 80), (40.0, 30.0), 2.0, 0.6, PX_PER_MM)
    n = normals_of(h, PX_PER_MM)
    gx, gy = gradients_from_normals(n)
    gy_true, gx_true = np.gradient(h, axis=(0, 1))
    np.testing.assert_allclose(gx, gx_true * PX_PER_MM, atol=1e-12)
    np.testing.assert_allclose(gy, gy_true * PX_PER_MM, atol=1e-12)


def test_scene_normals_round_trip() -> None:
    from tactile_cli.visuotactile import render

    h = sphere_cap(SHAPE, (150.0, 110.0), 3.0, 0.8, PX_PER_MM)
    n = render.surface_normals(h, PX_PER_MM)
    gx, gy = gradients_from_normals(np.asarray(n, dtype=np.float64))
    back = PoissonSolver(*SHAPE, PX_PER_MM).integrate(gx, gy)
    assert back.max() == pytest.approx(0.8, rel=0.05)


def test_nz_floor_bounds_the_slope() -> None:
    n = np.array([[[1.0, 0.0, 0.0], [0.6, 0.0, -0.8]]])
    gx, gy = gradients_from_normals(n)
    np.testing.assert_allclose(gx, [[-1.0 / NZ_FLOOR, -0.6 / NZ_FLOOR]])
    np.testing.assert_allclose(gy, 0.0)
    with pytest.raises(ValueError, match="nz_floor"):
        gradients_from_normals(n, nz_floor=0.0)


def test_padded_sizes_are_fft_friendly() -> None:
    for n in (244, 324, 484, 644, 336):
        m = fast_dst1_len(n)
        assert m >= n
        rest = m + 1
        for p in (2, 3, 5, 7, 11):
            while rest % p == 0:
                rest //= p
        assert rest == 1, (n, m)


def test_float32_solver_matches_float64() -> None:
    gx, gy = sphere_cap_gradients(SHAPE, (160.0, 120.0), 3.0, 1.0, PX_PER_MM)
    a = PoissonSolver(*SHAPE, PX_PER_MM).integrate(gx, gy)
    b = PoissonSolver(*SHAPE, PX_PER_MM, dtype=np.float32, workers=2).integrate(gx, gy)
    assert b.dtype == np.float32
    assert np.abs(a - b).max() < 1e-5


@pytest.mark.parametrize("dtype", [np.float32, np.float64])
def test_fft_workers_change_no_bit(dtype: type) -> None:
    """scipy.fft's workers split the independent 1-D transforms of each axis: the heights
    are bit-identical for any number (issue 30), on an odd grid too."""
    for shape in (SHAPE, (97, 131)):
        gx, gy = sphere_cap_gradients(shape, (60.0, 50.0), 3.0, 1.0, PX_PER_MM)
        one = PoissonSolver(*shape, PX_PER_MM, dtype=dtype, workers=1).integrate(gx, gy)
        for workers in (2, 3, 4):
            np.testing.assert_array_equal(
                PoissonSolver(*shape, PX_PER_MM, dtype=dtype, workers=workers).integrate(gx, gy),
                one)


def test_bad_arguments() -> None:
    with pytest.raises(ValueError, match="px_per_mm"):
        PoissonSolver(10, 10, 0.0)
    s = PoissonSolver(10, 12, 20.0)
    with pytest.raises(ValueError, match="do not match"):
        s.integrate(np.zeros((12, 10)), np.zeros((12, 10)))
    with pytest.raises(ValueError, match="sampling"):
        s.integrate(np.zeros((10, 12)), np.zeros((10, 12)), sampling="edge")  # type: ignore[arg-type]


def test_the_centre_divergence_is_the_mean_face_difference():
    """The centre sampling's divergence, built as four shifted adds, equals its definition:
    faces between neighbouring centres get their mean, faces at the frame's edge half of
    the one centre inside, and the divergence is the difference of the faces."""
    rng = np.random.default_rng(3)
    h, w = 9, 13
    s = PoissonSolver(h, w, 4.0, pad_px=1)
    gx, gy = rng.normal(size=(h, w)), rng.normal(size=(h, w))
    r, c, t, lft = s.rows, s.cols, s.top, s.left
    fx = np.zeros((r, c + 1))
    fy = np.zeros((r + 1, c))
    fx[t:t + h, lft + 1:lft + w + 1] += 0.5 * gx
    fx[t:t + h, lft:lft + w] += 0.5 * gx
    fy[t + 1:t + h + 1, lft:lft + w] += 0.5 * gy
    fy[t:t + h, lft:lft + w] += 0.5 * gy
    want = ((fx[:, 1:] - fx[:, :-1]) + (fy[1:, :] - fy[:-1, :])) / 4.0
    np.testing.assert_allclose(s.divergence(gx, gy), want, rtol=0, atol=1e-15)
