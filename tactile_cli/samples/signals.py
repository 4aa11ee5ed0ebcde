"""Small synthetic sampled-signal recordings: an accelerometer CSV tree, a mapped-CSV taxel array.

Each writer puts a few kB of raw files on disk and returns the ground truth it wrote, so a
test can ingest the files and compare exactly. Values are drawn as float32 and written with
9 significant digits, which read back to the same float32 numbers. Deterministic for a
given ``seed``.

- :func:`write_accel_tree`: the layout of paper 001 (sec. 4), ``object/orientation/speed/``
  folders with one 8-column CSV each (6 accelerations in [-1, 1] of +-5 g, slip and slide
  velocity in m/s, 8 kHz), alternating with and without a header row. The velocities are
  built segment by segment from an intended motion class, including samples exactly at the
  5 cm/s threshold and samples where both motions exceed it (expected: ``slip``).
- :func:`write_taxel_recording`: a 4 x 4 taxel array at 100 Hz in kPa with epoch
  timestamps and a text slip label, one CSV per trial, plus the YAML mapping that ingests it.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

#: Intended motion classes, in the code order of the ingest's ``motion`` label.
MOTION_CLASSES = ("no_motion", "slide", "slip")
ACCEL_RATE_HZ = 8000.0
TAXEL_RATE_HZ = 100.0
TAXEL_SLIP_CLASSES = ("stick", "slip")
#: Segment kinds of the synthetic velocities -> the motion class the ingest must give.
_SEGMENTS = {
    "no_motion": "no_motion",
    "slide": "slide",
    "slip": "slip",
    "both": "slip",  # both speeds above 5 cm/s: slip wins
    "edge_slip": "slip",  # |v_slip| exactly 0.05 m/s counts as moving
    "edge_slide": "slide",  # |v_slide| = 0.05 m/s, |v_slip| just below
}
#: Header of the files that have one: names unlike the ingest's, which reads by position.
_ACCEL_HEADER = ("acc_l_x", "acc_l_y", "acc_l_z", "acc_r_x", "acc_r_y", "acc_r_z",
                 "slip_v", "slide_v")
_SEGMENT_ORDER = ("no_motion", "slide", "slip", "both", "edge_slip", "edge_slide")


def _fmt(values: np.ndarray) -> np.ndarray:
    """Text of float32 values with 9 significant digits (reads back to the same float32)."""
    return np.char.mod("%.9g", values.astype(np.float64))


def _velocities(n: int, rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    """(n, 2) float32 (v_slip, v_slide) in m/s and (n,) int8 intended motion codes."""
    seg_len = max(1, n // (2 * len(_SEGMENT_ORDER)))
    kinds = np.resize(np.repeat(np.arange(len(_SEGMENT_ORDER)), seg_len), n)
    slow = rng.uniform(-0.045, 0.045, size=(n, 2))
    fast = rng.uniform(0.06, 0.35, size=(n, 2)) * rng.choice([-1.0, 1.0], size=(n, 2))
    v = slow.copy()
    kind = np.array(_SEGMENT_ORDER)[kinds]
    v[kind == "slide", 1] = fast[kind == "slide", 1]
    v[kind == "slip", 0] = fast[kind == "slip", 0]
    v[kind == "both"] = fast[kind == "both"]
    edge = kind == "edge_slip"
    v[edge, 0] = np.where(np.arange(edge.sum()) % 2, 0.05, -0.05)
    edge = kind == "edge_slide"
    v[edge, 0] = 0.0499
    v[edge, 1] = -0.05
    # float32 0.05 is 0.0500000007; the written 9-digit text keeps it at or above 0.05
    codes = np.array([MOTION_CLASSES.index(_SEGMENTS[k]) for k in _SEGMENT_ORDER], dtype=np.int8)
    return v.astype(np.float32), codes[kinds]


def write_accel_tree(root: str | Path, *, objects: tuple[str, ...] = ("wood", "aluminum"),
                     orientations: tuple[str, ...] = ("0", "30"),
                     speeds: tuple[str, ...] = ("0.16",), seconds: float = 0.02,
                     seed: int = 0) -> dict[str, Any]:
    """Write ``root/<object>/<orientation>/<speed>/data.csv`` files; returns the ground truth.

    Returns ``{"root", "sample_rate_hz", "trials": {name: {...}}}`` where each trial (named
    ``<object>_<orientation>_<speed>``, as the ingest names it) holds ``path``, ``labels``,
    ``header`` (whether the file has a header row), ``accel`` (n, 6) float32 in [-1, 1] of
    +-5 g, ``velocity`` (n, 2) float32 m/s and ``motion`` (n,) int8 codes of
    :data:`MOTION_CLASSES`. n = round(seconds x 8 kHz).
    """
    root = Path(root)
    rng = np.random.default_rng(seed)
    n = max(1, round(seconds * ACCEL_RATE_HZ))
    trials: dict[str, Any] = {}
    k = 0
    for obj in objects:
        for orientation in orientations:
            for speed in speeds:
                folder = root / obj / orientation / speed
                folder.mkdir(parents=True, exist_ok=True)
                t = np.arange(n) / ACCEL_RATE_HZ
                accel = (0.3 * np.sin(2 * np.pi * 230.0 * t)[:, None]
                         + rng.normal(0, 0.05, size=(n, 6))).clip(-1, 1).astype(np.float32)
                velocity, motion = _velocities(n, rng)
                header = k % 2 == 0
                cells = _fmt(np.hstack([accel, velocity]))
                lines = [",".join(row) for row in cells]
                if header:
                    lines.insert(0, ",".join(_ACCEL_HEADER))
                path = folder / "data.csv"
                path.write_text("\n".join(lines) + "\n")
                trials[f"{obj}_{orientation}_{speed}"] = {
                    "path": path, "header": header, "accel": accel, "velocity": velocity,
                    "motion": motion,
                    "labels": {"object": obj, "orientation": orientation, "speed": speed}}
                k += 1
    return {"root": root, "sample_rate_hz": ACCEL_RATE_HZ, "trials": trials}


TAXEL_MAPPING_YAML = """\
# Synthetic 4 x 4 taxel array (tactile_cli.samples.signals.write_taxel_recording).
version: 1
trials:
  layout: file
  glob: "*.csv"
  pattern: '(?P<object>[a-z]+)_(?P<rep>\\d+)\\.csv$'
  name: "{object}_{rep}"
  labels: {setup: synthetic}
