"""First-order-system fits of press and slip regions (paper 000, sec. 4.2, eqs. 16-17).

A pure array core for ``tactile fit-fos``: padded ``(n_trials, n_points)`` event counts per
bin in, per-trial dataclasses out. The fits run in float64 inside a scoped
``jax.enable_x64(True)`` context; importing this package changes no global JAX setting.

The fitting names are imported on first use (PEP 562), so ``tactile_cli.fos.models`` and
``tactile_cli.fos.actions`` stay importable without loading jax.
"""

from __future__ import annotations

import importlib
from typing import Any

_EXPORTS = {
    "FitOptions": "fit", "FitStatus": "fit", "FosFitResult": "fit", "fit_pulse": "fit",
    "fit_ramp": "fit", "fit_second_order": "fit", "fit_step": "fit",
    "first_order_response": "models", "pulse_response": "models", "ramp_response": "models",
    "second_order_basis": "models", "second_order_response": "models",
    "step_response": "models", "unit_response": "models",
    "OrderSelection": "order", "select_order": "order",
    "FitFosResult": "fit_files", "RegionResult": "fit_files", "fit_files": "fit_files",
    "fit_options": "fit_files",
}

__all__ = sorted(_EXPORTS)


def __getattr__(name: str) -> Any:
    module = _EXPORTS.get(name)
    if module is None:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    value = getattr(importlib.import_module(f".{module}", __name__), name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(_EXPORTS))
