"""MkDocs hooks of the tactile documentation site (``hooks:`` in mkdocs.yml).

- Generated pages: a page whose Markdown holds ``<!-- generated: commands -->``,
  ``<!-- generated: api -->`` or ``<!-- generated: schema -->`` gets that marker replaced by
  the reference rendered from the code (``docs/reference_gen.py``), so the command, API and
  schema references cannot drift from the package.
- The benchmark results: ``benchmarks/RESULTS.md`` and the figures it shows are added to the
  site as ``benchmarks/RESULTS.md`` (not copied into docs/), so a tutorial's "speed against
  accuracy" and "where it breaks" sections link to the measured tables themselves.
"""

from __future__ import annotations

import sys
from pathlib import Path

from mkdocs.structure.files import File, Files

DOCS = Path(__file__).resolve().parent
REPO = DOCS.parent
sys.path.insert(0, str(DOCS))

import reference_gen  # noqa: E402  (docs/ is not a package)

_GENERATORS = {
    "commands": reference_gen.command_reference,
    "api": reference_gen.api_reference,
    "schema": reference_gen.schema_reference,
}

#: Files of the repository that the site shows as they are, by their path in the site.
_BENCHMARK_FILES = ["benchmarks/RESULTS.md"] + [
    f"benchmarks/figures/{name}" for name in (
        "vibro_bandwidth.png", "sweep_vibro_speed_accuracy.png",
        "sweep_vibro_accuracy_vs_window.png", "biotac_inputs.png")
]


def on_files(files: Files, config) -> Files:
    for rel in _BENCHMARK_FILES:
        files.append(File.generated(config, rel, abs_src_path=str(REPO / rel)))
    return files


def on_page_markdown(markdown: str, page, config, files) -> str:
    for name, generate in _GENERATORS.items():
        marker = f"<!-- generated: {name} -->"
        if marker in markdown:
            markdown = markdown.replace(marker, generate())
    return markdown
