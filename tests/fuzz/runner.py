"""Run one `tactile` command on one damaged input and classify what happened (issue 20).

Each run is a forked child of a process that has already imported the CLI (and, when
asked, torch and matplotlib), so that a run costs tens of milliseconds of start-up instead
of the 1-2 s of a fresh interpreter, while keeping what a subprocess gives: its own exit
code, stdout and stderr at the file-descriptor level (warnings printed by numpy, pandas or
HDF5 included), a fresh copy of the state, and a hard time limit (SIGALRM, whose default
action ends the child wherever it is, C code included). The child resets the warning
filters to the interpreter's defaults, so pytest's ``-W error`` does not leak into it.

Outcome classes (the first that applies):

- ``hang``: killed by the time limit (or by a signal);
- ``traceback``: a Python traceback on stderr, or an exception that escaped the CLI;
- ``input-changed``: the damaged input's bytes differ afterwards;
- ``leftover``: the run was refused but left something new in the output folder;
- ``multi-line``: refused with more than one line on stderr;
- ``bad-exit``: another exit code than 0, 2 (and 1 for ``validate``);
- ``accepted-corrupt``: exit 0 on a case marked ``refuse``;
- ``ok-refused``: exit 2 (``validate``: 1 or 2) with one line, nothing left, input intact;
- ``ok-accepted``: exit 0 on a case marked ``either``.
"""

from __future__ import annotations

import hashlib
import os
import resource
import shutil
import signal
import sys
import tempfile
import time
import traceback
import warnings
from dataclasses import asdict, dataclass
from pathlib import Path

from .corpus import REFUSE, Case, Corpus

OK = ("ok-refused", "ok-accepted")
CLASSES = ("ok-refused", "ok-accepted", "traceback", "multi-line", "leftover", "input-changed",
           "accepted-corrupt", "bad-exit", "hang")
#: virtual memory a child may take: an absurd size fails fast instead of swapping
MEMORY_LIMIT_BYTES = 6 << 30


@dataclass
class RunResult:
    code: int  # exit code; -N when killed by signal N
    stdout: str
    stderr: str
    seconds: float


def preload(heavy: bool = True) -> None:
    """Import what most commands import, once, before forking the runs."""
    import h5py  # noqa: F401
    import numpy  # noqa: F401

    import tactile_cli.cli  # noqa: F401

    if heavy:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot  # noqa: F401
        import scipy.signal  # noqa: F401
        import torch  # noqa: F401

        # the sensor chains (scipy.signal, simulators, detectors): imported once, not by
        # every run (a refusal then takes 0.15 s instead of 1.1 s)
        import tactile_cli.accel  # noqa: F401
        import tactile_cli.spectral  # noqa: F401
        import tactile_cli.taxel  # noqa: F401
        import tactile_cli.vibro  # noqa: F401
        import tactile_cli.visuotactile  # noqa: F401

        torch.set_num_threads(1)


def _child(argv: list[str], cwd: Path, out_fd: int, err_fd: int, timeout_s: int) -> None:
    code = 1
    try:
        os.chdir(cwd)
        os.dup2(out_fd, 1)
        os.dup2(err_fd, 2)
        sys.stdout = open(1, "w", encoding="utf-8", errors="backslashreplace", closefd=False)  # noqa: SIM115
        sys.stderr = open(2, "w", encoding="utf-8", errors="backslashreplace", closefd=False)  # noqa: SIM115
        sys.stdin = open(os.devnull)  # noqa: SIM115
        signal.signal(signal.SIGALRM, signal.SIG_DFL)
        signal.signal(signal.SIGINT, signal.default_int_handler)
        signal.alarm(timeout_s)
        try:
            soft = min(MEMORY_LIMIT_BYTES, resource.getrlimit(resource.RLIMIT_AS)[1])
            if soft > 0:
                resource.setrlimit(resource.RLIMIT_AS, (soft, resource.getrlimit(
                    resource.RLIMIT_AS)[1]))
        except (ValueError, OSError):
            pass
        warnings.resetwarnings()  # the interpreter's defaults, not pytest's -W error
        warnings.simplefilter("default")
        for cat in (DeprecationWarning, PendingDeprecationWarning, ImportWarning,
                    ResourceWarning):
            warnings.simplefilter("ignore", cat)
        os.environ["COLUMNS"] = "100"
        os.environ.pop("FORCE_COLOR", None)
        sys.argv = ["tactile", *argv]
        from tactile_cli.cli import app

        try:
            app(args=argv, prog_name="tactile")
            code = 0
        except SystemExit as exc:
            c = exc.code
            code = 0 if c is None else c if isinstance(c, int) else 1
            if not isinstance(c, int | None):
                print(c, file=sys.stderr)
        except BaseException:  # what the interpreter would print for an uncaught error
            traceback.print_exc()
            code = 1
    finally:
        try:
            sys.stdout.flush()
            sys.stderr.flush()
        finally:
            os._exit(code & 0xFF)


