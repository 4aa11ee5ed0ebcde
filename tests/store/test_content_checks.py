"""Content checks (issue 20): validate reports corrupt content with its HDF5 path and never
raises on a damaged file; the one reader refuses the same content with one line; commands
that compute turn it into one error line with exit 2."""

from __future__ import annotations

import json
import re
import shutil

import h5py
import numpy as np
import pytest
from typer.testing import CliRunner

from tactile_cli.cli import app
from tactile_cli.errors import InputError, SchemaError
from tactile_cli.store import StoreWriter, TactileFile, summarize, validate_file

runner = CliRunner()
W, H = 64, 48


def _write(path):
    """One event trial (ev), one sampled trial (sig, with class labels and annotations)
    and a fits table."""
    rng = np.random.default_rng(0)
    n = 3000
    t = np.sort(rng.integers(0, 300_000, n)).astype(np.int64)
    with StoreWriter(path, command="test") as w:
        dvs = w.add_sensor("dvs", kind="event_camera", sample_rate_hz=0, width_px=W,
                           height_px=H)
        tr = w.trial("ev", annotations=[(0.0, 0.1, "press"), (0.1, 0.2, "slip")])
        app_ = tr.events(dvs)
        app_.append(rng.integers(0, W, n), rng.integers(0, H, n), t,
                    rng.choice(np.array([-1, 1]), n))
        app_.close()
        acc = w.add_sensor("acc", kind="accelerometer", sample_rate_hz=100,
                           channel_names=["ax", "ay"], channel_units="g")
        tr2 = w.trial("sig")
        tr2.write_signal("acc", sensor=acc, data=rng.normal(size=(60, 2)),
                         t_s=np.arange(60) / 100,
                         sample_labels={"motion": (np.arange(60) % 3 - 1,
                                                   ["no_motion", "slide", "slip"])})
        w.commit()
    with h5py.File(path, "a") as h5:  # a fits table as `tactile fit-fos` writes one
        g = h5.create_group("derived/fits/fos_press")
        for k, v in {"command": "t", "tool_version": "0", "created_utc": "2024"}.items():
            g.attrs[k] = v
        g["alpha"] = np.array([1.0, np.nan])  # NaN: a fit that did not converge
        g["trial"] = np.array(["ev", "sig"], dtype=object).astype("S")
    return path


@pytest.fixture(scope="module")
def good(tmp_path_factory):
    path = _write(tmp_path_factory.mktemp("content") / "good.h5")
    assert validate_file(path).ok, validate_file(path).violations
    return path


def _copy(good, tmp_path, edit, name="bad.h5"):
    bad = tmp_path / name
    shutil.copy(good, bad)
    with h5py.File(bad, "a") as h5:
        edit(h5)
    return bad


def _set(path, value):
    def edit(h5):
        group, _, key = path.rpartition("/")
        if "@" in path:
            node, attr = path.split("@")
            h5[node].attrs[attr] = value
        else:
            h5[group][key][...] = value
    return edit


def _replace(path, data):
    def edit(h5):
        del h5[path]
        h5[path] = data
    return edit


CASES = [
    # (edit, violation path, words of its message)
    (lambda h: h["trials/sig/signals/acc/data"].__setitem__((5, 1), np.nan),
     "/trials/sig/signals/acc/data", "non-finite"),
    (lambda h: h["trials/sig/signals/acc/t_s"].__setitem__(7, 0.06),
     "/trials/sig/signals/acc/t_s", "does not increase at index 7"),
    (lambda h: h["sensors/acc"].attrs.__setitem__("sample_rate_hz", np.inf),
     "/sensors/acc (attribute 'sample_rate_hz')", "not a finite number"),
    (lambda h: h["sensors/acc"].attrs.__setitem__("sample_rate_hz", 0.0),
     "/sensors/acc (attribute 'sample_rate_hz')", "needs its rate > 0"),
    (lambda h: h["trials/sig/signals/acc/sample_labels/motion"].__setitem__(4, 3),
     "/trials/sig/signals/acc/sample_labels/motion", "class codes outside 0..2"),
    (lambda h: h["trials/ev/annotations/end_s"].__setitem__(1, 0.05),
     "/trials/ev/annotations/end_s", "row 1 ends at 0.05 s, before it starts"),
    (_replace("derived/fits/fos_press/alpha", np.array([1.0, 2.0, 3.0])),
     "/derived/fits/fos_press", "columns that must have equal length differ"),
    (lambda h: h["sensors/dvs"].attrs.__setitem__("width_px", "wide"),
     "/sensors/dvs (attribute 'width_px')", "is not an integer"),
    (lambda h: h["sensors/dvs"].attrs.__setitem__("width_px", 0),
     "/sensors/dvs (attribute 'width_px')", "below the minimum 1"),
    (_replace("sensors/acc/channel_units", np.array([1, 2])),
     "/sensors/acc/channel_units", "expected a string dataset"),
    (_replace("sensors/acc/channel_names", np.array(["ax", "ay", "az"], dtype=object)),
     "/trials/sig/signals/acc/data", "sensor /sensors/acc names 3 channels"),
    (lambda h: h["trials/ev/events/x"].__setitem__(11, 65535),
     "/trials/ev/events/x", "values >= width_px"),
    (lambda h: h["trials/ev/events/t"].__setitem__(20, 0),
     "/trials/ev/events/t", "time goes backwards"),
    (lambda h: h["trials/ev/events/p"].__setitem__(2, 0),
     "/trials/ev/events/p", "values outside [-1, 1]"),
    (lambda h: h["sensors/acc"].attrs.__setitem__("sample_rate_hz", 1e300),
     "/sensors/acc (attribute 'sample_rate_hz')", "above the maximum 1e+09"),
    (lambda h: h["trials/sig/signals/acc"].attrs.__setitem__("sample_rate_hz", 0.0),
     "/trials/sig/signals/acc (attribute 'sample_rate_hz')", "must be above 0"),
    (lambda h: h.__delitem__("sensors/acc/channel_names"),
     "/trials/sig/signals/acc/data", "names no channels"),
]


