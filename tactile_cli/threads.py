"""How many threads the numeric libraries may use: the one place a command's ``--workers``
or ``--threads`` reaches BLAS, OpenMP and torch.

Without a limit, every BLAS call and every torch operator starts as many threads as the
machine has cores, inside each worker the command already runs: two ``heightmap
--workers 1`` side by side then take ten times as long. :func:`limit_threads` caps the
pools of the libraries already loaded (threadpoolctl: OpenBLAS, MKL, OpenMP) and torch's
intra-op pool, for the duration of a block; :func:`set_thread_env` sets the environment
variables the libraries read when they load, for worker processes started afterwards.

Results never depend on these numbers: code that splits work by worker count cuts it into
blocks of a fixed size first (see ``visuotactile/normals.py``), so the limits change only
the time a command takes.
"""

from __future__ import annotations

import os
import sys
from collections.abc import Iterator
from contextlib import contextmanager

from .errors import InputError

#: environment variables the BLAS and OpenMP runtimes read when they start
THREAD_ENV = ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS",
              "VECLIB_MAXIMUM_THREADS", "NUMEXPR_NUM_THREADS")


def available_cores() -> int:
    """The CPUs this process may run on (its affinity mask), at least 1."""
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except AttributeError:  # pragma: no cover - not on Linux
        return max(1, os.cpu_count() or 1)


def check_threads(n: object, name: str = "threads", *, most: int | None = None) -> int:
    """``n`` as a thread or worker count: an integer from 1 to ``most`` (default: 4 x the
    available cores, beyond which threads only wait for each other and runtimes fail to
    start them); one :class:`InputError` naming argument ``name`` otherwise."""
    limit = 4 * available_cores() if most is None else most
    if isinstance(n, bool) or not isinstance(n, int) or not 1 <= n <= limit:
        raise InputError(f"`{name}` (={n!r}) must be a whole number from 1 to {limit} (this "
                         f"machine has {available_cores()} cores)")
    return n


def set_thread_env(n: int) -> None:
    """Set :data:`THREAD_ENV` to ``n`` for libraries loaded later and for child processes."""
    for key in THREAD_ENV:
        os.environ[key] = str(int(n))


@contextmanager
def limit_threads(n: int) -> Iterator[None]:
    """Cap BLAS, OpenMP (through threadpoolctl, where installed) and torch (where already
    imported) at ``n`` threads inside the block; the previous limits are restored after."""
    n = max(1, int(n))
    limiter = None
    try:
        from threadpoolctl import threadpool_limits
    except ImportError:  # pragma: no cover - installed with scikit-learn
        threadpool_limits = None
    if threadpool_limits is not None:
        limiter = threadpool_limits(limits=n)
    torch = sys.modules.get("torch")
    before = None
    if torch is not None:
        before = torch.get_num_threads()
        torch.set_num_threads(n)
    try:
        yield
    finally:
        if torch is not None and before is not None:
            torch.set_num_threads(before)
        if limiter is not None:
            limiter.restore_original_limits()


__all__ = ["THREAD_ENV", "available_cores", "check_threads", "limit_threads", "set_thread_env"]
