"""The one atomic writer for single files (tactile_cli/store/atomic.py): a temporary file
beside the target renamed over it only when complete; an existing output replaced only at
that moment; file-system failures as one line; and no other package renaming files."""

from __future__ import annotations

import errno
import os
import re
import subprocess
from pathlib import Path

import numpy as np
import pytest

import tactile_cli
from tactile_cli.errors import InputError
from tactile_cli.store import atomic
from tactile_cli.store.atomic import (
    LIVE_TEMPORARIES,
    atomic_file,
    check_output_file,
    check_writable,
    save_figure,
    write_bytes,
    write_json,
    write_text,
)

PACKAGE = Path(tactile_cli.__file__).parent
def renames_outside_store(root: Path) -> list[str]:
    """``file:line`` of every ``os.replace``/``os.rename``/``Path.rename`` call outside
    ``store/`` in the package below ``root``."""
    found = []
    for path in sorted(root.rglob("*.py")):
        rel = path.relative_to(root)
        if rel.parts[0] == "store":
            continue
        for i, line in enumerate(path.read_text(encoding="utf-8").splitlines(), 1):
            code = line.split("#", 1)[0]
            if re.search(r"\bos\.(replace|rename|renames)\(", code) or re.search(
                    r"\.rename\(", code):
                found.append(f"{rel}:{i}")
    return found


def test_no_package_but_store_renames_files():
    assert renames_outside_store(PACKAGE) == []


def test_the_rename_check_catches_a_planted_rename(tmp_path):
    pkg = tmp_path / "pkg"
    (pkg / "store").mkdir(parents=True)
    (pkg / "chain").mkdir()
    (pkg / "store" / "ok.py").write_text("import os\nos.replace('a', 'b')\n")
    (pkg / "chain" / "bad.py").write_text("import os\n\nos.replace(tmp, out)  # atomic\n")
    (pkg / "chain" / "worse.py").write_text("from pathlib import Path\nPath('a').rename('b')\n")
    assert renames_outside_store(pkg) == ["chain/bad.py:3", "chain/worse.py:2"]


def _hidden(folder: Path) -> list[str]:
    return sorted(p.name for p in folder.iterdir() if p.name.startswith("."))


def test_write_text_bytes_json_round_trip_and_leave_no_temporary(tmp_path):
    assert write_text(tmp_path / "a.txt", "héllo\n").read_text(encoding="utf-8") == "héllo\n"
    assert write_bytes(tmp_path / "b.bin", b"\x00\xff").read_bytes() == b"\x00\xff"
    write_json(tmp_path / "c.json", {"x": [1, 2.5]})
    assert (tmp_path / "c.json").read_text() == '{\n  "x": [\n    1,\n    2.5\n  ]\n}\n'
    assert _hidden(tmp_path) == []
    assert not LIVE_TEMPORARIES


def test_json_refuses_nan(tmp_path):
    with pytest.raises(ValueError):
        write_json(tmp_path / "c.json", {"x": float("nan")})
    assert list(tmp_path.iterdir()) == []


def test_an_existing_output_needs_overwrite_and_is_replaced_whole(tmp_path):
    out = tmp_path / "r.csv"
    out.write_text("old\n")
    with pytest.raises(InputError, match=r"output exists; pass `overwrite=True`"):
        write_text(out, "new\n")
    assert out.read_text() == "old\n"
    write_text(out, "new\n", overwrite=True)
    assert out.read_text() == "new\n"


def test_an_error_while_writing_leaves_the_old_output_byte_identical(tmp_path):
    out = tmp_path / "r.csv"
    out.write_bytes(b"old contents\n")
    with pytest.raises(RuntimeError, match="boom"), atomic_file(out, overwrite=True) as tmp:
        tmp.write_bytes(b"half of the new")
        assert out.read_bytes() == b"old contents\n"  # not touched before the end
        raise RuntimeError("boom")
    assert out.read_bytes() == b"old contents\n"
    assert _hidden(tmp_path) == []


def test_a_full_disk_is_one_line_naming_the_output(tmp_path):
    out = tmp_path / "r.csv"
    out.write_text("old\n")
    with pytest.raises(InputError) as err, atomic_file(out, overwrite=True) as tmp:
        raise OSError(errno.ENOSPC, "No space left on device", str(tmp))
    assert str(err.value) == (f"{out}: cannot write the output (No space left on device); "
                              "nothing was written")
    assert out.read_text() == "old\n"
    assert _hidden(tmp_path) == []


def test_an_oserror_about_another_file_is_not_blamed_on_the_output(tmp_path):
    with pytest.raises(PermissionError), atomic_file(tmp_path / "r.csv"):
        raise PermissionError(errno.EACCES, "Permission denied", "/elsewhere/input.csv")


def test_stale_temporaries_of_dead_writers_are_swept(tmp_path):
    out = tmp_path / "r.png"
    proc = subprocess.Popen(["true"])
    proc.wait()
    stale = [tmp_path / f".r.png.tmp-{proc.pid}", tmp_path / f".r.png.tmp-{proc.pid}.png",
             tmp_path / f".r.png.old-{proc.pid}"]
    for s in stale:
        s.write_text("x")
    live = tmp_path / f".r.png.tmp-{os.getppid()}"  # a live writer's: kept
    live.write_text("x")
    write_text(out, "ok")
    assert _hidden(tmp_path) == [live.name]


def test_a_folder_that_refuses_new_files_is_refused_before_work(tmp_path, monkeypatch):
    real_open = os.open

    def refuse(path, flags, *args):
        if ".tactile-probe" in str(path):
            raise PermissionError(errno.EROFS, "Read-only file system", str(path))
        return real_open(path, flags, *args)

    monkeypatch.setattr(atomic.os, "open", refuse)
    with pytest.raises(InputError, match=r"cannot write in this folder \(Read-only file "
                                         r"system\); give an output in a folder"):
        check_output_file(tmp_path / "r.csv")


def _chattr(flag: str, path: Path) -> bool:
    try:
        return subprocess.run(["chattr", flag, str(path)], capture_output=True).returncode == 0
    except FileNotFoundError:
        return False


def test_immutable_folder_and_file_are_refused(tmp_path):
    folder = tmp_path / "locked"
    folder.mkdir()
    kept = tmp_path / "kept.txt"
    kept.write_text("keep\n")
    if not (_chattr("+i", folder) and _chattr("+i", kept)):
        pytest.skip("chattr +i is not permitted on this file system")
    try:
        with pytest.raises(InputError, match="cannot write in this folder"):
            check_output_file(folder / "r.csv")
        with pytest.raises(InputError, match="immutable"):
            check_writable(kept)
    finally:
        _chattr("-i", folder)
        _chattr("-i", kept)
    assert kept.read_text() == "keep\n"


def test_save_figure_writes_a_png_with_its_provenance_chunks(tmp_path):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from PIL import Image

    fig, ax = plt.subplots()
    ax.plot(np.arange(3))
    out = save_figure(fig, tmp_path / "f.png", meta={"Comment": "tactile plot x.h5"})
    with Image.open(out) as im:
        assert im.format == "PNG"
        assert im.text["Comment"] == "tactile plot x.h5"
    assert not plt.get_fignums()
    assert _hidden(tmp_path) == []
