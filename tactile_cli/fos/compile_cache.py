"""JAX's persistent compilation cache for the fits: where it lives and how it is enabled.

The solvers of :mod:`tactile_cli.fos.fit` are compiled by XLA on first use; with the cache
on, later processes load the compiled programs instead of compiling them again.
"""

from __future__ import annotations

import os
from pathlib import Path


def compilation_cache_dir() -> Path:
    """Where JAX keeps compiled solvers between runs: ``$TACTILE_CACHE_DIR/jax``, else
    ``~/.cache/tactile/jax``."""
    root = os.environ.get("TACTILE_CACHE_DIR")
    return (Path(root) if root else Path.home() / ".cache" / "tactile") / "jax"


def enable_compilation_cache() -> Path:
    """Turn on JAX's persistent compilation cache (every compilation kept, however quick),
    so later runs skip XLA compilation; returns the cache folder."""
    import jax

    cache = compilation_cache_dir()
    cache.mkdir(parents=True, exist_ok=True)
    jax.config.update("jax_compilation_cache_dir", str(cache))
    jax.config.update("jax_persistent_cache_min_compile_time_secs", 0)
    jax.config.update("jax_persistent_cache_min_entry_size_bytes", 0)
    return cache


__all__ = ["compilation_cache_dir", "enable_compilation_cache"]
