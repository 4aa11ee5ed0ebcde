"""Library errors name Python arguments (`overwrite=True`), never the flags of a command:
the CLI spells them as flags (tests/cli/test_errors.py)."""

from __future__ import annotations

import ast
import re
from pathlib import Path

import pytest

import tactile_cli
from tactile_cli.errors import InputError
from tactile_cli.events.recording import accumulate_file
from tactile_cli.learn.data import data_files
from tactile_cli.store import StoreWriter

ROOT = Path(tactile_cli.__file__).parent
# a whole command line to run names its flags: `tactile fit-fos FILE --overwrite`
COMMAND = re.compile(r"`tactile [^`]*`|<code>tactile .*?</code>|\(tactile [^)]*\)")
FLAG = re.compile(r"(?<![\w-])--[a-z][a-z0-9-]*")
# files whose strings are command lines, not messages
NOT_MESSAGES = {"samples/__init__.py": "builds the `tactile ingest` command lines it returns",
                "accel/simulate.py": "records the `tactile ingest` command line of a scene",
                "visuotactile/simulate.py": "returns the `tactile ingest` command lines of a "
                "digit-press scene",
                "visuotactile/avoidance.py": "records the `tactile ingest` command line of an "
                "avoidance scene"}


def _message_strings(tree: ast.AST):
    """(line, text) of every string in the code that is not documentation (docstrings and
    other bare string statements); an f-string's fields read ``{}``."""
    skip: set[int] = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Expr) and isinstance(node.value, ast.Constant | ast.JoinedStr):
            skip.add(id(node.value))
        if isinstance(node, ast.JoinedStr):
            skip.update(id(v) for v in node.values)
    for node in ast.walk(tree):
        if id(node) in skip:
            continue
        if isinstance(node, ast.JoinedStr):
            yield node.lineno, "".join(v.value if isinstance(v, ast.Constant) else "{}"
                                       for v in node.values)
        elif isinstance(node, ast.Constant) and isinstance(node.value, str):
            yield node.lineno, node.value


def _flags_in_library_messages() -> list[str]:
    offenders = []
    for path in sorted(ROOT.rglob("*.py")):
        rel = path.relative_to(ROOT).as_posix()
        if rel.startswith("cli/") or rel in NOT_MESSAGES:
            continue
        for line, text in _message_strings(ast.parse(path.read_text(encoding="utf-8"))):
            flags = FLAG.findall(COMMAND.sub("", text))
            if flags:
                offenders.append(f"{rel}:{line}: {', '.join(flags)} in {text!r}")
    return offenders


@pytest.mark.slow
def test_library_messages_name_no_cli_flags():
    offenders = _flags_in_library_messages()
    assert not offenders, ("library messages name CLI flags; name the Python argument in "
                           "backticks (`overwrite=True`) and add it to the command's FLAGS "
                           "table in tactile_cli/cli/:\n" + "\n".join(offenders))


@pytest.mark.parametrize(("text", "found"), [
    ("output exists; pass --overwrite to replace it", ["--overwrite"]),
    ("pass e.g. --bin-ms 20", ["--bin-ms"]),
    ("give the ROIs with --rois", ["--rois"]),
    ("re-run `tactile fit-fos {} --overwrite`", []),
    ("(tactile synth --centroids)", []),
    ("run <code>tactile evaluate {} --data FILE</code>", []),
    ("the run's-- double dash in prose and x--y", []),
])
def test_the_scan_finds_flags_outside_command_lines(text, found):
    assert FLAG.findall(COMMAND.sub("", text)) == found


def test_the_scan_reads_messages_not_docstrings():
    tree = ast.parse('"""Module `tactile x --flag`, see --flag."""\n'
                     'def f(n):\n'
                     '    """Use --flag."""\n'
                     '    raise ValueError(f"pass --count {n} " "or --other")\n')
    assert list(_message_strings(tree)) == [(4, "pass --count {} or --other")]


def test_store_writer_names_overwrite_true(tmp_path):
    out = tmp_path / "a.h5"
    out.write_bytes(b"old")
    with pytest.raises(InputError) as exc:
        StoreWriter(out)
    assert exc.value.message == "output exists; pass `overwrite=True` to replace it"


def test_argument_errors_name_the_python_argument(tmp_path):
    with pytest.raises(InputError) as exc:
        accumulate_file(tmp_path / "x.h5", bin_s=1.5e-6)
    assert str(exc.value) == ("bin width 0.0015 ms is not a whole number of microseconds; "
                              "pass e.g. `bin_s=0.02`")
    with pytest.raises(InputError) as exc:
        accumulate_file(tmp_path / "x.h5", smooth_bins=4)
    assert str(exc.value).endswith("pass e.g. `smooth_bins=5`")
    with pytest.raises(InputError) as exc:
        data_files([])
    assert str(exc.value) == "no data files; give `data_paths`"


@pytest.mark.parametrize("bad", [-1, True, 1.5, "3", None])
def test_check_seed_refuses_what_is_not_a_non_negative_integer(bad: object) -> None:
    from tactile_cli.errors import check_seed

    with pytest.raises(InputError, match=r"`seed` \(=.*\) must be a non-negative integer"):
        check_seed(bad)


def test_check_seed_takes_python_and_numpy_integers() -> None:
    import numpy as np

    from tactile_cli.errors import check_seed

    assert check_seed(0) == 0 and check_seed(np.int64(7)) == 7
    assert type(check_seed(np.uint32(3))) is int
