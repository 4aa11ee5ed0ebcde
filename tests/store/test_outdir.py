"""Output folders built in a hidden temporary folder beside the target and renamed into
place (tactile_cli/store/outdir.py)."""

from __future__ import annotations

import pytest

from tactile_cli import interrupt
from tactile_cli.errors import InputError
from tactile_cli.interrupt import Interrupted
from tactile_cli.store.atomic import LIVE_TEMPORARIES, check_output_file, remove_live_temporaries
from tactile_cli.store.outdir import check_output_folder, output_folder


@pytest.fixture(autouse=True)
def _no_interrupt_left():
    yield
    interrupt.clear()


def _tree(folder):
    return {str(p.relative_to(folder)): p.read_text() for p in folder.rglob("*") if p.is_file()}


def test_success_renames_the_folder_into_place_and_leaves_no_temporary(tmp_path):
    out = tmp_path / "out"
    with output_folder(out) as tmp:
        assert tmp.parent == tmp_path and tmp.name.startswith(".out.tmp-")
        assert tmp in LIVE_TEMPORARIES
        (tmp / "a.txt").write_text("a")
    assert _tree(out) == {"a.txt": "a"}
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out"]
    assert tmp not in LIVE_TEMPORARIES


def test_an_error_leaves_no_target_no_temporary_and_no_created_parents(tmp_path):
    out = tmp_path / "new" / "deep" / "out"
    with pytest.raises(RuntimeError, match="disk full"), output_folder(out) as tmp:
        (tmp / "a.txt").write_text("a")
        raise RuntimeError("disk full")
    assert list(tmp_path.iterdir()) == []


def test_an_interrupt_keeps_the_earlier_folder(tmp_path):
    out = tmp_path / "out"
    out.mkdir()
    (out / "old.txt").write_text("old")
    with pytest.raises(Interrupted), output_folder(out, overwrite=True) as tmp:
        (tmp / "new.txt").write_text("new")
        interrupt.request()  # what the CLI's signal handler does
    assert _tree(out) == {"old.txt": "old"}
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out"]


def test_existing_folder_refused_before_work_unless_overwrite(tmp_path):
    out = tmp_path / "out"
    out.mkdir()
    (out / "old.txt").write_text("old")
    with pytest.raises(InputError, match="not empty; pass `overwrite=True`"), \
            output_folder(out):
        pytest.fail("the body must not run")
    with output_folder(out, overwrite=True) as tmp:
        (tmp / "new.txt").write_text("new")
    assert _tree(out) == {"new.txt": "new"}
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out"]  # the old one is deleted


def test_merge_replaces_same_names_and_keeps_the_rest(tmp_path):
    out = tmp_path / "out"
    (out / "t0").mkdir(parents=True)
    (out / "t0" / "frame_0000.png").write_text("old frame")
    (out / "keep.txt").write_text("keep")
    (out / "index.html").write_text("old page")
    with output_folder(out, merge=True) as tmp:
        (tmp / "t0").mkdir()
        (tmp / "t0" / "contact_sheet.png").write_text("sheet")
        (tmp / "index.html").write_text("new page")
    assert _tree(out) == {"keep.txt": "keep", "index.html": "new page",
                          "t0/contact_sheet.png": "sheet"}
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out"]


@pytest.mark.parametrize("where", ["target", "parent"])
def test_a_file_where_the_folder_goes_is_one_input_error(tmp_path, where):
    blocker = tmp_path / "f"
    blocker.write_text("mine")
    out = blocker if where == "target" else blocker / "sub"
    for kwargs in ({}, {"overwrite": True}, {"merge": True}):
        with pytest.raises(InputError) as err, output_folder(out, **kwargs):
            pytest.fail("the body must not run")
        assert str(err.value).startswith(f"{blocker}: is a file")
        assert "\n" not in str(err.value)
    assert blocker.read_text() == "mine"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["f"]


def test_live_temporary_folders_are_removed_by_the_cli_cleanup(tmp_path):
    with pytest.raises(RuntimeError), output_folder(tmp_path / "out") as tmp:
        (tmp / "sub").mkdir()
        (tmp / "sub" / "x").write_text("x")
        remove_live_temporaries()  # what run_guarded does on an interrupt
        assert not tmp.exists()
        raise RuntimeError("stop")
    assert list(tmp_path.iterdir()) == []


def test_check_output_file_refuses_a_folder_and_a_file_parent(tmp_path):
    (tmp_path / "d").mkdir()
    (tmp_path / "f").write_text("x")
    with pytest.raises(InputError, match="is a folder; give a file name"):
        check_output_file(tmp_path / "d", overwrite=True)
    with pytest.raises(InputError, match="is a file, not a folder"):
        check_output_file(tmp_path / "f" / "out.csv")
    with pytest.raises(InputError, match="output exists; pass `overwrite=True`"):
        check_output_file(tmp_path / "f")
    assert check_output_file(tmp_path / "new.csv") == tmp_path / "new.csv"
    assert check_output_folder(tmp_path / "d") == tmp_path / "d"  # empty: fine
