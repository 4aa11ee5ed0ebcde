"""Where the trials of tactile files come from: recorded, simulated or synthetic (issue 11).

The convention: every trial may carry the trial labels

- ``origin``: one of :data:`ORIGINS`: ``recorded`` (a sensor's recording of the world),
  ``simulated`` (raw recordings of a simulated scene with known ground truth, such as
  ``tactile simulate marker-events``) or ``synthetic`` (model-based or generated training
  data, such as ``tactile synth`` and ``tactile samples``);
- ``dataset``: the name of the data set (``biotac_slide20``, ``marker-events seed 1``);
- ``lab``: for recorded data, who recorded it and the paper that describes it.

The producers set them: ``tactile simulate marker-events`` writes the columns ``origin``
and ``dataset`` into its ``trials.csv`` (ingested with ``--trial-labels``), ``tactile synth``
labels every trial it writes, the mappings of the real recordings
(``configs/xela_slip.yaml``, ``configs/biotac_slide20.yaml``) label theirs, and the demo
ingests ``tactile samples`` output with ``--label origin=synthetic``. Files derived trial
by trial (``tactile centroids``) keep the labels.

:func:`data_origin` reads the labels through the one trial reader. A trial without an
``origin`` label is ``synthetic`` when the file's root ``command`` attribute names a
command that only writes synthetic trials (``tactile synth``), else ``unknown``: an origin
is never guessed to be ``recorded``.
"""

from __future__ import annotations

import shlex
from collections import Counter
from collections.abc import Iterable, Mapping, Sequence
from pathlib import Path
from typing import Any

from ..errors import InputError
from .trials import TactileFile

#: The values of the trial label ``origin``, in the order a report lists them.
ORIGINS = ("recorded", "simulated", "synthetic")
#: What :func:`data_origin` says beyond :data:`ORIGINS`.
MIXED = "mixed"
UNKNOWN = "unknown"
#: Trial label names of the convention.
ORIGIN_LABEL, DATASET_LABEL, LAB_LABEL = "origin", "dataset", "lab"

#: ``tactile <command>`` -> the origin of every trial a file it wrote holds.
_COMMAND_ORIGINS = {"synth": "synthetic"}


def command_origin(command: str) -> str | None:
    """The origin a file's root ``command`` attribute implies (``tactile synth ...``:
    ``synthetic``), or None when the command says nothing about it."""
    try:
        argv = shlex.split(command or "")
    except ValueError:
        argv = (command or "").split()
    words = [a for a in argv[1:] if not a.startswith("-")]
    if not argv or Path(argv[0]).name not in ("tactile", "__main__.py") or not words:
        return None
    return _COMMAND_ORIGINS.get(words[0])


def _trial_kind(labels: Mapping[str, Any], fallback: str | None,
                notes: list[str]) -> str:
    """One trial's origin: its label, else ``fallback``, else unknown."""
    value = labels.get(ORIGIN_LABEL)
    if value is None:
        return fallback or UNKNOWN
    text = str(value).strip().lower()
    if text in ORIGINS:
        return text
    note = (f"label {ORIGIN_LABEL}={value!r} is not one of {', '.join(ORIGINS)} "
            "(taken as unknown)")
    if note not in notes:
        notes.append(note)
    return UNKNOWN


def combine(kinds: Iterable[str]) -> str:
    """One origin for several: the common one, ``mixed`` when they differ, ``unknown``
    when there are none."""
    found = set(kinds)
    if not found:
        return UNKNOWN
    return found.pop() if len(found) == 1 else MIXED


def _distinct(values: Iterable[Any]) -> list[str]:
    """The distinct non-empty values as text, sorted."""
    return sorted({str(v) for v in values if v is not None and str(v).strip()})


