"""Figure galleries of ``tactile report``: what a PNG shows, read from its name (issue 11).

The figure-writing commands name their files after what they draw (``tactile plot``:
``<file>__<trial>__events.png``; ``fit-fos --plot``: ``fos_press_<grade>.png``;
``slip-rate --plot``: ``slip_<trial>.png``; ``frames``: ``<trial>/contact_sheet.png``;
``grade --plot``: ``membership.png``, ``inference.png``, ``area_vs_level.png``;
``accumulate --plot DIR``: ``DIR/<trial>.png``; run folders: ``curves.png``,
``confusion_<head>.png``). :func:`describe_figure` turns such a path into a
:class:`FigureInfo`: the kind of figure (the gallery it belongs to, with a title that says
what it shows) and its subject within that kind (``trial g1_level06``). A file no rule
knows is captioned from its folder and name. :func:`group_figures` gathers the figures of
one kind into a :class:`Gallery`, in a fixed order of kinds; the report draws a gallery of
many near-duplicates (one per trial) as one grid of at most :data:`MAX_GRID` figures,
evenly spread, with the count.

Pure: paths in, dataclasses out (no file is opened here).
"""

from __future__ import annotations

import re
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path

from ..natural import natural_key
from ..vocabulary import FORCE_GRADES

#: At most this many figures of one kind are drawn; the rest are counted and listed.
MAX_GRID = 12
#: A gallery of more figures than this is drawn as a grid of small figures.
GRID_FROM = 3

_QUICKLOOK = re.compile(r"^(?P<file>.+)__(?P<trial>.+)__(?P<what>events|signals|frames)$")
_FOS = re.compile(r"^fos_(?P<region>press|slip)(?:_(?P<grade>.+))?$")
_FRAME = re.compile(r"^frame_(?P<k>\d+)$")
_SLIP = re.compile(r"^slip_(?P<trial>.+)$")
_CONFUSION = re.compile(r"^confusion_(?P<head>.+)$")

_QUICKLOOK_WHAT = {"events": "events per 20 ms and net polarity per pixel",
                   "signals": "sampled streams", "frames": "image frames"}
_FOS_TITLES = {"press": "first-order fits of the press region (eq. 16), one panel per trial",
               "slip": "first-order fits of the slip region (eq. 17), one panel per trial"}
_GRADE = {"membership": "membership functions of area and force (Figs. 20-21)",
          "inference": "one inference: firing strengths and the aggregate (Fig. 22)",
          "area_vs_level": "contact area against force level (Fig. 15)"}
#: Folders whose PNGs are one per trial, named after the trial (``accumulate --plot``).
_TRIAL_FOLDERS = {"counts": "event counts per bin with the action regions (Fig. 10)"}


@dataclass(frozen=True)
class FigureInfo:
    """What one PNG shows. ``key``: its gallery (same key, same kind of figure); ``title``:
    that gallery's title; ``subject``: what this figure of the kind is about (``trial
    g1_level06``); ``order``: where the gallery goes on the page (lower first); ``file``:
    the data file (stem) a quick look shows, else None."""

    path: Path
    key: tuple[str, ...]
    title: str
    subject: str
    order: int
    file: str | None = None
    rank: int | None = None  #: place among its gallery's figures, before name order

    @property
    def caption(self) -> str:
        """The full caption: ``<title>: <subject>``."""
        return f"{self.title}: {self.subject}" if self.subject else self.title


@dataclass
class Gallery:
    """The figures of one kind, in name order (natural: level2 before level10)."""

    key: tuple[str, ...]
    title: str
    order: int
    figures: list[FigureInfo] = field(default_factory=list)
    file: str | None = None

    @property
    def is_grid(self) -> bool:
        return len(self.figures) > GRID_FROM

    def shown(self) -> list[FigureInfo]:
        """The figures drawn: all, or :data:`MAX_GRID` evenly spread over them."""
        n = len(self.figures)
        if n <= MAX_GRID:
            return list(self.figures)
        picks = sorted({round(i * (n - 1) / (MAX_GRID - 1)) for i in range(MAX_GRID)})
        return [self.figures[i] for i in picks]


def _words(stem: str) -> str:
    return stem.replace("__", " / ").replace("_", " ")


def _quicklook(path: Path, stem: str, parent: str) -> FigureInfo | None:
    m = _QUICKLOOK.match(stem)
    if m is None:
        return None
    file = m["file"]
    return FigureInfo(path, ("quicklook", file), f"quick look: file {file}.h5",
                      f"trial {m['trial']}, {_QUICKLOOK_WHAT[m['what']]}", 80, file)


