"""The lumped-element model of paper 003 (sec. 2.2, eqs. 1-2): Kelvin-Voigt blocks assembled
into M x'' + C x' + K x = f and solved in the frequency domain.

Each block is a mass hung from its parent node (a block or the ground) by a spring and a
damper in parallel; a contact adds massless links (spring and damper) between two nodes.
The ERM prescribes the displacement ``u`` of the source block; the other blocks are free,
so at angular frequency w the free displacements solve

    D_ff(w) x_f = -D_fs(w) u,        D(w) = K - w^2 M + i w C,

and the spectrum is the accelerometer block's displacement per unit motor displacement,
``H(f) = x_sensor / u`` (dimensionless; its acceleration is ``-w^2 H u``). The resonances
are the peaks of ``|H|``; with the source held still they sit near the undamped natural
frequencies, ``sqrt(eig(K_ff, M_ff)) / 2 pi``.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from .config import GROUND, ModelConfig


@dataclass(frozen=True)
class LumpedModel:
    """Assembled matrices: ``mass_kg``, ``damping_n_s_m``, ``stiffness_n_m`` (n, n) float64
    over the blocks ``names`` (config order); ``source`` and ``sensor`` index the motor's
    and the accelerometer's blocks."""

    names: tuple[str, ...]
    mass_kg: np.ndarray
    damping_n_s_m: np.ndarray
    stiffness_n_m: np.ndarray
    source: int
    sensor: int


def _add_link(k: np.ndarray, c: np.ndarray, index: dict[str, int], a: str, b: str,
              stiffness: float, damping: float) -> None:
    nodes = [index[n] for n in (a, b) if n != GROUND]
    for i in nodes:
        k[i, i] += stiffness
        c[i, i] += damping
    if len(nodes) == 2:
        i, j = nodes
        k[i, j] -= stiffness
        k[j, i] -= stiffness
        c[i, j] -= damping
        c[j, i] -= damping


def assemble(cfg: ModelConfig, *, contact: bool | Sequence[float] = False) -> LumpedModel:
    """M, C, K of ``cfg`` (eq. 2). ``contact``: False (no contact), True (every contact link
    at its configured stiffness) or one stiffness (N/m) per contact link; a link's damping
    scales with its stiffness (its configured ``damping / stiffness`` ratio)."""
    names = tuple(cfg.blocks)
    index = {n: i for i, n in enumerate(names)}
    n = len(names)
    m = np.diag([cfg.blocks[b].mass_kg for b in names]).astype(np.float64)
    k = np.zeros((n, n))
    c = np.zeros((n, n))
    for name, block in cfg.blocks.items():
        _add_link(k, c, index, name, block.parent, block.stiffness_n_m, block.damping_n_s_m)
    if contact is True:
        stiffnesses = [link.stiffness_n_m for link in cfg.contact]
    elif contact is False:
        stiffnesses = [0.0] * len(cfg.contact)
    else:
        stiffnesses = [float(s) for s in contact]
        if len(stiffnesses) != len(cfg.contact):
            raise ValueError(f"`contact` gives {len(stiffnesses)} stiffnesses for "
                             f"{len(cfg.contact)} contact links")
    for link, stiffness in zip(cfg.contact, stiffnesses, strict=True):
        if stiffness < 0:
            raise ValueError(f"`contact` stiffness (={stiffness}) must be >= 0")
        ratio = link.damping_n_s_m / link.stiffness_n_m if link.stiffness_n_m > 0 else 0.0
        _add_link(k, c, index, *link.between, stiffness, ratio * stiffness)
    return LumpedModel(names, m, c, k, index[cfg.source], index[cfg.sensor])


def frequency_response(model: LumpedModel, f_hz: np.ndarray) -> np.ndarray:
    """(n_f,) complex ``x_sensor / u`` at the frequencies ``f_hz`` (n_f,) Hz, the source
    block's displacement prescribed (see the module docstring)."""
    f = np.asarray(f_hz, dtype=np.float64)
    w = 2 * np.pi * f
    free = np.array([i for i in range(len(model.names)) if i != model.source])
    s = model.source
    d = (model.stiffness_n_m[None] - (w ** 2)[:, None, None] * model.mass_kg[None]
         + 1j * w[:, None, None] * model.damping_n_s_m[None])
    d_ff = d[:, free[:, None], free[None, :]]
    rhs = -d[:, free, s]
    x_f = np.linalg.solve(d_ff, rhs[..., None])[..., 0]
    return x_f[:, int(np.flatnonzero(free == model.sensor)[0])]


