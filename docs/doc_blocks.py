"""The fenced code blocks of the documentation pages and the markers that say how each runs.

The rule (``docs/contributing-docs.md``): each fenced shell or Python block (``sh``, ``bash``,
``python``, and a fence with no language, which could be either) of
``docs/**/*.md`` and ``README.md`` sits right under one of these HTML comments:

- ``<!-- run -->``: cheap (seconds); ``tests/docs`` runs it, and ``make docs-figures`` too;
- ``<!-- figures -->``: a step that makes the page's figures (seconds to minutes):
  ``make docs-figures`` (``docs/make_figures.py``) runs it, the fast tests do not;
- ``<!-- not run: REASON -->``: shown only; REASON says why (minutes of training, a cluster,
  data only a lab has) and where it is run instead, if anywhere;
- ``<!-- file: PATH -->`` (any block, YAML and CSV too): the block's text is written to PATH
  before the blocks after it run.

A page's blocks run in order in one fresh folder (a page is one session), with ``tactile``
on ``PATH`` and ``configs/`` the repository's. A ``run`` block must not need the output of a
``figures`` block, since the tests run the ``run`` blocks alone.
"""

from __future__ import annotations

import os
import re
import subprocess
import sys
from collections.abc import Collection
from dataclasses import dataclass
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
DOCS = REPO / "docs"
CODE_LANGUAGES = {"sh", "bash", "shell", "console", "python", "py", "pycon", ""}
MARKERS = {"run", "figures", "not run", "file"}
_FENCE = re.compile(r"^(?P<indent> *)```(?P<lang>[\w-]*)[^\n]*$")
_MARKER = re.compile(
    r"^\s*<!--\s*(?P<kind>run|figures|not run|file)\s*(?::\s*(?P<arg>.*?))?\s*-->\s*$")


@dataclass(frozen=True)
class Block:
    """One fenced block of a page: its language, text, line and the marker above it."""

    page: Path
    line: int  # 1-based line of the opening fence
    lang: str
    text: str
    marker: str | None  # one of MARKERS, or None
    arg: str  # the reason of "not run", the path of "file"

    def where(self) -> str:
        try:
            return f"{self.page.relative_to(REPO)}:{self.line}"
        except ValueError:
            return f"{self.page}:{self.line}"


def blocks_of(page: Path) -> list[Block]:
    """The fenced blocks of a Markdown page, each with the marker comment right above it."""
    lines = page.read_text(encoding="utf-8").splitlines()
    found: list[Block] = []
    i = 0
    while i < len(lines):
        fence = _FENCE.match(lines[i])
        if not fence:
            i += 1
            continue
        indent = len(fence["indent"])
        j = i + 1
        while j < len(lines) and lines[j].strip() != "```":
            j += 1
        body = "\n".join(line[indent:] for line in lines[i + 1:j]) + "\n"
        marker = _MARKER.match(lines[i - 1]) if i > 0 else None
        found.append(Block(page, i + 1, fence["lang"], body,
                           marker["kind"] if marker else None,
                           (marker["arg"] or "").strip() if marker else ""))
        i = j + 1
    return found


def doc_pages() -> list[Path]:
    """Every page whose blocks follow the rule: the site's pages and the README."""
    return sorted(DOCS.rglob("*.md")) + [REPO / "README.md"]


def environment() -> dict[str, str]:
    """The environment the blocks run in: this interpreter's ``tactile`` first on PATH."""
    env = dict(os.environ)
    env["PATH"] = f"{Path(sys.executable).parent}{os.pathsep}{env.get('PATH', '')}"
    env.update({"COLUMNS": "100", "MPLBACKEND": "Agg"})
    return env


class BlockFailed(RuntimeError):
    """A block exited non-zero; the message holds the block and the end of its output."""


def run_page(page: Path, workdir: Path, kinds: Collection[str] = ("run",),
             timeout_s: float = 600) -> list[Block]:
    """Run the blocks of ``page`` whose marker is in ``kinds`` (and every ``file`` block), in
    order, in ``workdir``; return the blocks run. Raises :class:`BlockFailed` at the first
    block that fails."""
    workdir.mkdir(parents=True, exist_ok=True)
    configs = workdir / "configs"
    if not configs.exists():
        configs.symlink_to(REPO / "configs")
    env = environment()
    done: list[Block] = []
    for block in blocks_of(page):
        if block.marker == "file":
            target = workdir / block.arg
            target.parent.mkdir(parents=True, exist_ok=True)
            target.write_text(block.text, encoding="utf-8")
            continue
        if block.marker not in kinds:
            continue
        if block.lang == "python":
            argv = [sys.executable, "-c", block.text]
        else:
            argv = ["bash", "-euo", "pipefail", "-c", block.text]
        proc = subprocess.run(argv, cwd=workdir, env=env, capture_output=True, text=True,
                              timeout=timeout_s)
        if proc.returncode != 0:
            raise BlockFailed(f"{block.where()} failed ({proc.returncode}):\n{block.text}"
                              f"--- stdout\n{proc.stdout[-3000:]}\n"
                              f"--- stderr\n{proc.stderr[-3000:]}")
        done.append(block)
    return done
