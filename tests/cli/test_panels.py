"""`tactile --help` reads like a table of contents (issue 32 item 5): every command sits in
a panel of tactile_cli/cli/_panels.py with an example whose flags are its own options."""

from __future__ import annotations

import shlex

import pytest
import typer

from tactile_cli.cli import app
from tactile_cli.cli._panels import PANELS

ROWS = [(panel, name, example) for panel, rows in PANELS.items() for name, example in rows]


def _group():
    return typer.main.get_command(app)


def test_every_command_has_one_panel_row():
    names = [name for _, name, _ in ROWS]
    assert len(names) == len(set(names))
    assert set(names) == set(_group().commands)


@pytest.mark.parametrize(("panel", "name", "example"), ROWS, ids=[r[1] for r in ROWS])
def test_each_example_uses_the_options_of_its_command(panel, name, example):
    words = shlex.split(example)
    assert words[:2] == ["tactile", name]
    command = _group().commands[name]
    rest = words[2:]
    if hasattr(command, "commands"):  # a group: the example names one of its commands
        command = command.commands[rest[0]]
        rest = rest[1:]
    options = {o for p in command.params for o in [*p.opts, *p.secondary_opts]}
    used = {w for w in rest if w.startswith("-")}
    assert used <= options, f"{example}: {sorted(used - options)} are not options of {name}"


def test_help_lists_the_panels_in_workflow_order_and_ends_with_the_example():
    from typer.testing import CliRunner

    out = CliRunner().invoke(app, ["--help"], env={"COLUMNS": "120"}).output
    positions = [out.index(panel) for panel in PANELS]
    assert positions == sorted(positions)
    examples = {name: example for _, name, example in ROWS}
    grade = CliRunner().invoke(app, ["grade", "--help"], env={"COLUMNS": "120"}).output
    assert grade.rstrip().splitlines()[-1].strip() == f"Example: {examples['grade']}"
