"""The generated references list every command of the app and every public verb (issue 32)."""

from __future__ import annotations

import importlib.util
import re
import sys
from pathlib import Path

import pytest
import typer

from tactile_cli.cli import app

DOCS = Path(__file__).resolve().parents[2] / "docs"


def _reference_gen():
    spec = importlib.util.spec_from_file_location("reference_gen", DOCS / "reference_gen.py")
    module = importlib.util.module_from_spec(spec)
    sys.modules.setdefault("reference_gen", module)
    spec.loader.exec_module(module)
    return module


def _leaf_commands(group, prefix: tuple[str, ...] = ()) -> set[str]:
    ctx = group.context_class(group)
    names: set[str] = set()
    for name in group.list_commands(ctx):
        command = group.get_command(ctx, name)
        if hasattr(command, "list_commands"):  # a group (typer ships its own click)
            names |= _leaf_commands(command, (*prefix, name))
        elif not command.hidden:
            names.add(" ".join(("tactile", *prefix, name)))
    return names


@pytest.mark.slow
def test_command_reference_has_every_command_with_its_help():
    page = _reference_gen().command_reference()
    want = _leaf_commands(typer.main.get_command(app))
    assert {"tactile ingest", "tactile simulate vibrotouch", "tactile features spectral"} <= want
    headed = set(re.findall(r"^## `(tactile[^`]*)`", page, flags=re.M))
    assert headed == want | {"tactile"}
    # each section is the command's own --help: its usage line names the command
    for name in want:
        section = page.split(f"## `{name}`", 1)[1].split("\n## ", 1)[0]
        assert f"Usage: {name} " in section, name


def test_command_reference_page_is_the_generated_one():
    page = (DOCS / "reference" / "commands.md").read_text(encoding="utf-8")
    assert "<!-- generated: commands -->" in page


def test_api_reference_covers_every_lazy_verb():
    import tactile_cli

    gen = _reference_gen()
    text = gen.api_reference()
    for name, module in tactile_cli._VERBS.items():
        assert f"::: tactile_cli.{module}.{name}\n" in text, name
    assert "::: tactile_cli.store.reader.TactileFile\n" in text or \
        re.search(r"::: tactile_cli\.store\.[\w.]*TactileFile\n", text)


def test_schema_reference_lists_every_node_of_the_shipped_spec():
    import json

    import tactile_cli

    spec_path = Path(tactile_cli.__file__).parent / "data_schemas" / "tactile-h5-v1.json"
    spec = json.loads(spec_path.read_text(encoding="utf-8"))
    text = _reference_gen().schema_reference()
    for node in spec["nodes"]:
        assert f"| `{node['path']}` |" in text, node["path"]
