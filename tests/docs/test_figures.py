"""The tutorial figures are drawn by the tutorials' commands, none by hand (issue 32, item 3)."""

from __future__ import annotations

import re

from .test_docs_examples import DOCS, _load

make_figures = _load("make_figures")


def _shown_figures() -> set[tuple[str, str]]:
    """(page stem, file name) of every image of docs/figures/ a page shows."""
    shown = set()
    for page in DOCS.rglob("*.md"):
        for folder, name in re.findall(r"\]\((?:\.\./)*figures/([\w-]+)/([\w.-]+\.png)\)",
                                       page.read_text(encoding="utf-8")):
            shown.add((folder, name))
    return shown


def test_every_figure_shown_is_made_by_a_page_and_committed():
    made = {(make_figures.figure_folder(page).name, name)
            for page, figures in make_figures.FIGURES.items() for name in figures}
    shown = _shown_figures()
    assert len(shown) >= 10
    assert shown <= made, f"figures no script draws: {sorted(shown - made)}"
    missing = [f"{folder}/{name}" for folder, name in shown
               if not (DOCS / "figures" / folder / name).is_file()]
    assert not missing, f"run `make docs-figures` to draw {missing}"


def test_every_page_with_figures_has_blocks_that_make_them():
    for page, figures in make_figures.FIGURES.items():
        kinds = {b.marker for b in make_figures.doc_blocks.blocks_of(DOCS / page)}
        assert kinds & {"run", "figures"}, f"{page}: no block makes its figures {figures}"
