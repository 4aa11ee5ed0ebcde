"""The atomic writer, the validator and the readers of the tactile HDF5 store."""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys

import h5py
import numpy as np
import pytest

from tactile_cli.errors import InputError, SchemaError
from tactile_cli.store import StoreWriter, load_spec, read_events_window, summarize, validate_file
from tactile_cli.store.validate import check_readable


def _write_small(path, *, n_events=5000, seed=0):
    rng = np.random.default_rng(seed)
    t = np.sort(rng.integers(0, 200_000, n_events)).astype(np.int64) + 1_600_000_000_000_000
    x = rng.integers(0, 64, n_events)
    y = rng.integers(0, 48, n_events)
    p = rng.choice(np.array([-1, 1]), n_events)
    with StoreWriter(path, command="test", config={"a": 1}) as w:
        s = w.add_sensor("dvs", kind="event_camera", sample_rate_hz=0, width_px=64, height_px=48)
        tr = w.trial(
            "rec 1",
            labels={"object": "box", "force_level": 3},
            annotations=[(0.0, 0.05, "press"), (0.05, 0.2, "slip")],
        )
        ev = tr.events(s)
        for i in range(0, n_events, 1234):
            ev.append(x[i : i + 1234], y[i : i + 1234], t[i : i + 1234], p[i : i + 1234])
        ev.close()
        acc = w.add_sensor(
            "acc",
            kind="accelerometer",
            sample_rate_hz=100,
            channel_names=["ax", "ay"],
            channel_units=["g", "g"],
            channel_delays_s=[0.0, 0.005],
        )
        tr2 = w.trial("rec 1", labels={"object": "wood"}, split="train")
        tr2.write_signal(
            "acc",
            sensor=acc,
            data=rng.normal(size=(50, 2)),
            t_s=np.arange(50) / 100,
            sample_labels={"motion": (np.arange(50) % 3, ["no_motion", "slide", "slip"])},
        )
        w.commit()
    return {"x": x, "y": y, "t": t, "p": p}


def test_written_file_is_valid_and_reads_back(tmp_path):
    out = tmp_path / "a.h5"
    truth = _write_small(out)
    report = validate_file(out)
    assert report.ok, report.violations
    assert report.schema_version == load_spec().version
    with h5py.File(out) as h5:
        assert h5.attrs["command"] == "test"
        assert json.loads(h5.attrs["config_json"]) == {"a": 1}
        assert h5["schema/spec_json"].asstr()[()] == load_spec().raw_json  # self-describing copy
        ev = h5["trials/rec_1/events"]
        for k in "xytp":
            np.testing.assert_array_equal(ev[k][()], truth[k])
        assert ev["x"].dtype == np.uint16 and ev["t"].dtype == np.int64 and ev["p"].dtype == np.int8
        assert ev["x"].compression == "gzip" and ev["x"].shuffle
        assert list(h5["trials"]) == ["rec_1", "rec_1_2"]  # duplicate trial names get a suffix
        assert h5["trials/rec_1/annotations/label"].asstr()[()].tolist() == ["press", "slip"]
    s = summarize(out)
    assert [t.n_events for t in s.trials] == [5000, 0]
    assert s.label_counts["object"] == {"box": 1, "wood": 1}


def test_ms_index_window_matches_brute_force(tmp_path):
    out = tmp_path / "a.h5"
    truth = _write_small(out, n_events=20000, seed=3)
    origin = truth["t"][0]
    for t0, t1 in [(0, 50), (13, 14), (120, 500), (199, 200)]:
        got = read_events_window(out, "rec_1", t0, t1)
        mask = (truth["t"] >= origin + 1000 * t0) & (truth["t"] < origin + 1000 * t1)
        np.testing.assert_array_equal(got["t"], truth["t"][mask])
        np.testing.assert_array_equal(got["x"], truth["x"][mask])


def test_existing_output_needs_overwrite(tmp_path):
    out = tmp_path / "a.h5"
    out.write_bytes(b"old")
    with pytest.raises(InputError, match="output exists; pass `overwrite=True`"):
        StoreWriter(out)
    assert out.read_bytes() == b"old"


def test_failure_leaves_no_file_and_keeps_earlier_output(tmp_path):
    out = tmp_path / "a.h5"
    out.write_bytes(b"old")
    with pytest.raises(InputError, match=r"src\.csv, row 7: x = 99 is outside the sensor"):
        with StoreWriter(out, overwrite=True) as w:
            s = w.add_sensor(
                "dvs", kind="event_camera", sample_rate_hz=0, width_px=64, height_px=48
            )
            ev = w.trial("t").events(s)
            x = np.zeros(10, dtype=np.int64)
            x[5] = 99
            ev.append(x, x * 0, np.arange(10), np.ones(10), source="src.csv", first_row=2)
    assert out.read_bytes() == b"old"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a.h5"]


def test_interrupt_leaves_no_temp_file(tmp_path):
    out = tmp_path / "a.h5"
    with pytest.raises(KeyboardInterrupt):
        with StoreWriter(out) as w:
            w.add_sensor("dvs", kind="event_camera", sample_rate_hz=0, width_px=4, height_px=4)
            raise KeyboardInterrupt
    assert list(tmp_path.iterdir()) == []


