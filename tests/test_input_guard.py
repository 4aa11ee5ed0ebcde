"""Inputs are sacred (tactile_cli/input_guard.py): an output that is an input, contains one or
lies inside an input folder is refused in one line, by the library verb up front and by every
atomic writer of the store at its start and at its final rename."""

from __future__ import annotations

import hashlib
import os
from pathlib import Path

import pytest
from typer.testing import CliRunner

from tactile_cli.cli import app
from tactile_cli.errors import InputError
from tactile_cli.input_guard import (
    check_outputs,
    input_scope,
    note_input,
    noted_inputs,
    overlap,
    refuse_overlap,
)
from tactile_cli.store import StoreWriter, TactileFile
from tactile_cli.store.atomic import write_text
from tactile_cli.store.outdir import output_folder

from .cli.test_plot import _file

runner = CliRunner()


@pytest.fixture
def rec(tmp_path) -> Path:
    folder = tmp_path / "scene"
    (folder / "trials" / "t0").mkdir(parents=True)
    (folder / "trials" / "t0" / "frame_0.png").write_bytes(b"png")
    (folder / "labels.csv").write_text("trial\nt0\n")
    return folder


def test_overlap_is_contains_inside_and_apart(rec, tmp_path):
    frame = rec / "trials" / "t0" / "frame_0.png"
    assert overlap(frame, frame) == "is"
    assert overlap(rec / "trials" / ".." / "trials" / "t0" / "frame_0.png", frame) == "is"
    assert overlap(rec, frame) == "contains"
    assert overlap(rec / "trials", frame) == "contains"
    assert overlap(rec / "plots", rec) == "inside"  # a folder input is a tree
    assert overlap(rec / "plots", rec, tree=False) is None  # a run folder's files only
    assert overlap(tmp_path / "elsewhere", rec) is None
    assert overlap(tmp_path / "scene2", rec) is None  # a name that only starts the same


def test_symlinks_and_hard_links_are_seen_through(rec, tmp_path):
    frame = rec / "trials" / "t0" / "frame_0.png"
    link = tmp_path / "link"
    link.symlink_to(rec)
    assert overlap(link / "trials", frame) == "contains"
    hard = tmp_path / "hard.png"
    os.link(frame, hard)
    assert overlap(hard, frame) == "is"


def test_check_outputs_names_the_argument_and_the_input(rec):
    with pytest.raises(InputError) as err:
        check_outputs({"out": None, "plot": rec}, [rec / "labels.csv"], trees=[rec])
    assert str(err.value) == (f"{rec}: `plot` contains the input {rec / 'labels.csv'}; the "
                              "toolkit never overwrites or deletes its inputs: give an output "
                              "elsewhere")
    with pytest.raises(InputError, match=r"`plot` is the input"):
        check_outputs({"plot": rec}, [], trees=[rec])
    with pytest.raises(InputError, match="lies inside the input folder"):
        check_outputs([rec / "trials" / "t0" / "plots"], [], trees=[rec])
    check_outputs({"out": rec.parent / "out.h5"}, [rec / "labels.csv"], trees=[rec])


def test_the_scope_collects_inputs_and_every_writer_refuses_them(tmp_path):
    src = _file(tmp_path / "rec.h5")
    before = hashlib.sha256(src.read_bytes()).hexdigest()
    assert noted_inputs() == []
    note_input(src)  # outside a scope: nothing is kept (a notebook's later calls are free)
    assert noted_inputs() == []
    with input_scope():
        with TactileFile(src):
            pass
        assert noted_inputs() == [src.resolve()]
        with pytest.raises(InputError, match="is the input"):
            refuse_overlap(src)
        with pytest.raises(InputError, match="is the input"):
            write_text(src, "x", overwrite=True)
        with pytest.raises(InputError, match="is the input"):
            StoreWriter(src, overwrite=True)
        with pytest.raises(InputError, match="contains the input"):
            with output_folder(tmp_path, overwrite=True):
                pass
    assert noted_inputs() == []
    assert hashlib.sha256(src.read_bytes()).hexdigest() == before


def test_an_input_opened_after_the_output_check_is_refused_at_the_rename(tmp_path):
    src = _file(tmp_path / "rec.h5")
    before = src.read_bytes()
    with input_scope():
        with pytest.raises(InputError, match="contains the input"):
            with output_folder(tmp_path / "figs") as tmp:  # checked before the input is read
                (tmp / "a.txt").write_text("x")
                note_input(tmp_path / "figs" / "a.txt")  # ...then read as an input
    assert src.read_bytes() == before
    assert not (tmp_path / "figs").exists()


def test_accumulate_refuses_to_write_its_csv_over_its_input(tmp_path):
    src = _file(tmp_path / "rec.h5")
    before = src.read_bytes()
    result = runner.invoke(app, ["accumulate", str(src), "--csv", str(src), "--overwrite"])
    assert result.exit_code == 2, result.output
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and "is the input" in lines[0], result.stderr
    assert src.read_bytes() == before
