"""`--help` of every command, `--version`, `info` and `validate` through the CLI."""

from __future__ import annotations

import json
import re

import h5py
import numpy as np
import pytest
import typer
from typer.testing import CliRunner

from tactile_cli import __version__
from tactile_cli.cli import app
from tactile_cli.store import StoreWriter

runner = CliRunner()


def _file(path):
    with StoreWriter(path, command="test") as w:
        s = w.add_sensor(
            "acc", kind="accelerometer", sample_rate_hz=10, channel_names=["a"], channel_units="g"
        )
        for i, obj in enumerate(["wood", "wood", "plastic"]):
            w.trial(f"t{i}", labels={"object": obj}).write_signal(
                "acc", sensor=s, data=np.zeros((20, 1)), t_s=np.arange(20) / 10
            )
        w.commit()
    return path


def _commands(group, path=()):
    """(argv path, command) of every command and sub-command under a click group."""
    for name, command in sorted(group.commands.items()):
        yield (*path, name), command
        if hasattr(command, "commands"):
            yield from _commands(command, (*path, name))


COMMANDS = list(_commands(typer.main.get_command(app)))
WIDE = {"COLUMNS": "120"}  # rich wraps to the terminal and truncates long names in a narrow one


def test_every_command_is_discovered():
    # 18 commands and the `simulate` group with its `marker-events`
    assert len(COMMANDS) >= 19
    assert ("simulate", "marker-events") in [path for path, _ in COMMANDS]


def test_help_lists_every_command_with_a_description():
    groups = [((), typer.main.get_command(app))] + [
        (path, c) for path, c in COMMANDS if hasattr(c, "commands")
    ]
    for path, group in groups:
        result = runner.invoke(app, [*path, "--help"], env=WIDE)
        assert result.exit_code == 0, path
        for name in group.commands:
            # a row of the command table: the name, then spaces and its description
            assert re.search(rf"^\W*{re.escape(name)}\s{{2,}}\w", result.output, re.M), (path, name)
    assert "Raw recordings" in runner.invoke(app, ["--help"], env=WIDE).output


@pytest.mark.parametrize(("path", "command"), COMMANDS, ids=[" ".join(p) for p, _ in COMMANDS])
def test_every_command_has_help(path, command):
    result = runner.invoke(app, [*path, "--help"], env=WIDE)
    assert result.exit_code == 0, result.output
    assert f"Usage: tactile {' '.join(path)} " in result.output
    flags = [
        opt
        for param in command.params
        if param.param_type_name == "option"
        for opt in (*param.opts, *param.secondary_opts)
        if opt.startswith("--")
    ]
    if not hasattr(command, "commands"):
        assert flags, f"{' '.join(path)} has no options"
    for flag in flags:
        assert re.search(rf"(?<![\w-]){re.escape(flag)}(?![\w-])", result.output), flag


def test_version():
    result = runner.invoke(app, ["--version"])
    assert result.exit_code == 0
    assert result.output.strip() == f"tactile {__version__}"


def test_info_table_and_json(tmp_path):
    f = _file(tmp_path / "a.h5")
    result = runner.invoke(app, ["info", str(f), "--json"])
    assert result.exit_code == 0
    data = json.loads(result.output)
    assert len(data["trials"]) == 3
    assert data["label_counts"] == {"object": {"plastic": 1, "wood": 2}}
    assert abs(data["total_duration_s"] - 3 * 1.9) < 1e-9
    table = runner.invoke(app, ["info", str(f)])
    assert table.exit_code == 0 and "accelerometer" in table.output and "wood: 2" in table.output


def test_info_missing_file_is_one_line_exit_2(tmp_path):
    result = runner.invoke(app, ["info", str(tmp_path / "nope.h5")])
    assert result.exit_code == 2
    assert result.stderr.strip() == f"tactile: error: {tmp_path / 'nope.h5'}: file not found"
    assert "Traceback" not in result.output


def test_validate_exit_codes_and_paths(tmp_path):
    good = _file(tmp_path / "good.h5")
    ok = runner.invoke(app, ["validate", str(good)])
    assert ok.exit_code == 0 and "valid" in ok.output
    bad = _file(tmp_path / "bad.h5")
    with h5py.File(bad, "a") as h5:
        h5["trials/t1/signals/acc"].attrs["sensor"] = "missing"
        h5["trials/t2"].attrs["duration_s"] = -1.0
    result = runner.invoke(app, ["validate", str(good), str(bad), "--json"])
    assert result.exit_code == 1
    reports = json.loads(result.output)
    assert [r["valid"] for r in reports] == [True, False]
    paths = {v["path"] for v in reports[1]["violations"]}
    assert paths == {
        "/trials/t1/signals/acc (attribute 'sensor')",
        "/trials/t2 (attribute 'duration_s')",
    }