def test_invalid_content_is_not_renamed_into_place(tmp_path):
    out = tmp_path / "a.h5"
    with pytest.raises(SchemaError, match="breaks the schema"):
        with StoreWriter(out) as w:
            w.add_sensor("weird", kind="not_a_kind", sample_rate_hz=1, channel_names=["a"])
            w.trial("t")
            w.commit()
    assert list(tmp_path.iterdir()) == []


def test_event_checks_name_the_row(tmp_path):
    with StoreWriter(tmp_path / "a.h5") as w:
        s = w.add_sensor("dvs", kind="event_camera", sample_rate_hz=0, width_px=8, height_px=8)
        ev = w.trial("t").events(s)
        ev.append(
            np.zeros(3), np.zeros(3), np.array([5, 6, 7]), np.ones(3), source="f.csv", first_row=2
        )
        with pytest.raises(
            InputError, match=r"f\.csv, row 10: timestamp 6 us is earlier than the previous 7"
        ):
            ev.append(
                np.zeros(2), np.zeros(2), np.array([6, 8]), np.ones(2), source="f.csv", first_row=10
            )
        with pytest.raises(InputError, match=r"row 4: polarity 0 is not -1/\+1"):
            ev.append(
                np.zeros(2),
                np.zeros(2),
                np.array([8, 9]),
                np.array([1, 0]),
                source="f.csv",
                first_row=3,
            )


def _corrupt(src, dst, edit):
    shutil.copy(src, dst)
    with h5py.File(dst, "a") as h5:
        edit(h5)
    return validate_file(dst)


@pytest.mark.parametrize(
    ("edit", "path", "message"),
    [
        (
            lambda h: h["trials/rec_1/events/p"].__setitem__(3, 0),
            "/trials/rec_1/events/p",
            "values outside [-1, 1], first at index 3",
        ),
        (
            lambda h: h["trials/rec_1/events/y"].__setitem__(9, 48),
            "/trials/rec_1/events/y",
            "values >= height_px of /sensors/dvs (48), first at index 9",
        ),
        (
            lambda h: h["trials/rec_1/events/t"].__setitem__(100, 0),
            "/trials/rec_1/events/t",
            "time goes backwards at index 100",
        ),
        (
            lambda h: h["sensors/acc"].attrs.__setitem__("kind", "banana"),
            "/sensors/acc (attribute 'kind')",
            "value 'banana' is not one of",
        ),
        (
            lambda h: h.__delitem__("trials/rec_1_2/labels"),
            "/trials/rec_1_2/labels",
            "required group is missing",
        ),
        (lambda h: h.create_group("junk"), "/junk", "not part of the schema"),
        (
            lambda h: h["sensors/dvs"].attrs.__delitem__("width_px"),
            "/sensors/dvs",
            "missing attribute 'width_px'",
        ),
        (
            lambda h: h["trials/rec_1_2/signals/acc"].attrs.__setitem__("sensor", "nope"),
            "/trials/rec_1_2/signals/acc (attribute 'sensor')",
            "refers to /sensors/nope, which does not exist",
        ),
        (
            lambda h: h["trials/rec_1"].attrs.__setitem__("split", "training"),
            "/trials/rec_1 (attribute 'split')",
            "not one of",
        ),
        (
            lambda h: (
                h.__delitem__("provenance/sources/sha256"),
                h["provenance/sources"].create_dataset(
                    "sha256", data=["xyz"], dtype=h5py.string_dtype()
                ),
            ),
            "/provenance/sources/sha256",
            "does not match",
        ),
    ],
)
def test_validator_reports_each_violation_with_its_path(tmp_path, edit, path, message):
    good = tmp_path / "good.h5"
    _write_small(good)
    report = _corrupt(good, tmp_path / "bad.h5", edit)
    assert not report.ok
    hits = [v for v in report.violations if v.h5_path == path and message in v.message]
    assert hits, [str(v) for v in report.violations]


def test_signal_column_and_length_checks(tmp_path):
    good = tmp_path / "good.h5"
    _write_small(good)

    def edit(h):
        del h["trials/rec_1_2/signals/acc/t_s"]
        h["trials/rec_1_2/signals/acc"].create_dataset("t_s", data=np.arange(49, dtype=np.float64))
        del h["sensors/acc/channel_units"]
        h["sensors/acc"].create_dataset("channel_units", data=["g"], dtype=h5py.string_dtype())

    report = _corrupt(good, tmp_path / "bad.h5", edit)
    text = [str(v) for v in report.violations]
    assert any(
        "/trials/rec_1_2/signals/acc: datasets that must have equal length differ: data=50, t_s=49"
        in v
        for v in text
    ), text
    assert any("/sensors/acc: datasets that must have equal length differ" in v for v in text), text


