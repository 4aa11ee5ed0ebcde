"""`--help` into a pipe or a file is rendered wide enough that nothing is cut, and the
placeholders of paths read the same in every command (FILE, FOLDER, RUN, INPUT)."""

from __future__ import annotations

import re
import typing

import pytest
import typer
from typer import rich_utils
from typer.testing import CliRunner

from tactile_cli import cli
from tactile_cli.cli import HELP_WIDTH, app, help_width

runner = CliRunner()
NO_COLUMNS = {"COLUMNS": None, "TERMINAL_WIDTH": None}

#: Placeholders of path arguments and options.
PATH_METAVARS = {"FILE", "FOLDER", "RUN", "INPUT", "CONFIG", "CSV"}
#: Commands whose files are being edited elsewhere; their placeholders come with that work.
NOT_YET: set[str] = set()


def _commands(group, path=()):
    for name, command in sorted(group.commands.items()):
        yield (*path, name), command
        if hasattr(command, "commands"):
            yield from _commands(command, (*path, name))


COMMANDS = list(_commands(typer.main.get_command(app)))


def test_help_into_a_pipe_is_wide_and_not_cut():
    result = runner.invoke(app, ["ingest", "--help"], env=NO_COLUMNS)
    assert result.exit_code == 0, result.output
    widths = [len(line) for line in result.output.splitlines()]
    assert max(widths) == HELP_WIDTH > 80
    assert "…" not in result.output
    assert "configs/mapping_example.yaml)" in result.output  # was cut at 80 columns
    assert rich_utils.MAX_WIDTH is None  # restored after the command


@pytest.mark.parametrize(("path", "command"), COMMANDS, ids=[" ".join(p) for p, _ in COMMANDS])
def test_no_help_is_cut(path, command):
    result = runner.invoke(app, [*path, "--help"], env=NO_COLUMNS)
    assert result.exit_code == 0, result.output
    assert "…" not in result.output


def test_help_width_follows_the_terminal_and_columns(monkeypatch):
    monkeypatch.delenv("COLUMNS", raising=False)
    monkeypatch.setattr(cli.sys.stdout, "isatty", lambda: False, raising=False)
    assert help_width() >= HELP_WIDTH
    monkeypatch.setenv("COLUMNS", "72")
    assert help_width() is None  # rich reads COLUMNS
    monkeypatch.delenv("COLUMNS")
    monkeypatch.setattr(cli.sys.stdout, "isatty", lambda: True, raising=False)
    assert help_width() is None  # rich asks the terminal
    result = runner.invoke(app, ["ingest", "--help"], env={"COLUMNS": "120"})
    assert max(len(line) for line in result.output.splitlines()) == 120


@pytest.mark.parametrize(("path", "command"), COMMANDS, ids=[" ".join(p) for p, _ in COMMANDS])
def test_path_placeholders_are_upper_case_words(path, command):
    if path[-1] in NOT_YET:
        pytest.skip(f"{' '.join(path)}: placeholders come with the work on its file")
    if hasattr(command, "commands"):
        return
    hints = typing.get_type_hints(command.callback)
    for param in command.params:
        if "Path" not in str(hints.get(param.name, "")):
            continue
        assert param.metavar in PATH_METAVARS, (path, param.name, param.metavar)
    usage = runner.invoke(app, [*path, "--help"], env=NO_COLUMNS).output
    line = next(line for line in usage.splitlines() if "Usage:" in line)
    assert not re.search(r"\{[a-z_]+\}", line), line  # {file} instead of FILE