@pytest.mark.parametrize(("edit", "where", "words"), CASES)
def test_validate_reports_corrupt_content_at_its_path(good, tmp_path, edit, where, words):
    report = validate_file(_copy(good, tmp_path, edit))
    assert not report.ok and report.readable
    hits = [v for v in report.violations if v.h5_path == where]
    assert hits, report.violations
    assert any(words in v.message for v in hits), hits


def test_nan_is_allowed_where_the_schema_says_so(good, tmp_path):
    """NaN parameters of unconverged fits, -1 (unlabelled) class codes, NaN numeric
    per-sample labels and zero-length annotations are valid."""
    def edit(h5):
        h5["trials/sig/signals/acc/sample_labels/force"] = np.full(60, np.nan)
        h5["trials/ev/annotations/end_s"][0] = 0.0  # a point annotation
    assert validate_file(_copy(good, tmp_path, edit)).ok


def test_validate_cli_lists_violations_exit_1_and_unreadable_exit_2(good, tmp_path):
    bad = _copy(good, tmp_path, CASES[0][0])
    result = runner.invoke(app, ["validate", str(bad)])
    assert result.exit_code == 1
    assert "/trials/sig/signals/acc/data: non-finite values" in result.stdout
    text = tmp_path / "text.h5"
    text.write_text("not hdf5\n")
    result = runner.invoke(app, ["validate", str(good), str(text)])
    assert result.exit_code == 2
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith(f"tactile: error: {text}: not a readable")
    assert "valid" in result.stdout and "Traceback" not in result.output
    result = runner.invoke(app, ["validate", "--json", str(text)])
    assert result.exit_code == 2 and json.loads(result.stdout)[0]["readable"] is False


