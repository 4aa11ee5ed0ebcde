"""Linear solves of the few-parameter systems of the FOS fits, written out in jax.numpy.

The fits iterate one to three nonlinear parameters and report five at most, so every
linear system they solve is tiny: an unrolled Cholesky factorisation compiles to a few
dozen scalar operations per trial, vectorises across the trials of a chunk, and contains no
LAPACK call. That last point lets the solver programs be serialised with ``jax.export``
(lineax's QR applies its reflectors through ``ormqr``, a LAPACK call that export refuses),
which is how :mod:`tactile_cli.fos.compile_cache` skips tracing in later processes.

:class:`SmallLeastSquares` is the same thing as a lineax solver, for optimistix's
Levenberg-Marquardt and Gauss-Newton steps: they solve ``[J; sqrt(lambda) I] dx = [r; 0]``
in the least-squares sense, here through its normal equations.
"""

from __future__ import annotations

from typing import Any

import equinox.internal as eqxi
import jax.numpy as jnp
import lineax as lx
from jax import Array
from lineax._solver.misc import (
    pack_structures,
    ravel_vector,
    transpose_packed_structures,
    unravel_solution,
)


def spd_solve(a: Array, b: Array) -> Array:
    """``a^-1 b`` for a small symmetric positive definite ``a`` (n, n) and ``b`` (n,).

    An unrolled Cholesky factorisation, n at most about 6. A singular or indefinite ``a``
    gives inf or NaN, which the callers flag; it never raises.
    """
    n = a.shape[0]
    low: list[list[Any]] = [[None] * n for _ in range(n)]
    for j in range(n):
        low[j][j] = jnp.sqrt(a[j, j] - sum(low[j][k] ** 2 for k in range(j)))
        for i in range(j + 1, n):
            low[i][j] = (a[i, j] - sum(low[i][k] * low[j][k] for k in range(j))) / low[j][j]
    z: list[Any] = []
    for i in range(n):
        z.append((b[i] - sum(low[i][k] * z[k] for k in range(i))) / low[i][i])
    x: list[Any] = [None] * n
    for i in reversed(range(n)):
        x[i] = (z[i] - sum(low[k][i] * x[k] for k in range(i + 1, n))) / low[i][i]
    return jnp.stack(x)


def spd_inverse(a: Array) -> Array:
    """``a^-1`` (n, n) of a small symmetric positive definite ``a``, column by column."""
    eye = jnp.eye(a.shape[0], dtype=a.dtype)
    return jnp.stack([spd_solve(a, eye[:, j]) for j in range(a.shape[0])], axis=1)


class SmallLeastSquares(lx.AbstractLinearSolver):
    """Least-squares solve of a tall operator with a few columns, by its normal equations.

    For the damped Gauss-Newton systems of the fits, whose columns are one to three log
    time constants: their Gram matrix is well conditioned enough in float64, and the
    damping keeps it positive definite. The transposed (wide) system gets the minimum-norm
    solution ``A (A^T A)^-1 b``.
    """

    def init(self, operator: lx.AbstractLinearOperator, options: dict[str, Any]) -> Any:
        del options
        return operator.as_matrix(), eqxi.Static(False), pack_structures(operator)

    def compute(self, state: Any, vector: Any, options: dict[str, Any]
                ) -> tuple[Any, lx.RESULTS, dict[str, Any]]:
        del options
        matrix, transposed, packed = state
        v = ravel_vector(vector, packed)
        # Products as sums of elementwise terms: under vmap a dot of these thin matrices
        # becomes a batch of tiny matrix products, several times slower on the CPU.
        gram = jnp.sum(matrix[:, :, None] * matrix[:, None, :], axis=0)
        if transposed.value:
            x = jnp.sum(matrix * spd_solve(gram, v), axis=1)
        else:
            x = spd_solve(gram, jnp.sum(matrix * v[:, None], axis=0))
        return unravel_solution(x, packed), lx.RESULTS.successful, {}

    def transpose(self, state: Any, options: dict[str, Any]) -> tuple[Any, dict[str, Any]]:
        matrix, transposed, packed = state
        return (matrix, eqxi.Static(not transposed.value),
                transpose_packed_structures(packed)), options

    def conj(self, state: Any, options: dict[str, Any]) -> tuple[Any, dict[str, Any]]:
        return state, options  # real matrices

    def assume_full_rank(self) -> bool:
        return True


__all__ = ["SmallLeastSquares", "spd_inverse", "spd_solve"]