def natural_frequencies_hz(model: LumpedModel) -> np.ndarray:
    """Undamped natural frequencies (Hz, ascending) with the source block held still:
    ``sqrt(eig(K_ff, M_ff)) / 2 pi``."""
    from scipy.linalg import eigh

    free = [i for i in range(len(model.names)) if i != model.source]
    k = model.stiffness_n_m[np.ix_(free, free)]
    m = model.mass_kg[np.ix_(free, free)]
    lam = eigh(k, m, eigvals_only=True)
    return np.sqrt(np.clip(lam, 0, None)) / (2 * np.pi)


@dataclass(frozen=True)
class Resonance:
    """A peak of ``|H|``: frequency (Hz) and amplitude (``|x_sensor / u|``)."""

    f_hz: float
    amplitude: float


def find_resonances(f_hz: np.ndarray, magnitude: np.ndarray, *,
                    prominence_db: float = 1.0) -> list[Resonance]:
    """Peaks of a (n_f,) magnitude spectrum at least ``prominence_db`` above their
    surroundings, refined by a parabola through the log-magnitude of the three bins."""
    from scipy.signal import find_peaks

    f = np.asarray(f_hz, dtype=np.float64)
    db = 20 * np.log10(np.maximum(np.asarray(magnitude, dtype=np.float64), 1e-300))
    peaks, _ = find_peaks(db, prominence=prominence_db)
    out = []
    for p in peaks:
        y0, y1, y2 = db[p - 1], db[p], db[p + 1]
        denom = y0 - 2 * y1 + y2
        shift = 0.5 * (y0 - y2) / denom if denom != 0 else 0.0
        step = f[p + 1] - f[p]
        out.append(Resonance(float(f[p] + shift * step),
                             float(10 ** ((y1 - 0.25 * (y0 - y2) * shift) / 20))))
    return out


@dataclass(frozen=True)
class ModelSpectra:
    """Fig. 3A: ``f_hz`` (n_f,), ``free`` and ``contact`` (n_f,) ``|x_sensor / u|``, their
    resonances and the natural frequencies of each state."""

    f_hz: np.ndarray
    free: np.ndarray
    contact: np.ndarray
    resonances_free: list[Resonance]
    resonances_contact: list[Resonance]
    natural_free_hz: np.ndarray
    natural_contact_hz: np.ndarray

    def as_dict(self) -> dict[str, Any]:
        def res(rs: list[Resonance]) -> list[dict[str, float]]:
            return [{"f_hz": round(r.f_hz, 3), "amplitude": float(f"{r.amplitude:.6g}")}
                    for r in rs]
        return {"f_range_hz": [float(self.f_hz[0]), float(self.f_hz[-1])],
                "resonances_free": res(self.resonances_free),
                "resonances_contact": res(self.resonances_contact),
                "natural_free_hz": [round(float(v), 3) for v in self.natural_free_hz],
                "natural_contact_hz": [round(float(v), 3) for v in self.natural_contact_hz]}


def model_spectra(cfg: ModelConfig) -> ModelSpectra:
    """Both spectra of ``cfg`` over its frequency grid, without and with contact."""
    f = np.arange(cfg.f_min_hz, cfg.f_max_hz + 0.5 * cfg.f_step_hz, cfg.f_step_hz)
    free_model, contact_model = assemble(cfg), assemble(cfg, contact=True)
    free = np.abs(frequency_response(free_model, f))
    contact = np.abs(frequency_response(contact_model, f))
    return ModelSpectra(f, free, contact, find_resonances(f, free), find_resonances(f, contact),
                        natural_frequencies_hz(free_model), natural_frequencies_hz(contact_model))
