"""Issue 20, reader/validator side: events shifted off the trial's clock, annotations past
the trial's end, frames of the wrong type and multi-line value reprs are refused by the
one reader (one InputError line naming the HDF5 path) and reported by validate."""

from __future__ import annotations

import shutil

import h5py
import numpy as np
import pytest

from tactile_cli.errors import InputError, SchemaError
from tactile_cli.store import StoreWriter, TactileFile, validate_file

W, H = 32, 24


def _write(path):
    rng = np.random.default_rng(1)
    n = 2000
    t = np.sort(rng.integers(0, 300_000, n)).astype(np.int64)
    with StoreWriter(path, command="test") as w:
        dvs = w.add_sensor("dvs", kind="event_camera", sample_rate_hz=0, width_px=W,
                           height_px=H)
        tr = w.trial("ev", duration_s=0.3, annotations=[(0.0, 0.1, "press"),
                                                       (0.1, 0.3, "slip")])
        ev = tr.events(dvs)
        ev.append(rng.integers(0, W, n), rng.integers(0, H, n), t,
                  rng.choice(np.array([-1, 1]), n))
        ev.close()
        cam = w.add_sensor("cam", kind="visuotactile", sample_rate_hz=30, width_px=W,
                           height_px=H)
        tv = w.trial("vis", duration_s=0.2)
        tv.write_frames(sensor=cam, images=np.zeros((4, H, W, 3), np.uint8),
                        t_s=np.arange(4) / 30, reference=np.zeros((H, W, 3), np.uint8))
        w.commit()
    return path


@pytest.fixture(scope="module")
def good(tmp_path_factory):
    path = _write(tmp_path_factory.mktemp("damage") / "good.h5")
    assert validate_file(path).ok, validate_file(path).violations
    return path


def _copy(good, tmp_path, edit):
    bad = tmp_path / "bad.h5"
    shutil.copy(good, bad)
    with h5py.File(bad, "a") as h5:
        edit(h5)
    return bad


def _replace(path, make):
    def edit(h5):
        data = make(h5[path][()])
        del h5[path]
        h5[path] = data
    return edit


def _one_line(exc: BaseException) -> str:
    text = str(exc)
    assert "\n" not in text
    return text


@pytest.mark.parametrize("shift", [-10**15, 10**15])
def test_events_shifted_off_the_clock_are_refused_on_open(good, tmp_path, shift):
    bad = _copy(good, tmp_path, _replace("trials/ev/events/t", lambda t: t + shift))
    before = bad.read_bytes()
    with TactileFile(bad) as f, pytest.raises(InputError) as exc:
        f.trial("ev").events  # noqa: B018 (opening is the check)
    text = _one_line(exc.value)
    assert "/trials/ev/events/t" in text and str(bad) in text and "millisecond index" in text
    report = validate_file(bad)
    assert not report.ok and any(v.h5_path == "/trials/ev/events/ms_to_idx"
                                 for v in report.violations), report.violations
    assert bad.read_bytes() == before


def test_annotations_past_the_trial_end_are_refused(good, tmp_path):
    def edit(h5):
        h5["trials/ev/annotations/start_s"][...] += 1e6
        h5["trials/ev/annotations/end_s"][...] += 1e6
    bad = _copy(good, tmp_path, edit)
    with TactileFile(bad) as f, pytest.raises(InputError) as exc:
        f.trial("ev").annotations  # noqa: B018
    text = _one_line(exc.value)
    assert "/trials/ev/annotations" in text and "after the trial's end" in text
    report = validate_file(bad)
    hits = [v for v in report.violations if v.h5_path == "/trials/ev/annotations/start_s"]
    assert hits and "after the trial's end" in hits[0].message, report.violations


def test_annotations_a_little_past_the_end_are_kept(good, tmp_path):
    def edit(h5):  # hand-made annotations may outlast a short recording by a minute
        h5["trials/ev/annotations/start_s"][1] = 30.0
        h5["trials/ev/annotations/end_s"][1] = 90.0
    bad = _copy(good, tmp_path, edit)
    assert validate_file(bad).ok
    with TactileFile(bad) as f:
        assert [a.label for a in f.trial("ev").annotations] == ["press", "slip"]


@pytest.mark.parametrize("data", [np.full(4, b"img"), np.zeros((4, H, W, 3), np.float32),
                                  np.zeros((4, H, W), np.uint8)])
def test_frames_of_the_wrong_type_are_refused(good, tmp_path, data):
    bad = _copy(good, tmp_path, _replace("trials/vis/frames/images", lambda _: data))
    with TactileFile(bad) as f, pytest.raises(InputError) as exc:
        f.trial("vis").frames()
    assert "/trials/vis/frames/images" in _one_line(exc.value)
    report = validate_file(bad)
    assert any(v.h5_path == "/trials/vis/frames/images" for v in report.violations), \
        report.violations


def test_array_value_is_reported_on_one_short_line(good, tmp_path):
    bad = _copy(good, tmp_path, lambda h5: h5.require_group("trials/ev/labels").attrs
                .__setitem__("force_level", np.zeros((30, 30))))
    report = validate_file(bad)
    hits = [v for v in report.violations if "force_level" in v.h5_path]
    assert hits and all("\n" not in str(v) and len(v.message) < 160 for v in hits), hits


def test_writer_schema_error_is_one_line(tmp_path):
    out = tmp_path / "out.h5"
    with pytest.raises(SchemaError) as exc, StoreWriter(out, command="test") as w:
        w.trial("a", labels={"force_level": np.zeros((3, 3))})
        w.commit()
    assert "\n" not in str(exc.value) and "force_level" in str(exc.value)
    assert not out.exists() and list(tmp_path.iterdir()) == []


def test_a_reference_frame_of_another_size_is_one_input_error(tmp_path):
    """Found by the damaged-input corpus: a reference frame cut to half its rows reached
    normal-labels, heightmap, slip-signal and monitor as a numpy broadcast traceback."""
    from tests.factories.gel_frames import make_frames_file

    path = tmp_path / "f.h5"
    make_frames_file(path, n_trials=1, n_frames=3, onset_frame=1)
    with h5py.File(path, "r+") as f:
        ref = f["trials/t_00/frames/reference"][()]
        del f["trials/t_00/frames/reference"]
        f["trials/t_00/frames/reference"] = ref[: ref.shape[0] // 2]
    with TactileFile(path) as tf, pytest.raises(InputError) as err:
        tf.trial("t_00").frames()
    assert "/trials/t_00/frames/reference" in str(err.value)
    assert "\n" not in str(err.value)