def file_origin(file: TactileFile) -> dict[str, Any]:
    """The origin of one open file's trials (JSON-ready): ``path``, ``kind`` (an origin,
    ``mixed`` or ``unknown``), ``n_trials``, ``trials`` (origin -> number of trials),
    ``datasets`` and ``labs`` (distinct labels), ``from`` (``labels``, ``command``, both
    joined by ``+``, or ``none``: what the kind was read from) and ``notes``."""
    notes: list[str] = []
    fallback = command_origin(str(file.attrs.get("command", "")))
    counts: Counter[str] = Counter()
    used: set[str] = set()
    datasets, labs = [], []
    for trial in file.trials():
        labels = trial.labels
        counts[_trial_kind(labels, fallback, notes)] += 1
        used.add("labels" if ORIGIN_LABEL in labels else
                 "command" if fallback is not None else "none")
        datasets.append(labels.get(DATASET_LABEL))
        labs.append(labels.get(LAB_LABEL))
    kind = combine(counts)
    if not counts:
        notes.append("the file holds no trials")
        kind = fallback or UNKNOWN
        used.add("command" if fallback is not None else "none")
    return {"path": str(file.path), "kind": kind,
            "n_trials": sum(counts.values()), "trials": dict(sorted(counts.items())),
            "datasets": _distinct(datasets), "labs": _distinct(labs),
            "from": "+".join(sorted(used - {"none"})) or "none", "notes": notes}


def _unreadable(path: Path, why: str) -> dict[str, Any]:
    return {"path": str(path), "kind": UNKNOWN, "n_trials": 0, "trials": {}, "datasets": [],
            "labs": [], "from": "none", "notes": [why]}


def data_origin(paths: Sequence[str | Path]) -> dict[str, Any]:
    """Where the trials of ``paths`` come from (JSON-ready)::

        {"kind": "recorded" | "simulated" | "synthetic" | "mixed" | "unknown",
         "datasets": [...], "labs": [...], "files": [file_origin(...) per path]}

    ``kind`` is the origin every trial of every file shares, ``mixed`` when they differ
    (``unknown`` trials included) and ``unknown`` for no files. A file that is missing or
    cannot be read counts as ``unknown`` with a note saying why; this never raises for one
    bad file (it describes data that may have moved since it was used)."""
    files = []
    for p in paths:
        path = Path(p)
        try:
            with TactileFile(path) as f:
                files.append(file_origin(f))
        except InputError as exc:
            files.append(_unreadable(path, f"not read: {exc.message}"))
    return {"kind": combine(f["kind"] for f in files),
            "datasets": _distinct(d for f in files for d in f["datasets"]),
            "labs": _distinct(lab for f in files for lab in f["labs"]),
            "files": files}


def unknown_origin(paths: Sequence[str | Path], why: str) -> dict[str, Any]:
    """The record of :func:`data_origin` for files that cannot be looked at (``why``)."""
    files = [_unreadable(Path(p), why) for p in paths]
    return {"kind": UNKNOWN, "datasets": [], "labs": [], "files": files}


def _texts_or(value: Any, kind: type) -> list[Any]:
    """The items of list ``value`` that are of type ``kind`` (a stored record may be old or
    damaged: describing it must not fail)."""
    return [v for v in value if isinstance(v, kind)] if isinstance(value, list) else []


def describe_origin(origin: Mapping[str, Any]) -> str:
    """One line for people: ``recorded: biotac_slide20 · Gao et al., IROS 2020``,
    ``simulated: marker-events seed 1``, ``mixed: recorded (a.h5), synthetic (b.h5)``,
    ``unknown (no origin label)``."""
    kind = str(origin.get("kind") or UNKNOWN)
    files = _texts_or(origin.get("files"), dict)
    if kind == MIXED:
        parts = [f"{f.get('kind')} ({Path(str(f.get('path'))).name})" for f in files]
        return f"{MIXED}: " + ", ".join(parts) if parts else MIXED
    if kind == UNKNOWN:
        why = next((n for f in files for n in _texts_or(f.get("notes"), str)),
                   f"no {ORIGIN_LABEL} label on the trials")
        return f"{UNKNOWN} ({why})"
    what = ", ".join(_texts_or(origin.get("datasets"), str))
    labs = "; ".join(_texts_or(origin.get("labs"), str))
    text = f"{kind}: {what}" if what else kind
    return f"{text} · {labs}" if labs else text


__all__ = ["DATASET_LABEL", "LAB_LABEL", "MIXED", "ORIGINS", "ORIGIN_LABEL", "UNKNOWN",
           "combine", "command_origin", "data_origin", "describe_origin", "file_origin",
           "unknown_origin"]
