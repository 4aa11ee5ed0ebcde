"""A command line click refuses is one `tactile: error:` line and exit 2, like every other
error; every float option refuses nan, inf and numbers that overflow
(tactile_cli/cli/_options.py)."""

from __future__ import annotations

import pytest
from typer.testing import CliRunner

from tactile_cli.cli import app

runner = CliRunner()


def _one_line(result) -> str:
    assert result.exit_code == 2, result.output
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1, result.stderr
    assert lines[0].startswith("tactile: error: ")
    assert "╭" not in result.output and "Traceback" not in result.output
    return lines[0]


def test_unknown_option_is_one_line_with_the_help_to_read():
    line = _one_line(runner.invoke(app, ["ingest", "x.csv", "--bogus"]))
    assert line == ("tactile: error: ingest: No such option: --bogus (Possible options: --out); "
                    "see `tactile ingest --help`")


def test_missing_argument_and_unknown_command():
    assert "Missing argument 'INPUT'" in _one_line(runner.invoke(app, ["ingest"]))
    assert _one_line(runner.invoke(app, ["nosuch"])) == (
        "tactile: error: No such command 'nosuch'; see `tactile --help`")


def test_a_value_of_the_wrong_type_names_the_option():
    line = _one_line(runner.invoke(app, ["simulate", "vibro-slip", "--out", "x", "--seed",
                                         "abc"]))
    assert "'--seed'" in line and line.endswith("see `tactile simulate vibro-slip --help`")


@pytest.mark.parametrize("value", ["nan", "NaN", "inf", "-inf", "Infinity", "1e400"])
def test_every_float_option_refuses_non_finite_values(value, tmp_path):
    line = _one_line(runner.invoke(app, ["simulate", "vibro-slip", "--out",
                                         str(tmp_path / "x"), "--duration", value]))
    assert "Invalid value for '--duration'" in line  # nan, -inf: also below the range
    if value in ("inf", "Infinity", "1e400"):
        assert "is not a finite number" in line
    assert not (tmp_path / "x").exists()


def test_float_options_of_every_command_are_checked():
    from typer.main import get_command

    from tactile_cli.cli._options import finite_float_options

    group = get_command(app)
    finite_float_options(group)
    unchecked = []

    def walk(command, path):
        for param in command.params:
            if not getattr(param.process_value, "tactile_finite", False):
                unchecked.append(f"{path} {param.name}")
        for name, sub in getattr(command, "commands", {}).items():
            walk(sub, f"{path} {name}")

    walk(group, "tactile")
    assert unchecked == []


def test_help_and_version_still_exit_zero():
    assert runner.invoke(app, ["--version"]).exit_code == 0
    result = runner.invoke(app, ["fit-fos", "--help"])
    assert result.exit_code == 0 and "--rtol" in result.output
