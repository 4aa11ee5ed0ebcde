"""Adding /derived groups to an existing tactile file: copy, validate, rename; never in place."""

from __future__ import annotations

import hashlib
import json
import os

import h5py
import numpy as np
import pytest

from tactile_cli import __version__
from tactile_cli.errors import InputError, SchemaError
from tactile_cli.store import StoreWriter, validate_file
from tactile_cli.store.atomic import LIVE_TEMPORARIES, remove_live_temporaries
from tactile_cli.store.update import DerivedUpdate, check_derived_targets, update_derived


def _digest(path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


@pytest.fixture
def h5file(tmp_path):
    path = tmp_path / "rec.h5"
    rng = np.random.default_rng(0)
    with StoreWriter(path, command="test") as w:
        s = w.add_sensor("dvs", kind="event_camera", sample_rate_hz=0, width_px=64, height_px=48)
        ev = w.trial("t0", labels={"force_level": 3}).events(s)
        n = 3000
        ev.append(rng.integers(0, 64, n), rng.integers(0, 48, n),
                  np.sort(rng.integers(0, 500_000, n)), rng.choice([-1, 1], n))
        ev.close()
        w.commit()
    return path


def _temporaries(path):
    return sorted(p.name for p in path.parent.glob(f".{path.name}.tmp-*"))


def test_success_adds_a_validated_group_with_provenance(h5file):
    with h5py.File(h5file) as h5:
        t_before = h5["trials/t0/events/t"][()]
    with update_derived(h5file, "fits", "fos_press", command="tactile fit-fos rec.h5",
                        config={"solver": "lm"}, inputs={"file": "rec.h5"}) as group:
        assert group.name == "/derived/fits/fos_press"
        group.create_dataset("alpha", data=np.array([1.0, 2.0]))
        assert _temporaries(h5file) == [f".rec.h5.tmp-{os.getpid()}"]
    assert _temporaries(h5file) == []
    assert validate_file(h5file).ok
    with h5py.File(h5file) as h5:
        g = h5["derived/fits/fos_press"]
        np.testing.assert_array_equal(g["alpha"][()], [1.0, 2.0])
        assert g.attrs["command"] == "tactile fit-fos rec.h5"
        assert g.attrs["tool_version"] == __version__
        assert g.attrs["created_utc"].startswith("20")
        assert json.loads(g.attrs["config_json"]) == {"solver": "lm"}
        assert json.loads(g.attrs["inputs_json"]) == {"file": "rec.h5"}
        np.testing.assert_array_equal(h5["trials/t0/events/t"][()], t_before)
        assert h5.attrs["command"] == "test"  # the file's own provenance is kept


def test_error_inside_the_block_leaves_the_original_byte_identical(h5file):
    before = _digest(h5file)
    with pytest.raises(RuntimeError, match="boom"):
        with update_derived(h5file, "fits", "fos_press") as group:
            group.create_dataset("alpha", data=np.ones(3))
            raise RuntimeError("boom")
    assert _digest(h5file) == before
    assert _temporaries(h5file) == []
    assert not LIVE_TEMPORARIES


def test_interrupt_inside_the_block_leaves_the_original_byte_identical(h5file):
    before = _digest(h5file)
    with pytest.raises(KeyboardInterrupt):
        with update_derived(h5file, "fits", "fos_press"):
            raise KeyboardInterrupt
    assert _digest(h5file) == before
    assert _temporaries(h5file) == []


def test_a_copy_that_breaks_the_schema_is_not_renamed(h5file):
    before = _digest(h5file)
    with pytest.raises(SchemaError, match="the updated file would break the schema .*"
                                          "not part of the schema.*the file was left unchanged"):
        with update_derived(h5file, "fits", "fos_press") as group:
            group.file.create_group("not_in_schema")
    assert _digest(h5file) == before
    assert _temporaries(h5file) == []


def test_live_temporary_is_registered_for_ctrl_c(h5file):
    update = DerivedUpdate(h5file, [("fits", "a")])
    try:
        assert update.tmp in LIVE_TEMPORARIES and update.tmp.exists()
        update._h5.close()  # what the CLI's interrupt handler finds: an open, unfinished copy
        update._h5 = None
        remove_live_temporaries()
        assert not update.tmp.exists()
    finally:
        update.abort()
    assert not LIVE_TEMPORARIES


def test_existing_group_needs_overwrite(h5file):
    with update_derived(h5file, "fits", "fos_press") as g:
        g.create_dataset("alpha", data=[1.0])
    before = _digest(h5file)
    with pytest.raises(InputError) as exc:
        with update_derived(h5file, "fits", "fos_press"):
            pass
    assert str(exc.value) == (f"{h5file}: /derived/fits/fos_press exists already; "
                              "pass `overwrite=True` to replace it")
    assert _digest(h5file) == before
    with update_derived(h5file, "fits", "fos_press", overwrite=True) as g:
        g.create_dataset("tau_s", data=[0.3])
    with h5py.File(h5file) as h5:
        assert list(h5["derived/fits/fos_press"]) == ["tau_s"]  # replaced, not merged
    assert validate_file(h5file).ok


def test_two_groups_in_one_update(h5file):
    with DerivedUpdate(h5file, [("fits", "fos_press"), ("fits", "fos_slip")]) as up:
        up.group("fits", "fos_press").create_dataset("alpha", data=[1.0])
        up.group("fits", "fos_slip").create_dataset("alpha", data=[2.0])
        with pytest.raises(KeyError, match="not a target"):
            up.group("fits", "other")
        up.commit()
    with h5py.File(h5file) as h5:
        assert sorted(h5["derived/fits"]) == ["fos_press", "fos_slip"]


def test_bad_inputs(tmp_path, h5file):
    with pytest.raises(InputError, match="file not found"):
        check_derived_targets(tmp_path / "missing.h5", [("fits", "a")])
    plain = tmp_path / "plain.h5"
    with h5py.File(plain, "w") as h5:
        h5["x"] = 1
    with pytest.raises(SchemaError, match="not a tactile HDF5 file"):
        check_derived_targets(plain, [("fits", "a")])
    text = tmp_path / "notes.txt"
    text.write_text("hello")
    with pytest.raises(InputError, match="not a readable HDF5 file"):
        check_derived_targets(text, [("fits", "a")])
    with pytest.raises(ValueError, match="`kind` \\(='results'\\) must be one of"):
        check_derived_targets(h5file, [("results", "a")])
    with pytest.raises(ValueError, match="`name`"):
        check_derived_targets(h5file, [("fits", "a/b")])
