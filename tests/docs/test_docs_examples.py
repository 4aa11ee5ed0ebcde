"""Every example of the documentation runs, or says why it does not (issue 32, item 4).

The rule is in ``docs/doc_blocks.py`` (and docs/contributing-docs.md): each ``sh``/``python``
block of the site and the README is marked ``run`` (run here), ``figures`` (run by
``make docs-figures``) or ``not run: REASON``. This file runs the ``run`` blocks of every
page in a fresh folder, and fails on a block without a marker or a reason.
"""

from __future__ import annotations

import importlib.util
import sys
from pathlib import Path

import pytest

DOCS = Path(__file__).resolve().parents[2] / "docs"


def _load(name: str):
    if name in sys.modules:
        return sys.modules[name]
    spec = importlib.util.spec_from_file_location(name, DOCS / f"{name}.py")
    module = importlib.util.module_from_spec(spec)
    sys.modules[name] = module
    spec.loader.exec_module(module)
    return module


doc_blocks = _load("doc_blocks")


def test_every_code_block_is_run_or_says_why_not():
    blocks = [b for p in doc_blocks.doc_pages() for b in doc_blocks.blocks_of(p)]
    unmarked = [b.where() for b in blocks
                if b.lang in doc_blocks.CODE_LANGUAGES and b.marker is None]
    no_reason = [b.where() for b in blocks if b.marker == "not run" and len(b.arg) < 10]
    assert not unmarked, f"code blocks without <!-- run --> or <!-- not run: why -->: {unmarked}"
    assert not no_reason, f"<!-- not run --> needs a reason: {no_reason}"
    assert sum(b.marker == "run" for b in blocks) >= 8, "the docs should show examples that run"
    assert sum(b.marker == "figures" for b in blocks) >= 5


def test_marker_parser_reads_every_kind(tmp_path):
    page = tmp_path / "p.md"
    page.write_text("<!-- run -->\n```sh\necho a\n```\n\n<!-- not run: needs a GPU -->\n"
                    "```python\nx = 1\n```\n<!-- file: m.yaml -->\n"
                    "```yaml title=\"m.yaml\"\na: 1\n```\n"
                    "<!-- figures -->\n  ```sh\n  slow\n  ```\n```sh\nbare\n```\n",
                    encoding="utf-8")
    got = [(b.lang, b.marker, b.arg, b.text) for b in doc_blocks.blocks_of(page)]
    assert got == [("sh", "run", "", "echo a\n"), ("python", "not run", "needs a GPU", "x = 1\n"),
                   ("yaml", "file", "m.yaml", "a: 1\n"), ("sh", "figures", "", "slow\n"),
                   ("sh", None, "", "bare\n")]


def test_a_failing_block_fails_with_its_page_and_line(tmp_path):
    page = tmp_path / "p.md"
    page.write_text("<!-- file: a.txt -->\n```text\nhello\n```\n<!-- run -->\n```sh\n"
                    "grep -q hello a.txt\n```\n<!-- figures -->\n```sh\nfalse\n```\n"
                    "<!-- run -->\n```python\nraise SystemExit(3)\n```\n", encoding="utf-8")
    with pytest.raises(doc_blocks.BlockFailed, match=r"p\.md:14 failed \(3\)"):
        doc_blocks.run_page(page, tmp_path / "w")


def _runnable_pages() -> list[Path]:
    return [p for p in doc_blocks.doc_pages()
            if any(b.marker == "run" for b in doc_blocks.blocks_of(p))]


@pytest.mark.slow
@pytest.mark.parametrize("page", _runnable_pages(),
                         ids=lambda p: str(p.relative_to(doc_blocks.REPO)))
def test_runnable_examples_of_a_page_pass(page, tmp_path):
    ran = doc_blocks.run_page(page, tmp_path, kinds=("run",), timeout_s=120)
    assert ran and all(b.marker == "run" for b in ran)
