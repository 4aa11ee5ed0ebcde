"""The fuzz runner's outcome classes: each failure is named for what went wrong."""

from __future__ import annotations

from pathlib import Path

import pytest

from .corpus import EITHER, REFUSE, Case
from .runner import RunResult, classify, tree_hash


def _case(command: str = "info", expect: str = REFUSE) -> Case:
    return Case("id", command, (), "d", "m", expect)


ONE = "tactile: error: f.h5: /trials/a/events/t is missing; re-ingest the file\n"
TB = "Traceback (most recent call last):\n  File \"x\", line 1\nKeyError: 't'\n"


@pytest.mark.parametrize(("case", "result", "changed", "left", "expected"), [
    (_case(), RunResult(2, "", ONE, 0.1), False, False, "ok-refused"),
    (_case("validate"), RunResult(1, "f.h5: 2 violations\n", "", 0.1), False, False,
     "ok-refused"),
    (_case("info"), RunResult(1, "", "", 0.1), False, False, "bad-exit"),
    (_case(), RunResult(1, "", TB, 0.1), False, False, "traceback"),
    (_case(), RunResult(2, "", "warning: x\n" + ONE, 0.1), False, False, "multi-line"),
    (_case(), RunResult(2, "", "Usage: tactile\n", 0.1), False, False, "multi-line"),
    (_case(), RunResult(2, "", ONE, 0.1), False, True, "leftover"),
    (_case(), RunResult(2, "", ONE, 0.1), True, False, "input-changed"),
    (_case(), RunResult(0, "fine\n", "", 0.1), False, False, "accepted-corrupt"),
    (_case(expect=EITHER), RunResult(0, "fine\n", "", 0.1), False, False, "ok-accepted"),
    (_case(), RunResult(-14, "", "", 60.0), False, False, "hang"),
])
def test_classify(case, result, changed, left, expected):
    assert classify(case, result, input_changed=changed, leftover=left)[0] == expected


@pytest.mark.slow
def test_run_argv_captures_exit_code_and_one_line(tmp_path: Path):
    """In a fresh interpreter, as the fast subset runs (a fork of the pytest process would
    copy the threads of libraries that other tests loaded)."""
    import json
    import subprocess
    import sys

    code = ("import json, sys; from pathlib import Path; from tests.fuzz.runner import run_argv; "
            "r = run_argv(['info', sys.argv[1]], cwd=Path(sys.argv[2]), timeout_s=60); "
            "print(json.dumps([r.code, r.stderr]))")
    root = Path(__file__).resolve().parents[2]
    proc = subprocess.run([sys.executable, "-c", code, str(tmp_path / "nope.h5"),
                           str(tmp_path)], cwd=root, capture_output=True, text=True,
                          timeout=300, check=True)
    exit_code, stderr = json.loads(proc.stdout.strip().splitlines()[-1])
    assert exit_code == 2
    assert stderr.splitlines() == [f"tactile: error: {tmp_path / 'nope.h5'}: file not found"]


def test_tree_hash_sees_bytes_names_and_links(tmp_path: Path):
    (tmp_path / "a").mkdir()
    (tmp_path / "a" / "f").write_bytes(b"1")
    h = tree_hash(tmp_path / "a")
    (tmp_path / "a" / "f").write_bytes(b"2")
    assert tree_hash(tmp_path / "a") != h
    (tmp_path / "a" / "eval").mkdir()
    h = tree_hash(tmp_path / "a", ("eval",))
    (tmp_path / "a" / "eval" / "m.json").write_text("{}")
    assert tree_hash(tmp_path / "a", ("eval",)) == h
    (tmp_path / "loop").symlink_to("loop")
    assert tree_hash(tmp_path / "loop")  # a symlink loop is hashed, not followed
