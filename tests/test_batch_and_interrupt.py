"""Batch use from make, and interrupted ingests (Ctrl-C, kill) leaving earlier outputs intact."""

from __future__ import annotations

import os
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from tactile_cli.samples import write_events_csv
from tactile_cli.store import validate_file

REPO = Path(__file__).resolve().parents[1]
TACTILE = f"{sys.executable} -m tactile_cli"


def _make(*args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        ["make", "--no-print-directory", "-C", str(REPO), *args, "STAMP=", f"TACTILE={TACTILE}"],
        capture_output=True,
        text=True,
    )


@pytest.mark.slow
@pytest.mark.skipif(shutil.which("make") is None, reason="make is not installed")
def test_make_ingest_one_output_per_input_parallel_and_incremental(tmp_path):
    raw, out = tmp_path / "raw", tmp_path / "out"
    raw.mkdir()
    for k in range(3):
        write_events_csv(raw / f"rec{k}.csv", 2000, width=64, height=48, seed=k)
    flags = "INGEST_FLAGS=--width 64 --height 48"
    first = _make("ingest", f"RAW={raw}", f"OUT={out}", flags, "-j", "2")
    assert first.returncode == 0, first.stderr
    outputs = sorted(out.glob("*.h5"))
    assert [p.name for p in outputs] == ["rec0.csv.h5", "rec1.csv.h5", "rec2.csv.h5"]
    assert all(validate_file(p).ok for p in outputs)
    stamps = {p: p.stat().st_mtime_ns for p in outputs}

    again = _make("ingest", f"RAW={raw}", f"OUT={out}", flags, "-j", "2")
    assert again.returncode == 0 and "tactile_cli ingest" not in again.stdout  # nothing rebuilt
    assert {p: p.stat().st_mtime_ns for p in outputs} == stamps

    time.sleep(0.01)
    os.utime(raw / "rec1.csv")  # only this input is newer than its output
    third = _make("ingest", f"RAW={raw}", f"OUT={out}", flags)
    assert third.returncode == 0
    assert third.stdout.count("tactile_cli ingest") == 1 and "rec1.csv" in third.stdout
    assert (out / "rec0.csv.h5").stat().st_mtime_ns == stamps[out / "rec0.csv.h5"]

    (raw / "bad.csv").write_text("t,x,y,p\n1,2,3\n")
    bad = _make("ingest", f"RAW={raw}", f"OUT={out}", flags)
    assert bad.returncode != 0
    assert "bad.csv" in bad.stderr and "Traceback" not in bad.stderr
    assert not (out / "bad.csv.h5").exists()
    assert not list(out.glob(".*tmp*"))


@pytest.mark.slow
@pytest.mark.parametrize("sig", [signal.SIGINT, signal.SIGTERM])
def test_interrupted_ingest_keeps_the_earlier_output(tmp_path, sig):
    src = tmp_path / "big.csv"
    write_events_csv(src, 4_000_000, width=640, height=480, seed=1)
    out = tmp_path / "out.h5"
    out.write_bytes(b"earlier output")
    proc = subprocess.Popen(
        [
            sys.executable,
            "-m",
            "tactile_cli",
            "ingest",
            str(src),
            "--width",
            "640",
            "--height",
            "480",
            "--out",
            str(out),
            "--overwrite",
            "--no-progress",
        ],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    deadline = time.monotonic() + 60
    while not list(tmp_path.glob(".out.h5.tmp-*")):  # wait until it is writing
        assert proc.poll() is None, proc.communicate()
        assert time.monotonic() < deadline, "ingest never started writing"
        time.sleep(0.01)
    proc.send_signal(sig)
    _, stderr = proc.communicate(timeout=60)
    assert proc.returncode == 130, stderr
    assert (
        stderr.strip()
        == "tactile: error: interrupted; no output was written and earlier outputs are intact"
    )
    assert out.read_bytes() == b"earlier output"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["big.csv", "out.h5"]
