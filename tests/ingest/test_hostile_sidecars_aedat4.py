"""Issue 20 fuzz findings in `tactile ingest`: damaged AEDAT4 files (flipped header bytes,
cut short, trailing garbage), an .npy with a damaged header dict, and annotations, trial
labels and accelerometer CSVs that are cut, hold NUL bytes, have no rows or hold
non-finite or stray text labels. Each is one stderr line naming the file (and line), exit
2, no traceback, no output file, the input unchanged."""

from __future__ import annotations

import hashlib
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

from tactile_cli.cli import app
from tactile_cli.samples import write_all
from tactile_cli.samples.events import write_events_npy

from ..conftest import shared_path

runner = CliRunner()
DVX = ("aedat4", "dvxplorer_sample.aedat4")


def _one_error(result, out: Path, *, needle: str) -> str:
    assert result.exit_code == 2, result.output
    assert "Traceback" not in result.output
    lines = result.stderr.splitlines()
    assert len(lines) == 1 and lines[0].startswith("tactile: error: "), result.stderr
    assert needle in lines[0], lines[0]
    assert not out.exists() and not list(out.parent.glob("*.tmp*"))
    return lines[0]


def _sha(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


# -- AEDAT4 ----------------------------------------------------------------------------------
def _flip(data: bytes, offsets: list[int], xor: int = 0xA5) -> bytes:
    buf = bytearray(data)
    for o in offsets:
        buf[o] ^= xor
    return bytes(buf)


AEDAT_DAMAGE = {
    # name: (damage, words of the message)
    "flip-header-flatbuffer": (lambda b: _flip(b, [20, 60, 90]), "header is damaged"),
    "flip-header-xml": (lambda b: _flip(b, [929, 1301, 2004]), "header is damaged"),
    "flip-info-offset": (lambda b: _flip(b, [52]), "header is damaged"),
    "truncate-0.999": (lambda b: b[: int(len(b) * 0.999)], "cut short"),
    "truncate-inside-packet": (lambda b: b[:945243 - 100], "cut short"),
    "trailing-garbage": (lambda b: b + b"\x07" * 333, "333 bytes after the end"),
}


@pytest.mark.parametrize("name", sorted(AEDAT_DAMAGE))
def test_damaged_aedat4_is_one_line(tmp_path, capfd, name):
    damage, needle = AEDAT_DAMAGE[name]
    bad = tmp_path / "bad.aedat4"
    bad.write_bytes(damage(shared_path(*DVX).read_bytes()))
    before = _sha(bad)
    out = tmp_path / "o.h5"
    result = runner.invoke(app, ["ingest", str(bad), "--out", str(out), "--no-progress"])
    line = _one_error(result, out, needle=needle)
    assert "bad.aedat4" in line
    assert _sha(bad) == before
    # nothing from the Rust decoder (a panic message, a backtrace) reached the terminal
    assert capfd.readouterr().err == ""


def test_decoder_panic_is_caught_by_name(tmp_path, monkeypatch):
    """A decoder panic (pyo3_runtime.PanicException, a BaseException) is one InputError;
    KeyboardInterrupt is not swallowed."""
    import aedat

    from tactile_cli.errors import InputError
    from tactile_cli.ingest import events_aedat4

    PanicException = type("PanicException", (BaseException,), {})

    def panics(path):
        raise PanicException("range start index 7602200 out of range")

    monkeypatch.setattr(aedat, "Decoder", panics)
    with pytest.raises(InputError, match=r"x\.aedat4: not a readable AEDAT4 file \(range"):
        events_aedat4._open(tmp_path / "x.aedat4")

    def interrupted(path):
        raise KeyboardInterrupt

    monkeypatch.setattr(aedat, "Decoder", interrupted)
    with pytest.raises(KeyboardInterrupt):
        events_aedat4._open(tmp_path / "x.aedat4")


def test_intact_aedat4_layout_passes():
    from tactile_cli.ingest.events_aedat4 import check_layout
    check_layout(shared_path(*DVX))  # no error


# -- NPY -------------------------------------------------------------------------------------
def test_npy_with_damaged_header_dict(tmp_path):
    npy = tmp_path / "ev.npy"
    write_events_npy(npy, 100, width=64, height=48, seed=0)
    data = bytearray(npy.read_bytes())
    data[data.index(b"{"):data.index(b"{") + 1] = b"("  # an unclosed bracket: TokenError
    npy.write_bytes(bytes(data))
    out = tmp_path / "o.h5"
    result = runner.invoke(app, ["ingest", str(npy), "--width", "64", "--height", "48",
                                 "--out", str(out), "--no-progress"])
    line = _one_error(result, out, needle="not a readable .npy array")
    assert "ev.npy" in line


# -- annotations and trial labels ------------------------------------------------------------
@pytest.fixture
def events_npy(tmp_path) -> Path:
    path = tmp_path / "events.npy"
    write_events_npy(path, 300, width=64, height=48, seed=1)
    return path


SIDECARS = {
    # name: (flag, file text, words of the message, line)
    "annotations-nul": ("--annotations", "trial,start_s,end_s,label\nevents,0,0.01,press\n"
                        "\0\0\0\0\0events,0.01,0.02,slip\n", "NUL bytes", "line 3"),
    "annotations-cut-mid-row": ("--annotations", "trial,start_s,end_s,label\n"
                                "events,0.0,0.01,press\nevents,0.01,0.0",
                                "fields", "line 3"),
    "annotations-header-only": ("--annotations", "trial,start_s,end_s,label\n", "no rows",
                                None),
    "labels-nul": ("--trial-labels", "trial,force_level\n\0\0events,3\n", "NUL bytes",
                   "line 2"),
    "labels-header-only": ("--trial-labels", "trial,force_level\n", "no rows", None),
    "labels-cut-mid-row": ("--trial-labels", "trial,force_level\nevent", "fields",
                           "line 2"),
    "labels-nan": ("--trial-labels", "trial,force_level\nevents,nan\n", "not a finite number",
                   "line 2, column 'force_level'"),
    "labels-inf": ("--trial-labels", "trial,force_level\nevents,-inf\n", "not a finite number",
                   "line 2, column 'force_level'"),
    "labels-1e999": ("--trial-labels", "trial,force_level\nevents,1e999\n",
                     "not a finite number", "line 2"),
}


@pytest.mark.parametrize("name", sorted(SIDECARS))
def test_damaged_sidecar_is_one_line(tmp_path, events_npy, name):
    flag, text, needle, where = SIDECARS[name]
    side = tmp_path / "side.csv"
    side.write_bytes(text.encode())
    out = tmp_path / "o.h5"
    result = runner.invoke(app, ["ingest", str(events_npy), "--width", "64", "--height", "48",
                                 flag, str(side), "--out", str(out), "--no-progress"])
    line = _one_error(result, out, needle=needle)
    assert "side.csv" in line
    if where is not None:
        assert where in line
    assert side.read_bytes() == text.encode()


def test_text_in_an_otherwise_numeric_label_column(tmp_path):
    from tactile_cli.errors import InputError
    from tactile_cli.ingest.sidecars import read_trial_labels

    path = tmp_path / "labels.csv"
    path.write_text("trial,force,object\na,3,wood\nb,4,foam\nc,banana,cork\n")
    with pytest.raises(InputError, match=r"labels\.csv, line 4, column 'force': 'banana' is "
                                         r"not a number"):
        read_trial_labels(path)
    # free text, and a one-row file, stay labels as written
    path.write_text("trial,force,object\na,3,wood\n")
    assert read_trial_labels(path).rows["a"][0] == {"force": 3, "object": "wood"}
    path.write_text("trial,force\na,banana\n")
    assert read_trial_labels(path).rows["a"][0] == {"force": "banana"}
    path.write_text("trial,grade\na,light\nb,heavy\nc,1\nd,medium\n")  # mostly text: kept
    assert read_trial_labels(path).rows["c"][0] == {"grade": 1}


# -- accelerometer tree ----------------------------------------------------------------------
@pytest.fixture(scope="module")
def accel_tree(tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("hostile_accel") / "s"
    write_all(out, n_events=500)
    return out / "accel_tree"


@pytest.mark.slow
@pytest.mark.parametrize("damage,needle", [
    ("cut-mid-row", "does not end with a line break"),
    ("nul-bytes", "NUL bytes"),
])
def test_damaged_accel_csv_is_one_line(tmp_path, accel_tree, damage, needle):
    import shutil
    root = tmp_path / "tree"
    shutil.copytree(accel_tree, root)
    csv = root / "wood" / "0" / "0.16" / "data.csv"
    raw = csv.read_bytes()
    if damage == "cut-mid-row":
        csv.write_bytes(raw.rstrip(b"\n")[:-3])
        n_lines = raw.count(b"\n")
    else:
        lines = raw.splitlines(keepends=True)
        lines[2] = b"\0" * 5 + lines[2]
        csv.write_bytes(b"".join(lines))
        n_lines = 3
    out = tmp_path / "o.h5"
    result = runner.invoke(app, ["ingest", str(root), "--format", "accel-tree", "--out",
                                 str(out), "--no-progress"])
    line = _one_error(result, out, needle=needle)
    assert f"data.csv, line {n_lines}" in line


def test_npy_events_still_ingest(tmp_path, events_npy):
    """The new checks keep a clean file with clean sidecars working."""
    ann = tmp_path / "a.csv"
    ann.write_text("trial,start_s,end_s,label\nevents,0,0.001,press\n")
    labels = tmp_path / "l.csv"
    labels.write_text("trial,force_level,note\nevents,3,none\n")
    out = tmp_path / "o.h5"
    result = runner.invoke(app, ["ingest", str(events_npy), "--width", "64", "--height", "48",
                                 "--annotations", str(ann), "--trial-labels", str(labels),
                                 "--out", str(out), "--no-progress"])
    assert result.exit_code == 0, result.output
    assert out.is_file() and np.isfinite(out.stat().st_size)
