"""Thread and worker counts (tactile_cli/threads.py): bounded by the machine, and the limits
of BLAS, OpenMP and torch restored after a block."""

from __future__ import annotations

import pytest

from tactile_cli.errors import InputError
from tactile_cli.threads import available_cores, check_threads, limit_threads


def test_check_threads_bounds_by_the_cores():
    assert check_threads(1) == 1
    most = 4 * available_cores()
    assert check_threads(most) == most
    for bad in (0, -1, most + 1, 4096, 2.0, True, "2"):
        with pytest.raises(InputError, match=r"`threads` \(=.*\) must be a whole number from 1"):
            check_threads(bad)
    with pytest.raises(InputError, match=r"`workers` \(=3\) must be a whole number from 1 to 2"):
        check_threads(3, "workers", most=2)


def test_limit_threads_caps_blas_and_torch_and_restores_them():
    import torch
    from threadpoolctl import threadpool_info

    before_torch = torch.get_num_threads()
    before_blas = [p["num_threads"] for p in threadpool_info()]
    with limit_threads(1):
        assert torch.get_num_threads() == 1
        assert all(p["num_threads"] == 1 for p in threadpool_info())
    assert torch.get_num_threads() == before_torch
    assert [p["num_threads"] for p in threadpool_info()] == before_blas