def run_argv(argv: list[str], *, cwd: Path, timeout_s: int = 120) -> RunResult:
    """``tactile *argv`` in a forked child with ``cwd`` as working folder."""
    with tempfile.TemporaryFile() as out, tempfile.TemporaryFile() as err:
        sys.stdout.flush()
        sys.stderr.flush()
        start = time.perf_counter()
        pid = os.fork()
        if pid == 0:
            _child(argv, cwd, out.fileno(), err.fileno(), timeout_s)
        _, status = os.waitpid(pid, 0)
        seconds = time.perf_counter() - start
        code = (os.WEXITSTATUS(status) if os.WIFEXITED(status)
                else -os.WTERMSIG(status))
        out.seek(0)
        err.seek(0)
        return RunResult(code, out.read().decode("utf-8", "replace"),
                         err.read().decode("utf-8", "replace"), seconds)


def tree_hash(path: Path, skip: tuple[str, ...] = ()) -> str:
    """SHA-256 over the names, link targets and bytes of a file or a folder tree."""
    h = hashlib.sha256()
    if path.is_symlink() or not path.exists():
        h.update(f"link:{os.readlink(path) if path.is_symlink() else 'missing'}".encode())
        return h.hexdigest()
    if path.is_file():
        h.update(path.read_bytes())
        return h.hexdigest()
    for root, dirs, files in os.walk(path):
        rel = Path(root).relative_to(path)
        if not rel.parts:  # outputs a command may add next to its input
            dirs[:] = [d for d in dirs if d not in skip]
        dirs.sort()
        for name in sorted(files) + [d for d in dirs if (Path(root) / d).is_symlink()]:
            p = Path(root) / name
            h.update(str(rel / name).encode())
            h.update(os.readlink(p).encode() if p.is_symlink() else p.read_bytes())
        h.update(f"dirs:{','.join(d for d in dirs if not (Path(root) / d).is_symlink())}".encode())
    return h.hexdigest()


def _listing(folder: Path) -> list[str]:
    return sorted(str(p.relative_to(folder)) for p in folder.rglob("*"))


@dataclass
class Outcome:
    id: str
    command: str
    mutation: str
    damaged: str
    expect: str
    outcome: str
    code: int
    seconds: float
    stderr_lines: int
    first_stderr: str
    detail: str  # the traceback's last line, the extra output, ...

    def as_dict(self) -> dict:
        return asdict(self)