def test_validate_reads_every_chunk(tmp_path):
    """A damaged chunk of a dataset no content check reads (frames) is a violation at
    its path, with the HDF5 message on one line."""
    path = tmp_path / "frames.h5"
    rng = np.random.default_rng(1)
    with StoreWriter(path, command="test") as w:
        cam = w.add_sensor("cam", kind="visuotactile", sample_rate_hz=30, width_px=W,
                           height_px=H)
        tr = w.trial("press")
        tr.write_frames(sensor=cam, images=rng.integers(0, 255, (4, H, W, 3), dtype=np.uint8),
                        t_s=np.arange(4) / 30, reference=np.zeros((H, W, 3), np.uint8))
        w.commit()
    with h5py.File(path) as h5:
        ds = h5["trials/press/frames/images"]
        assert ds.compression == "gzip"
        offset, size = ds.id.get_chunk_info(0).byte_offset, ds.id.get_chunk_info(0).size
    data = bytearray(path.read_bytes())
    for k in range(offset + size // 3, offset + size // 3 + 8):
        data[k] ^= 0xFF
    path.write_bytes(bytes(data))
    report = validate_file(path)
    hits = [v for v in report.violations if v.h5_path == "/trials/press/frames/images"]
    assert hits and "cannot be read" in hits[0].message and "\n" not in hits[0].message


@pytest.mark.slow
def test_validate_never_raises_on_flipped_bytes(good, tmp_path):
    """Byte flips anywhere (compressed chunks, B-tree and heap metadata) give a report,
    with every violation on one line; the reader gives one InputError line or succeeds."""
    data = good.read_bytes()
    rng = np.random.default_rng(7)
    bad = tmp_path / "flipped.h5"
    for _ in range(40):
        b = bytearray(data)
        off = int(rng.integers(0, len(b) - 16))
        for j in range(int(rng.integers(1, 16))):
            b[off + j] ^= 0xFF
        bad.write_bytes(bytes(b))
        report = validate_file(bad)
        assert all("\n" not in str(v) for v in report.violations)
        try:
            with TactileFile(bad) as f:
                for trial in f.trials():
                    _ = trial.labels, trial.annotations, trial.duration_s
                    if trial.has_events:
                        list(trial.events.blocks())
                        trial.events.all()
                    for s in trial.signal_names:
                        trial.signal(s)
        except InputError as exc:
            assert "\n" not in str(exc)


@pytest.mark.parametrize(
    ("edit", "where", "words"),
    [
        (lambda h: h["sensors/dvs"].attrs.__setitem__("width_px", "wide"), "/sensors/dvs",
         "'width_px' is 'wide'; expected a whole number of pixels"),
        (lambda h: h["sensors/dvs"].attrs.__setitem__("width_px", 0), "/sensors/dvs",
         "'width_px' is 0"),
        (lambda h: h["sensors/acc"].attrs.__setitem__("sample_rate_hz", "fast"), "/sensors/acc",
         "'sample_rate_hz' is 'fast'; expected a finite number"),
        (lambda h: h["sensors/acc"].attrs.__setitem__("sample_rate_hz", np.inf), "/sensors/acc",
         "expected a finite number"),
        (_replace("sensors/acc/channel_units", np.array([1, 2])), "/sensors/acc/channel_units",
         "expected a 1-D list of strings"),
        (lambda h: h["sensors/acc"].attrs.__setitem__("sample_rate_hz", 1e300), "/sensors/acc",
         "'sample_rate_hz' is 1e+300; expected at most 1e+09"),
        (lambda h: h["sensors/acc"].attrs.__setitem__("sample_rate_hz", 0.0), "/sensors/acc",
         "a sampled sensor needs a rate > 0"),
        (lambda h: h["sensors/acc"].attrs.__setitem__("kind", "toaster"), "/sensors/acc",
         "'kind' is 'toaster'; expected one of event_camera"),
        (lambda h: h["sensors/dvs"].attrs.__delitem__("width_px"), "/sensors/dvs",
         "'width_px' is missing; a sensor of kind event_camera needs"),
    ],
)
def test_reader_refuses_retyped_sensor_attributes(good, tmp_path, edit, where, words):
    bad = _copy(good, tmp_path, edit)
    name = where.rsplit("/", 1)[1] if where.count("/") == 2 else where.split("/")[2]
    with TactileFile(bad) as f, pytest.raises(InputError) as err:
        f.sensor(name)
    msg = str(err.value)
    assert msg.startswith(f"{bad}, {where}: ") and words in msg and "\n" not in msg
    assert "`tactile validate FILE`" in msg
    with pytest.raises(InputError, match=words.split(";")[0][:20]):  # info checks them too
        summarize(bad)


@pytest.mark.parametrize(
    ("edit", "where", "words"),
    [
        (lambda h: h["trials/ev/events/x"].__setitem__(11, 65535), "/trials/ev/events/x",
         "event 11: x = 65535 is outside the sensor (width_px 64"),
        (lambda h: h["trials/ev/events/p"].__setitem__(2, 0), "/trials/ev/events/p",
         "event 2: polarity 0 is not -1 or +1"),
        (lambda h: h["trials/ev/events/t"].__setitem__(20, 0), "/trials/ev/events/t",
         "event 20: time 0 us comes after a later time"),
    ],
)
def test_reader_refuses_bad_events_in_windows_and_blocks(good, tmp_path, edit, where, words):
    bad = _copy(good, tmp_path, edit)
    with TactileFile(bad) as f:
        ev = f.trial("ev").events
        with pytest.raises(InputError, match=re.escape(words)) as err:
            ev.all()
        assert str(err.value).startswith(f"{bad}, {where}: ")
        with pytest.raises(InputError, match=re.escape(words)):
            for _ in ev.blocks(block=7):  # the unsorted pair may straddle two blocks
                pass


@pytest.mark.parametrize(
    ("edit", "where", "words"),
    [
        (lambda h: h["trials/sig/signals/acc/data"].__setitem__((5, 1), np.inf),
         "/trials/sig/signals/acc/data", "row 5, column 1 is inf; samples must be finite"),
        (lambda h: h["trials/sig/signals/acc/t_s"].__setitem__(7, 0.06),
         "/trials/sig/signals/acc/t_s", "time 0.06 s at row 7 does not come after 0.06 s"),
        (_replace("trials/sig/signals/acc/data", np.full((60, 2), "x", dtype=object)),
         "/trials/sig/signals/acc/data", "expected numbers"),
        (lambda h: h["trials/sig/signals/acc/sample_labels/motion"].__setitem__(4, 3),
         "/trials/sig/signals/acc/sample_labels/motion", "sample 4 has class code 3"),
        (lambda h: h["trials/ev/annotations/end_s"].__setitem__(1, 0.05),
         "/trials/ev/annotations", "must not end before it starts"),
    ],
)
def test_reader_refuses_bad_samples(good, tmp_path, edit, where, words):
    bad = _copy(good, tmp_path, edit)
    with TactileFile(bad) as f, pytest.raises(InputError) as err:
        trial = f.trial("ev" if "annotations" in where else "sig")
        _ = trial.annotations if "annotations" in where else trial.signal("acc")
    msg = str(err.value)
    assert msg.startswith(f"{bad}, {where}: ") and words in msg and "\n" not in msg


def test_fits_table_of_unequal_columns_is_refused(good, tmp_path):
    bad = _copy(good, tmp_path, _replace("derived/fits/fos_press/alpha", np.ones(3)))
    with TactileFile(bad) as f, pytest.raises(InputError, match="columns of unequal length"):
        f.derived("fits", "fos_press")


@pytest.mark.parametrize("command", [["info"], ["accumulate"], ["plot"]])
def test_commands_give_one_line_for_corrupt_content(good, tmp_path, command):
    def edit(h5):
        h5["trials/ev/events/x"][11] = 65535
        h5["sensors/acc"].attrs["sample_rate_hz"] = "fast"

    bad = _copy(good, tmp_path, edit)
    before = bad.read_bytes()
    args = [*command, str(bad)]
    if command == ["plot"]:
        args += ["--out", str(tmp_path / "plots")]
    result = runner.invoke(app, args)
    assert result.exit_code == 2, result.output
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith(f"tactile: error: {bad}, /"), lines
    assert "Traceback" not in result.output
    assert bad.read_bytes() == before
    assert not (tmp_path / "plots").exists()


def test_symlink_loop_is_not_file_not_found(tmp_path):
    loop = tmp_path / "loop.h5"
    loop.symlink_to(loop)
    result = runner.invoke(app, ["info", str(loop)])
    assert result.exit_code == 2
    assert "does not resolve (broken, or a loop)" in result.stderr
    report = validate_file(loop)
    assert not report.readable and "does not resolve" in report.violations[0].message


def test_writer_refuses_content_validate_rejects_naming_the_source(tmp_path):
    """What validate rejects is never written: NaN samples or an infinite rate stop the
    commit with one line naming the trial's source file, and nothing is left behind."""
    src = tmp_path / "rec_01.csv"
    src.write_text("t,a\n0,1\n")
    out = tmp_path / "out.h5"
    for rate, value in ((100.0, np.nan), (float("inf"), 1.0)):
        with pytest.raises(SchemaError) as err, StoreWriter(out, command="test") as w:
            acc = w.add_sensor("acc", kind="accelerometer", sample_rate_hz=rate,
                               channel_names=["a"], channel_units="g")
            tr = w.trial("rec_01", sources=[w.add_source(src)])
            tr.write_signal("acc", sensor=acc, data=np.array([[1.0], [value]]),
                            t_s=np.array([0.0, 0.01]))
            w.commit()
        msg = str(err.value)
        assert "\n" not in msg and msg.endswith("nothing was written")
        assert ("non-finite" if rate == 100.0 else "'sample_rate_hz'): value inf") in msg
        if rate == 100.0:
            assert f"(from {src})" in msg
        assert sorted(p.name for p in tmp_path.iterdir()) == ["rec_01.csv"]


@pytest.mark.parametrize("group", ["trials", "sensors"])
def test_file_without_trials_or_sensors_is_refused_not_empty(good, tmp_path, group):
    bad = _copy(good, tmp_path, lambda h: h.__delitem__(group))
    with pytest.raises(InputError, match=rf"{bad}, /{group}: required group is missing"):
        TactileFile(bad)
    result = runner.invoke(app, ["accumulate", str(bad)])
    assert result.exit_code == 2 and len(result.stderr.strip().splitlines()) == 1
