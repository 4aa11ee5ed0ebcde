"""Draw the figures of the tutorial pages by running the tutorials' own commands.

    .venv/bin/python docs/make_figures.py [--keep DIR] [PAGE ...]     (make docs-figures)

For each page below, every ``run`` and ``figures`` block of the page runs in order in a
fresh folder (``docs/doc_blocks.py``: the same commands a reader types), then the figures
the page shows are copied from that folder into ``docs/figures/<page>/``, scaled down to at
most :data:`MAX_WIDTH_PX` pixels wide. The PNGs are committed, so the site builds in seconds
without rerunning the chains; a change that breaks a tutorial's commands breaks this script
(and the ``run`` blocks break ``tests/docs``). A figure a page shows that is not listed here
fails ``tests/docs/test_figures.py``: no figure is drawn by hand.
"""

from __future__ import annotations

import argparse
import shutil
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

import doc_blocks  # noqa: E402  (docs/ is not a package)

MAX_WIDTH_PX = 1000

#: Page (relative to docs/) -> {figure written into docs/figures/<stem>/: glob of the file
#: the page's commands write, relative to the page's working folder (first match taken)}.
FIGURES: dict[str, dict[str, str]] = {
    "getting-started.md": {},
    "tutorials/event-camera.md": {
        "counts.png": "counts/g1_level06.png",
        "fits_press.png": "fits/fos_press_small_medium.png",
        "fits_slip.png": "fits/fos_slip_small_medium.png",
        "frames.png": "frames/*/contact_sheet.png",
        "slip.png": "slip/slip_g1_level06.png",
        "grade.png": "grade/area_vs_level.png",
    },
    "tutorials/accelerometer.md": {
        "quicklook.png": "quicklook/*.png",
    },
    "tutorials/visuotactile.md": {
        "calibration.png": "calibration/*.png",
        "heightmap.png": "heightmaps/*.png",
        "slip_height.png": "slip_height/slip_cable_01_height.png",
        "monitor.png": "monitor/*.png",
    },
    "tutorials/active-vibration.md": {
        "model_spectra.png": "model_spectra.png",
        "detections.png": "detections.png",
    },
    "tutorials/taxel-arrays.md": {
        "features.png": "features.png",
    },
}


def figure_folder(page: str) -> Path:
    return doc_blocks.DOCS / "figures" / Path(page).stem


def _save_scaled(source: Path, target: Path) -> None:
    from PIL import Image

    target.parent.mkdir(parents=True, exist_ok=True)
    with Image.open(source) as image:
        if image.width > MAX_WIDTH_PX:
            height = round(image.height * MAX_WIDTH_PX / image.width)
            image = image.resize((MAX_WIDTH_PX, height), Image.Resampling.LANCZOS)
        image.save(target, optimize=True)


def make_page(page: str, workdir: Path, run: bool = True) -> list[Path]:
    """Run ``page``'s ``run`` and ``figures`` blocks in ``workdir`` (unless ``run`` is
    False: the folder of an earlier ``--keep``); copy its figures into docs/figures/."""
    if run:
        doc_blocks.run_page(doc_blocks.DOCS / page, workdir, kinds=("run", "figures"))
    written = []
    for name, pattern in FIGURES[page].items():
        matches = sorted(workdir.glob(pattern))
        if not matches:
            raise SystemExit(f"{page}: no file matches {pattern} in {workdir}")
        target = figure_folder(page) / name
        _save_scaled(matches[0], target)
        written.append(target)
    return written


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("pages", nargs="*", help="pages to redraw (default: all)")
    parser.add_argument("--keep", type=Path, help="work in DIR and keep it (default: a "
                        "temporary folder, removed)")
    parser.add_argument("--copy-only", action="store_true", help="run nothing: copy the "
                        "figures from the folders an earlier run left in --keep DIR")
    args = parser.parse_args(argv)
    if args.copy_only and args.keep is None:
        parser.error("--copy-only needs --keep DIR")
    pages = args.pages or list(FIGURES)
    unknown = [p for p in pages if p not in FIGURES]
    if unknown:
        parser.error(f"unknown pages {unknown}; known: {list(FIGURES)}")
    root = args.keep or Path(tempfile.mkdtemp(prefix="tactile-docs-"))
    try:
        for page in pages:
            start = time.perf_counter()
            try:
                written = make_page(page, root / Path(page).stem, run=not args.copy_only)
            except doc_blocks.BlockFailed as exc:
                print(exc, file=sys.stderr)
                return 1
            names = ", ".join(p.name for p in written) or "no figures (its blocks ran)"
            print(f"{page}: {names} ({time.perf_counter() - start:.0f} s)")
    finally:
        if args.keep is None:
            shutil.rmtree(root, ignore_errors=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