def run_case(corpus: Corpus, case: Case, scratch: Path, *, timeout_s: int = 120) -> Outcome:
    """Run ``case`` in a fresh folder under ``scratch`` (removed afterwards)."""
    work = Path(tempfile.mkdtemp(prefix="case-", dir=scratch))
    try:
        src = corpus.root / case.damaged
        shutil.copytree(src, work / "in", symlinks=True)
        damaged = next(d for d in corpus.damaged if d.name == case.damaged)
        inp = work / "in" / damaged.entry
        out = work / "out"
        out.mkdir()
        run_copy = work / "runcopy"
        subs = {"{IN}": str(inp), "{OUT}": str(out), "{BASE}": str(corpus.base),
                "{RUN}": str(run_copy)}
        argv = [_sub(a, subs) for a in case.argv]
        if any("{RUN}" in a for a in case.argv):
            shutil.copytree(corpus.base / "run", run_copy, symlinks=True)
        for clash in case.clash:
            if clash == "run-eval-file":
                shutil.rmtree(run_copy / "eval", ignore_errors=True)
                (run_copy / "eval").write_text("a file where a folder is expected\n")
            else:
                kind, name = clash.split(":", 1)
                if kind == "file":
                    (out / name).write_text("a file where a folder is expected\n")
                elif kind == "ro":  # a folder nothing can be written in
                    (out / name).mkdir()
                    _immutable(out / name, True)
                else:
                    (out / name).mkdir()
        writes_input = case.command in ("evaluate", "perturb") or (
            case.command == "fit-fos" and "--no-write" not in argv)
        # the input itself, so that what a command may add beside it (RUN/eval) is skipped
        watched = [inp] + ([run_copy] if run_copy.exists() else [])
        # and every valid input of the bases the case names: never written either
        watched += sorted({Path(a) for a in argv if a.startswith(str(corpus.base))
                           and Path(a).exists()})
        before = [tree_hash(p) for p in watched]
        before_skip = [tree_hash(p, ("eval", "perturb")) for p in watched]
        # the shared valid inputs a case names are inputs too: never written by any case
        shared = sorted({Path(a) for a in argv if a.startswith(str(corpus.base))
                         and Path(a).exists()})
        shared_before = [tree_hash(p) for p in shared]
        listing = _listing(out)
        res = run_argv(argv, cwd=work, timeout_s=timeout_s)
        after = [tree_hash(p) for p in watched]
        after_skip = [tree_hash(p, ("eval", "perturb")) for p in watched]
        outcome, detail = classify(case, res, input_changed=(
            before != after if res.code != 0 or not writes_input else before_skip != after_skip)
            or shared_before != [tree_hash(p) for p in shared],
            leftover=_listing(out) != listing)
        lines = [ln for ln in res.stderr.splitlines() if ln.strip()]
        return Outcome(case.id, case.command, case.mutation, case.damaged, case.expect,
                       outcome, res.code, round(res.seconds, 3), len(lines),
                       lines[0][:300] if lines else "", detail[:300])
    finally:
        for clash in case.clash:
            if clash.startswith("ro:"):
                _immutable(work / "out" / clash[3:], False)
        shutil.rmtree(work, ignore_errors=True)


def _immutable(folder: Path, on: bool) -> None:
    """``chattr +i`` (root) and mode 0o555 (everyone else) on ``folder``, or both undone."""
    import subprocess

    if not folder.exists():
        return
    if on:
        folder.chmod(0o555)
    try:
        subprocess.run(["chattr", "+i" if on else "-i", str(folder)], capture_output=True)
    except OSError:
        pass
    if not on:
        folder.chmod(0o755)


def _sub(arg: str, subs: dict[str, str]) -> str:
    for k, v in subs.items():
        arg = arg.replace(k, v)
    return arg


def classify(case: Case, res: RunResult, *, input_changed: bool,
             leftover: bool) -> tuple[str, str]:
    """The outcome class of one run, and a detail line."""
    lines = [ln for ln in res.stderr.splitlines() if ln.strip()]
    if res.code < 0:
        return "hang", f"killed by signal {-res.code} after {res.seconds:.0f} s"
    if "Traceback (most recent call last)" in res.stderr:
        tail = [ln for ln in lines if not ln.startswith((" ", "\t"))]
        return "traceback", tail[-1] if tail else lines[-1]
    if input_changed:
        return "input-changed", f"exit {res.code}"
    refused = res.code == 2 or (res.code == 1 and case.command == "validate")
    if refused and leftover:
        return "leftover", f"exit {res.code}"
    if res.code == 2 and len(lines) != 1:
        return "multi-line", " | ".join(lines[:4])
    if res.code == 2 and not lines[0].startswith("tactile: error: "):
        return "multi-line", lines[0]
    if refused:
        return "ok-refused", ""
    if res.code != 0:
        return "bad-exit", f"exit {res.code}: " + " | ".join(lines[-2:])
    if case.expect == REFUSE:
        return "accepted-corrupt", (res.stdout.strip().splitlines() or [""])[-1][:200]
    return "ok-accepted", ""
