"""Where the compiled FOS solver is kept between runs, and how a process gets it.

One program (:mod:`tactile_cli.fos.solver`) fits every model; each process needs it for
the chunk shape it meets, and two caches spare later processes its cost:

- the **traced program**: the solver is traced once (optimistix builds its loop in
  Python, about as slow as the compilation) and serialised with ``jax.export`` to
  ``$TACTILE_CACHE_DIR/fos/`` (default ``~/.cache/tactile/fos``), one file per solver
  setting and chunk shape, named after a hash of the solver's source and the versions of
  jax, jaxlib, optimistix, equinox and lineax (a change of either traces anew). A later
  process loads it without importing optimistix.
- **JAX's persistent compilation cache** in ``$TACTILE_CACHE_DIR/jax/``: XLA's compiled
  executable, keyed by JAX on the program, so the loaded program is not compiled again.

Both are used once :func:`enable_compilation_cache` has been called (the CLI does); a
library user who does not gets the plain ``jax.jit`` of the solver, compiled per process.
A file that cannot be read or written is ignored (the program is traced instead), so a
read-only or damaged cache costs time, never a failure.
"""

from __future__ import annotations

import hashlib
import importlib.metadata
import os
from pathlib import Path
from typing import TYPE_CHECKING, Any

from ..errors import InputError
from ..store.atomic import write_bytes

if TYPE_CHECKING:
    from .solver import SolverSpec

#: Processes' programs by (spec, n_rows, n_points).
_PROGRAMS: dict[tuple, Any] = {}
#: Folder of the serialised programs once :func:`enable_compilation_cache` ran, else None.
_EXPORT_DIR: Path | None = None


def cache_root() -> Path:
    """``$TACTILE_CACHE_DIR``, else ``~/.cache/tactile``."""
    root = os.environ.get("TACTILE_CACHE_DIR")
    return Path(root) if root else Path.home() / ".cache" / "tactile"


def compilation_cache_dir() -> Path:
    """Where JAX keeps compiled solvers between runs: ``cache_root() / "jax"``."""
    return cache_root() / "jax"


def program_cache_dir() -> Path:
    """Where the traced solver programs are kept: ``cache_root() / "fos"``."""
    return cache_root() / "fos"


def enable_compilation_cache() -> Path:
    """Turn on JAX's persistent compilation cache (every compilation kept, however quick)
    and the store of traced programs, so later runs skip tracing and XLA compilation;
    returns the compilation cache folder."""
    global _EXPORT_DIR
    import jax

    cache = compilation_cache_dir()
    cache.mkdir(parents=True, exist_ok=True)
    jax.config.update("jax_compilation_cache_dir", str(cache))
    jax.config.update("jax_persistent_cache_min_compile_time_secs", 0)
    jax.config.update("jax_persistent_cache_min_entry_size_bytes", 0)
    _EXPORT_DIR = program_cache_dir()
    return cache


def _code_version() -> str:
    """Hash of the solver's source and of the libraries that shape its program."""
    digest = hashlib.sha256()
    here = Path(__file__).parent
    for name in ("solver.py", "small_solve.py", "models.py"):
        digest.update((here / name).read_bytes())
    for dist in ("jax", "jaxlib", "optimistix", "equinox", "lineax"):
        try:
            digest.update(f"{dist}={importlib.metadata.version(dist)};".encode())
        except importlib.metadata.PackageNotFoundError:
            digest.update(f"{dist}=none;".encode())
    return digest.hexdigest()[:16]


def _arg_specs(n_rows: int, n_points: int) -> tuple[Any, ...]:
    import jax
    import numpy as np

    rows = jax.ShapeDtypeStruct((n_rows, n_points), np.float64)
    flag = jax.ShapeDtypeStruct((), np.bool_)
    tol = jax.ShapeDtypeStruct((), np.float64)
    return (rows, rows, rows, jax.ShapeDtypeStruct((n_rows,), np.float64),
            jax.ShapeDtypeStruct((n_rows, 3), np.float64), flag, flag, flag, tol, tol)


def _exported(spec: SolverSpec, n_rows: int, n_points: int, folder: Path) -> Any:
    """The solver as a ``jax.export.Exported``, loaded from ``folder`` or traced and saved
    there; None where export is not available (serialisation needs ``flatbuffers``)."""
    import jax
    from jax import export

    try:
        import flatbuffers  # noqa: F401  (jax.export's serialisation needs it)
    except ImportError:
        return None
    path = folder / f"solver-{_code_version()}-{spec.key()}-{n_rows}x{n_points}.jaxexport"
    try:
        return export.deserialize(bytearray(path.read_bytes()))
    except FileNotFoundError:
        pass
    except Exception:  # unreadable or damaged (the decoder raises many kinds): trace anew
        pass
    from .solver import chunk_function

    with jax.enable_x64(True):
        exported = export.export(jax.jit(chunk_function(spec)))(*_arg_specs(n_rows, n_points))
    try:  # a cache: a folder that cannot be written only costs the next run a compile
        folder.mkdir(parents=True, exist_ok=True)
        write_bytes(path, bytes(exported.serialize()), overwrite=True)
    except (OSError, InputError):
        pass
    return exported


def _traceable(spec: SolverSpec, n_rows: int, n_points: int) -> Any:
    """The function to jit: the loaded or newly exported program, else the solver itself."""
    exported = None if _EXPORT_DIR is None else _exported(spec, n_rows, n_points, _EXPORT_DIR)
    if exported is not None:
        return exported.call
    from .solver import chunk_function

    return chunk_function(spec)


def solver_program(spec: SolverSpec, n_rows: int, n_points: int) -> Any:
    """The compiled chunk solver of :mod:`tactile_cli.fos.solver` for ``(n_rows, n_points)``
    chunks: one per process and shape, from the program cache when it is enabled."""
    key = (spec, n_rows, n_points)
    if key not in _PROGRAMS:
        import jax

        _PROGRAMS[key] = jax.jit(_traceable(spec, n_rows, n_points))
    return _PROGRAMS[key]


__all__ = ["cache_root", "compilation_cache_dir", "enable_compilation_cache",
           "program_cache_dir", "solver_program"]