def _fos(path: Path, stem: str, parent: str) -> FigureInfo | None:
    m = _FOS.match(stem)
    if m is None:
        return None
    region = m["region"]
    grade = m["grade"]
    words = grade.replace("_", " ") if grade else None
    subject = f"force grade {words}" if words else "all trials"
    rank = FORCE_GRADES.index(words) if words in FORCE_GRADES else None
    return FigureInfo(path, ("fos", region), _FOS_TITLES[region], subject,
                      20 if region == "press" else 21, rank=rank)


def _frames(path: Path, stem: str, parent: str) -> FigureInfo | None:
    if stem == "contact_sheet":
        return FigureInfo(path, ("contact_sheet",), "event frames with the ROIs (contact "
                          "sheet, Fig. 13)", f"trial {parent}" if parent else "", 30)
    m = _FRAME.match(stem)
    if m is None:
        return None
    return FigureInfo(path, ("frames", parent), f"event frames of trial {parent}"
                      if parent else "event frames", f"frame {int(m['k'])}", 31)


def _slip(path: Path, stem: str, parent: str) -> FigureInfo | None:
    m = _SLIP.match(stem)
    if m is None or stem == "slip_rate":
        return None
    return FigureInfo(path, ("slip",), "slip: ROI centroids, velocity (eq. 20) and "
                      "displacement (eq. 21) over the slip region (Fig. 23)",
                      f"trial {m['trial']}", 40)


def _grade(path: Path, stem: str, parent: str) -> FigureInfo | None:
    if stem not in _GRADE:
        return None
    return FigureInfo(path, ("grade",), "fuzzy force grading", _GRADE[stem], 50)


def _per_trial_folder(path: Path, stem: str, parent: str) -> FigureInfo | None:
    if parent not in _TRIAL_FOLDERS:
        return None
    return FigureInfo(path, ("trial_folder", parent), _TRIAL_FOLDERS[parent],
                      f"trial {stem}", 10)


def _learning(path: Path, stem: str, parent: str) -> FigureInfo | None:
    if stem == "curves":
        return FigureInfo(path, ("curves",), "training curves: loss and validation accuracy "
                          "per epoch", f"run {parent}" if parent else "", 60)
    if stem == "compare":
        return FigureInfo(path, ("compare",), "accuracy against latency per window",
                          f"comparison {parent}" if parent else "", 61)
    if stem == "perturb":
        return FigureInfo(path, ("perturb",), "accuracy against perturbation level",
                          f"{parent}" if parent else "", 62)
    m = _CONFUSION.match(stem)
    if m is None:
        return None
    return FigureInfo(path, ("confusion", m["head"]), f"confusion matrix of {m['head']} "
                      "(rows true, columns predicted)", f"evaluation {parent}"
                      if parent else "", 63)


_Rule = Callable[[Path, str, str], "FigureInfo | None"]
#: Tried in this order; the first that knows the name wins.
RULES: tuple[_Rule, ...] = (_quicklook, _fos, _frames, _slip, _grade, _per_trial_folder,
                            _learning)


def describe_figure(rel: str | Path) -> FigureInfo:
    """What the PNG at ``rel`` (relative to its figure folder) shows (see the module
    docstring); a name no rule knows: its folder as the kind, its name in words as the
    subject."""
    rel = Path(rel)
    stem, parent = rel.stem, rel.parent.name
    for rule in RULES:
        info = rule(rel, stem, parent)
        if info is not None:
            return info
    folder = rel.parent.as_posix()
    title = f"figures in {folder}" if folder != "." else "other figures"
    return FigureInfo(rel, ("folder", folder), title, _words(stem), 90)


def group_figures(rel_paths: Sequence[str | Path],
                  file_rank: Mapping[str, int] | None = None) -> list[Gallery]:
    """The galleries of ``rel_paths``: one per kind, ordered by kind (quick looks by
    ``file_rank[file stem]``, then by name; unranked files last), figures in the force grades'
    order (paper 000's Table III) where their names carry one, else in natural name order."""
    rank = file_rank or {}
    by_key: dict[tuple[str, ...], Gallery] = {}
    for rel in rel_paths:
        info = describe_figure(rel)
        g = by_key.setdefault(info.key, Gallery(info.key, info.title, info.order,
                                                file=info.file))
        g.figures.append(info)
    for g in by_key.values():
        # the paper's grades lightest first (light, small, ..., big), the rest by name
        g.figures.sort(key=lambda f: (f.rank is None, f.rank or 0,
                                      natural_key(f.path.as_posix())))

    def order(g: Gallery) -> tuple[int, int, tuple[object, ...]]:
        file_order = rank.get(g.file, len(rank)) if g.file is not None else 0
        return (g.order, file_order, natural_key(" ".join(g.key)))

    return sorted(by_key.values(), key=order)


__all__ = ["GRID_FROM", "MAX_GRID", "RULES", "FigureInfo", "Gallery", "describe_figure",
           "group_figures"]
