"""Tactile meshes: evenly spaced units at the paper's densities."""

from __future__ import annotations

import numpy as np
import pytest

from tactile_cli.visuotactile.mesh import (
    MESH_SIZES,
    mesh_indices,
    mesh_mask,
    parse_mesh,
    sample_mesh,
)


def test_paper_mesh_is_every_tenth_pixel() -> None:
    r, c = mesh_indices(240, 320, (32, 24))
    np.testing.assert_array_equal(c, np.arange(5, 320, 10))
    np.testing.assert_array_equal(r, np.arange(5, 240, 10))
    assert mesh_mask(240, 320, (32, 24)).sum() == 768


@pytest.mark.parametrize("mesh", MESH_SIZES)
def test_every_density_is_even_and_distinct(mesh: tuple[int, int]) -> None:
    r, c = mesh_indices(240, 320, mesh)
    assert (c.size, r.size) == mesh
    assert np.unique(c).size == c.size and np.unique(r).size == r.size
    steps = np.diff(c)
    assert steps.size == 0 or steps.max() - steps.min() <= 1


def test_full_mesh_is_the_map() -> None:
    maps = np.arange(2 * 6 * 8).reshape(2, 6, 8)
    np.testing.assert_array_equal(sample_mesh(maps, (8, 6)), maps)
    np.testing.assert_array_equal(sample_mesh(maps, (4, 3)), maps[:, 1::2, 1::2])


def test_parse_and_errors() -> None:
    assert parse_mesh("32x24") == (32, 24)
    assert parse_mesh(" 4X3 ") == (4, 3)
    for bad in ("32", "0x3", "axb", "3x-1"):
        with pytest.raises(ValueError, match="COLSxROWS"):
            parse_mesh(bad)
    with pytest.raises(ValueError, match="denser"):
        mesh_indices(24, 32, (64, 48))
