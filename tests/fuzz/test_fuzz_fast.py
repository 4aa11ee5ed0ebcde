"""A fast, seeded subset of the damaged-input corpus (issue 20); the whole corpus is
``make fuzz`` (benchmarks/fuzz_corpus.py).

Every selected command run on a damaged input must end in one of the two good outcomes:
refused (exit 2, or 1 from ``validate`` for a readable but invalid file) with exactly one
line on stderr, no traceback, nothing left in the output folder and the input unchanged;
or, where the case allows it (a harmless damage or a baseline), accepted with exit 0.

The runs that still fail are listed in XFAIL by case id with their failure class, strict:
when a fix makes one pass, the XPASS fails the suite until the entry is removed here.
"""

from __future__ import annotations

import dataclasses
import fcntl
import hashlib
import json
import subprocess
import sys
import tempfile
from pathlib import Path

import pytest

from . import corpus as fuzz_corpus
from . import runner

SEED = 0
#: share of each command's cases that the fast subset runs (by a hash of the case id, so
#: that a case's membership does not depend on the rest of the corpus)
RATE_PERCENT = {"info": 3, "validate": 4, "plot": 3, "grade": 5, "train": 3, "evaluate": 4,
                "perturb": 3, "ingest": 10, "centroids": 4, "slip-rate": 4, "frames": 4,
                "fit-fos": 3, "accumulate": 5, "compare": 10, "report": 10, "synth": 20,
                # the sensor chains (tests/fuzz/chains.py): few, their runs are slower
                "accel-prepare": 2, "detect-delay": 1, "features": 1, "slip-interface": 1,
                "vibro-model": 5, "detect-contact": 2, "normal-labels": 3, "heightmap": 2,
                "slip-signal": 3, "monitor": 1, "simulate": 2, "export": 4, "sweep": 5,
                "seed-spread": 20}
#: kinds run for every command they have cases of (one case per command and kind, chosen by
#: a hash of the case id; `make fuzz` runs them all): each case is a different command or
#: output option, refused before any work
ALWAYS = ("clash", "symlink", "sacred", "unwritable", "learn-io")


def _source_key() -> str:
    """Changes whenever the code that builds the corpus does (the bases are cached)."""
    root = Path(__file__).resolve().parents[2]
    h = hashlib.sha256()
    files = sorted([*(root / "tactile_cli").rglob("*.py"), *(root / "tests" / "fuzz").glob("*.py"),
                    *(root / "tests" / "factories").glob("*.py"),
                    *(p for p in (root / "configs").rglob("*") if p.is_file())])
    for p in files:
        h.update(str(p.relative_to(root)).encode())
        h.update(p.read_bytes())
    return h.hexdigest()[:16]


def _selected(case: fuzz_corpus.Case, kind: str) -> bool:
    if kind in ALWAYS:
        return False  # one per command, in _subset
    digest = int(hashlib.sha256(case.id.encode()).hexdigest()[:8], 16)
    return digest % 100 < RATE_PERCENT.get(case.command, 0)


WORK = Path(tempfile.gettempdir()) / f"tactile-fuzz-fast-{_source_key()}"


def _corpus() -> fuzz_corpus.Corpus:
    """The cached corpus, built by one process at a time: a second pytest process that
    collects meanwhile waits on the lock and then reuses what the first one finished."""
    WORK.mkdir(parents=True, exist_ok=True)
    with open(WORK / ".lock", "w") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)
        return fuzz_corpus.build_corpus(WORK, seed=SEED, n_random=1)


CORPUS = _corpus()
KINDS = {d.name: d.kind for d in CORPUS.damaged}


def _subset() -> list[fuzz_corpus.Case]:
    chosen = {c.id for c in CORPUS.cases if _selected(c, KINDS[c.damaged])}
    first: dict[object, fuzz_corpus.Case] = {}  # and one case of every kind of input at least
    for c in sorted(CORPUS.cases, key=lambda c: hashlib.sha256(c.id.encode()).hexdigest()):
        kind = KINDS[c.damaged]
        first.setdefault((kind, c.command) if kind in ALWAYS else kind, c)
    chosen |= {c.id for c in first.values()}
    return [c for c in CORPUS.cases if c.id in chosen]


CASES = _subset()

#: case id -> failure class; every one still fails (strict xfail). Remove an entry once
#: its run passes.
XFAIL: dict[str, str] = {}


def _param(case: fuzz_corpus.Case):
    marks = ()
    if case.id in XFAIL:
        marks = (pytest.mark.xfail(strict=True, reason=f"issue 20: {XFAIL[case.id]}"),)
    return pytest.param(case, id=case.id, marks=marks)


def test_fast_subset_is_broad():
    """The subset covers every command and every kind of damaged input."""
    assert {c.command for c in CASES} == {c.command for c in CORPUS.cases}
    assert {KINDS[c.damaged] for c in CASES} == set(KINDS.values())
    assert len(CORPUS.damaged) >= 500
    assert 100 <= len(CASES) <= 280  # one of each kind adds about 30 for the chains
    listed = {i for i in XFAIL if fuzz_corpus.AEDAT4.exists() or ":aedat4:" not in i}
    assert listed <= {c.id for c in CASES}, "XFAIL names a case the subset does not run"


def run_subset(ids: list[str], scratch: Path) -> dict[str, dict]:
    """Run the cases ``ids`` in this (fresh) process: preload the CLI, then fork one child
    per run; case id -> its outcome as a dict."""
    runner.preload()
    out = {}
    for case in (c for c in CORPUS.cases if c.id in set(ids)):
        one = scratch / str(len(out))
        one.mkdir(parents=True)
        out[case.id] = dataclasses.asdict(runner.run_case(CORPUS, case, one, timeout_s=60))
    return out


@pytest.fixture(scope="module")
def outcomes(tmp_path_factory) -> dict[str, dict]:
    """Every run of the subset, made by a fresh interpreter: forking the pytest process
    would copy the threads of libraries other tests loaded (JAX warns that its children
    may deadlock)."""
    scratch = tmp_path_factory.mktemp("fuzz")
    code = ("import json, sys; from pathlib import Path; "
            "from tests.fuzz import test_fuzz_fast as t; "
            f"print(json.dumps(t.run_subset(sys.argv[1:], Path({str(scratch)!r}))))")
    root = Path(__file__).resolve().parents[2]
    proc = subprocess.run([sys.executable, "-c", code, *[c.id for c in CASES]], cwd=root,
                          capture_output=True, text=True, timeout=900)
    assert proc.returncode == 0, proc.stderr[-2000:]
    return json.loads(proc.stdout.strip().splitlines()[-1])


@pytest.mark.slow
@pytest.mark.parametrize("case", [_param(c) for c in CASES])
def test_damaged_input(case: fuzz_corpus.Case, outcomes: dict[str, dict]):
    result = runner.Outcome(**outcomes[case.id])
    assert result.outcome in runner.OK, (
        f"{result.outcome} (exit {result.code}): {result.detail or result.first_stderr}")