streams:
  - name: taxels
    file: "{object}_{rep}.csv"
    kind: taxel_array
    description: "synthetic 4 x 4 pressure taxels"
    channels: ["p_r*"]
    units: kPa
    time: {column: timestamp, unit: s, epoch: true}
    sample_labels:
      - {name: slip, column: state, classes: [stick, slip]}
"""


def write_taxel_recording(root: str | Path, *, objects: tuple[str, ...] = ("foam", "wood"),
                          repeats: int = 2, seconds: float = 0.5, seed: int = 0) -> dict[str, Any]:
    """Write one CSV per trial (``<object>_<rep>.csv``) and ``taxels.yaml``; returns the truth.

    Columns: ``timestamp`` (Unix s, 100 Hz, 6 decimals), ``p_r<row>c<col>`` (16 taxels, kPa),
    ``state`` (``stick``/``slip``). Returns ``{"mapping", "channels", "classes",
    "sample_rate_hz", "trials": {name: {...}}}`` where each trial holds ``path``,
    ``labels``, ``data`` (n, 16) float32 kPa, ``t_s`` (n,) s from the first sample,
    ``time_origin_unix_s`` and ``slip`` (n,) int8 codes of ``classes``.
    """
    root = Path(root)
    root.mkdir(parents=True, exist_ok=True)
    rng = np.random.default_rng(seed)
    n = max(2, round(seconds * TAXEL_RATE_HZ))
    channels = [f"p_r{r}c{c}" for r in range(4) for c in range(4)]
    trials: dict[str, Any] = {}
    k = 0
    for obj in objects:
        for rep in range(1, repeats + 1):
            origin = 1_700_000_000.0 + 100.0 * k
            stamp = _fmt_fixed(origin + np.arange(n) / TAXEL_RATE_HZ)
            load = np.linspace(0.0, 12.0, n)[:, None] * rng.uniform(0.5, 1.5, size=(1, 16))
            data = (load + rng.normal(0.0, 0.2, size=(n, 16))).astype(np.float32)
            slip = np.zeros(n, dtype=np.int8)
            slip[n // 2: n // 2 + max(1, n // 5)] = 1
            cells = np.column_stack([stamp, _fmt(data), np.array(TAXEL_SLIP_CLASSES)[slip]])
            path = root / f"{obj}_{rep}.csv"
            lines = [",".join(["timestamp", *channels, "state"])] + [",".join(r) for r in cells]
            path.write_text("\n".join(lines) + "\n")
            t_read = stamp.astype(np.float64)
            trials[f"{obj}_{rep}"] = {
                "path": path, "data": data, "t_s": t_read - t_read[0],
                "time_origin_unix_s": float(t_read[0]), "slip": slip,
                "labels": {"object": obj, "rep": str(rep), "setup": "synthetic"}}
            k += 1
    mapping = root / "taxels.yaml"
    mapping.write_text(TAXEL_MAPPING_YAML)
    return {"mapping": mapping, "channels": channels, "classes": list(TAXEL_SLIP_CLASSES),
            "sample_rate_hz": TAXEL_RATE_HZ, "trials": trials}


def _fmt_fixed(values: np.ndarray) -> np.ndarray:
    return np.char.mod("%.6f", values)


__all__ = ["MOTION_CLASSES", "TAXEL_MAPPING_YAML", "write_accel_tree", "write_taxel_recording"]
