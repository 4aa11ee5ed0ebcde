"""Names and defaults shared by every package that handles action trials (paper 000, sec. 4.2).

The four actions of a trial and the default bin width of its event counts are used by
event accumulation and segmentation (``events``), the FOS fits (``fos``), the synthetic
generators (``scene``, ``synth``), the centroid streams (``spatial``), the grader
(``grade``) and the models (``learn``). They live here, not in one of those packages, so
that using the words costs no other package: importing this module loads nothing beyond
``tactile_cli`` itself (no jax, optimistix, torch or ``tactile_cli.fos``; a test checks).

It is a top-level module rather than ``tactile_cli/events/labels.py`` because
``tactile_cli/events/__init__.py`` imports the accumulation and segmentation modules, and
with them h5py readers and ``scipy.signal`` (about 0.7 s), which ``tactile_cli.fos.actions``
and the config modules that only need the names should not pay.
"""

from __future__ import annotations

#: Action classes in label order, paper 000 sec. 4.2: per-bin action labels are int8
#: indices into this tuple (-1 for none), and files store it as the ``classes`` attribute.
ACTIONS: tuple[str, ...] = ("approach", "press", "slip", "release")

#: Default bin width of event counts, seconds (paper 000's 20 ms bins).
BIN_S: float = 0.02

#: The pressing-force grades of paper 000 (sec. 4.4, Table III), lowest first, as the
#: scenes name them; files and figure names write them with ``_`` for the space.
FORCE_GRADES: tuple[str, ...] = ("light", "small", "small medium", "medium", "small big",
                                 "big")


#: The eight accelerometer channel configurations of paper 001 (sec. 4) by name: L and R
#: are the left and right fingertips, x/y/z their axes; values are channel names of the
#: ``accel`` stream in stored order. A training config may name one (``channels: L3R3``).
CHANNEL_SETS: dict[str, tuple[str, ...]] = {
    "L3R3": ("L_x", "L_y", "L_z", "R_x", "R_y", "R_z"),
    "L3": ("L_x", "L_y", "L_z"),
    "LxRx": ("L_x", "R_x"),
    "Lx": ("L_x",),
    "LyRy": ("L_y", "R_y"),
    "Ly": ("L_y",),
    "LzRz": ("L_z", "R_z"),
    "Lz": ("L_z",),
}


def action_index(label: str) -> int | None:
    """Index into :data:`ACTIONS` of an annotation ``label``, matched ignoring case and
    surrounding spaces (``" Press"`` is 1); ``None`` for a label that names no action."""
    name = str(label).strip().lower()
    return ACTIONS.index(name) if name in ACTIONS else None


__all__ = ["ACTIONS", "BIN_S", "CHANNEL_SETS", "action_index"]