def test_version_rules(tmp_path):
    good = tmp_path / "good.h5"
    _write_small(good)
    major = _corrupt(
        good, tmp_path / "major.h5", lambda h: h.attrs.__setitem__("schema_version", "2.0")
    )
    assert not major.ok and "re-create the file" in major.violations[0].message
    with pytest.raises(SchemaError, match="cannot be read by this tool"):
        check_readable(tmp_path / "major.h5")

    def newer_minor(h):
        h.attrs["schema_version"] = f"{load_spec().major}.{load_spec().minor + 1}"
        h.create_group("trials/rec_1/future_modality")

    newer = _corrupt(good, tmp_path / "newer.h5", newer_minor)
    assert newer.ok and "newer than this tool" in newer.notes[0]
    with pytest.warns(UserWarning, match="newer than this tool"):
        check_readable(tmp_path / "newer.h5")
    other = tmp_path / "other.h5"
    with h5py.File(other, "w") as h5:
        h5["x"] = 1
    report = validate_file(other)
    assert not report.ok and "not a tactile file" in report.violations[0].message
    (tmp_path / "text.h5").write_text("hello")
    assert "not a readable HDF5 file" in validate_file(tmp_path / "text.h5").violations[0].message


def test_derived_groups_need_their_own_provenance(tmp_path):
    good = tmp_path / "good.h5"
    _write_small(good)

    def add_fits(h):
        g = h.create_group("derived/fits/fos_press")
        g.attrs["command"] = "tactile fit-fos"
        g.attrs["tool_version"] = "0.1.0"
        g.attrs["created_utc"] = "2026-11-23T10:00:00+00:00"
        g.create_dataset("anything/inside", data=[1, 2, 3])  # inner layout is the command's own

    assert _corrupt(good, tmp_path / "ok.h5", add_fits).ok
    bad = _corrupt(
        good, tmp_path / "bad.h5", lambda h: h.create_group("derived/fits/no_provenance")
    )
    assert {v.message for v in bad.violations} >= {
        "missing attribute 'command'",
        "missing attribute 'created_utc'",
    }
    odd = _corrupt(good, tmp_path / "odd.h5", lambda h: h.create_group("derived/guesses"))
    assert any("is not one of" in v.message for v in odd.violations)


def test_stale_temporaries_of_killed_writers_are_removed(tmp_path):
    out = tmp_path / "a.h5"
    dead = subprocess.run(
        [sys.executable, "-c", "import os; print(os.getpid())"],
        capture_output=True,
        text=True,
        check=True,
    ).stdout.strip()
    stale = tmp_path / f".a.h5.tmp-{dead}"
    stale.write_bytes(b"left by a killed writer")
    live = tmp_path / f".a.h5.tmp-{os.getpid()}0"  # not a pid of ours; may or may not be alive
    other = tmp_path / ".b.h5.tmp-1"
    other.write_bytes(b"another output's")
    with StoreWriter(out) as w:
        assert not stale.exists()
        w.add_sensor(
            "acc", kind="accelerometer", sample_rate_hz=1, channel_names=["a"], channel_units="g"
        )
        w.trial("t")
        w.commit()
    assert other.exists() and not live.exists()
    assert sorted(p.name for p in tmp_path.iterdir()) == [".b.h5.tmp-1", "a.h5"]


def test_verified_datasets_skip_only_value_scans(tmp_path):
    good = tmp_path / "good.h5"
    _write_small(good)

    def edit(h):
        h["trials/rec_1/events/p"][3] = 0
        h["trials/rec_1/signals"] = 1  # structural problems are always reported

    bad = tmp_path / "bad.h5"
    _corrupt(good, bad, edit)
    report = validate_file(bad, verified={"/trials/rec_1/events/p"})
    assert [v.h5_path for v in report.violations] == ["/trials/rec_1/signals"]
    assert any(v.h5_path == "/trials/rec_1/events/p" for v in validate_file(bad).violations)


def test_trials_keep_input_order(tmp_path):
    out = tmp_path / "a.h5"
    with StoreWriter(out) as w:
        s = w.add_sensor(
            "acc", kind="accelerometer", sample_rate_hz=1, channel_names=["a"], channel_units="g"
        )
        for name in ["mat2_1", "mat10_1", "mat1_1"]:
            w.trial(name).write_signal("x y", sensor=s, data=np.zeros((2, 1)), t_s=np.arange(2.0))
        w.commit()
    assert [t.name for t in summarize(out).trials] == ["mat2_1", "mat10_1", "mat1_1"]
    with h5py.File(out) as h5:
        assert list(h5["trials/mat2_1/signals"]) == ["x_y"]


def test_a_killed_writer_not_yet_reaped_counts_as_dead():
    """A zombie (killed, its parent has not waited for it yet) writes nothing any more, so
    its temporaries are stale: a retry on another worker must not leave them behind."""
    import time

    from tactile_cli.store.atomic import process_alive

    child = subprocess.Popen([sys.executable, "-c", "import time; time.sleep(60)"])
    try:
        assert process_alive(child.pid) and process_alive(os.getpid())
        child.kill()
        deadline = time.monotonic() + 10
        while process_alive(child.pid) and time.monotonic() < deadline:
            time.sleep(0.05)
        assert not process_alive(child.pid)  # a zombie until the wait below
    finally:
        child.wait()
    assert not process_alive(child.pid)
