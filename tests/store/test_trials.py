"""The one trial reader (tactile_cli.store.trials): round trips, time origins, lazy frames,
and one-line errors for damaged files."""

from __future__ import annotations

import h5py
import numpy as np
import pytest

from tactile_cli.errors import InputError
from tactile_cli.store import StoreWriter, TactileFile, read_events_window, read_signal

W, H = 64, 48
#: the trial's time 0 lies 37.25 ms before the first event (so the index origin, the first
#: event, and the trial origin differ by a fraction of a millisecond too)
T_FIRST_US = 1_600_000_000_037_250
T_ORIGIN_US = 1_600_000_000_000_000


def _events(n: int, seed: int) -> dict[str, np.ndarray]:
    rng = np.random.default_rng(seed)
    t = np.sort(rng.integers(0, 400_000, n)).astype(np.int64) + T_FIRST_US
    t[0] = T_FIRST_US
    return {"x": rng.integers(0, W, n).astype(np.uint16),
            "y": rng.integers(0, H, n).astype(np.uint16),
            "t": t, "p": rng.choice(np.array([-1, 1], dtype=np.int8), n)}


def _file(path, *, n_events: int = 20_000, seed: int = 0):
    """A file with one event trial (origin before the first event), one sampled trial
    and one frames trial; returns the truth."""
    rng = np.random.default_rng(seed)
    ev = _events(n_events, seed)
    signal = rng.normal(size=(120, 3)).astype(np.float32)
    motion = (np.arange(120) // 40).astype(np.int8)
    ref = rng.integers(0, 255, (H, W, 3), dtype=np.uint8)
    images = rng.integers(0, 255, (5, H, W, 3), dtype=np.uint8)
    with StoreWriter(path, command="test") as w:
        dvs = w.add_sensor("dvs", kind="event_camera", sample_rate_hz=0, width_px=W,
                           height_px=H, pixel_pitch_m=9e-6, focal_length_m=3.6e-3)
        tr = w.trial("ev", labels={"object": "box", "force_level": 3}, split="test",
                     annotations=[(0.05, 0.2, "press"), (0.2, 0.35, "slip")])
        app = tr.events(dvs)
        for i in range(0, n_events, 4096):
            app.append(*(ev[k][i:i + 4096] for k in "xytp"))
        app.close(t_origin_us=T_ORIGIN_US)
        acc = w.add_sensor("acc", kind="accelerometer", sample_rate_hz=8000,
                           channel_names=["ax", "ay", "az"], channel_units=["g", "g", "m/s2"])
        w.trial("sig", labels={"texture": "felt"}).write_signal(
            "acc", sensor=acc, data=signal, t_s=np.arange(120) / 8000,
            sample_labels={"motion": (motion, ["still", "slide", "slip"])})
        cam = w.add_sensor("digit", kind="visuotactile", sample_rate_hz=30, width_px=W,
                           height_px=H)
        w.trial("img").write_frames(sensor=cam, images=images, t_s=np.arange(5) / 30, reference=ref)
        w.commit()
    return {"events": ev, "signal": signal, "motion": motion, "ref": ref, "images": images}


@pytest.fixture(scope="module")
def stored(tmp_path_factory):
    path = tmp_path_factory.mktemp("trials") / "a.h5"
    return path, _file(path)


def test_trials_labels_split_annotations_round_trip(stored):
    path, _ = stored
    with TactileFile(path) as f:
        assert f.trial_names == ["ev", "sig", "img"]
        ev = f.trial("ev")
        assert ev.labels == {"object": "box", "force_level": 3}
        assert ev.split == "test"
        assert [tuple(a) for a in ev.annotations] == [(0.05, 0.2, "press"), (0.2, 0.35, "slip")]
        assert ev.annotation(" SLIP ") == (0.2, 0.35, "slip")
        assert ev.annotation("release") is None
        assert f.trial("sig").labels == {"texture": "felt"}
        assert f.trial("sig").annotations == []
        assert f.sources == []
        assert f.attrs["command"] == "test"


def test_event_window_is_in_trial_time_from_t_origin(stored):
    path, truth = stored
    t = truth["events"]["t"]
    with TactileFile(path) as f:
        events = f.trial("ev").events
        assert events.origin_us == T_ORIGIN_US
        assert events.n_events == t.shape[0]
        assert events.sensor.width_px == W and events.sensor.optics["pixel_pitch_m"] == 9e-6
        rng = np.random.default_rng(1)
        for t0_s in [0.0, 0.03725, 0.0372501, 0.1, *rng.uniform(0, 0.45, 30).tolist()]:
            t1_s = t0_s + float(rng.uniform(0, 0.05))
            got = events.window(t0_s, t1_s)
            lo, hi = T_ORIGIN_US + round(t0_s * 1e6), T_ORIGIN_US + round(t1_s * 1e6)
            mask = (t >= lo) & (t < hi)
            np.testing.assert_array_equal(got.t_us, t[mask])
            np.testing.assert_array_equal(got.x, truth["events"]["x"][mask])
            np.testing.assert_array_equal(got.p, truth["events"]["p"][mask])
        blocks = list(events.blocks(block=7000))
        assert [b[0].shape[0] for b in blocks] == [7000, 7000, 6000]
        np.testing.assert_array_equal(np.concatenate([b[0] for b in blocks]), t)


def test_the_event_readers_share_one_time_origin(stored):
    """One window read three ways: the trial reader, the store's millisecond window and
    the event counts of the accumulation (bins from the same origin)."""
    from tactile_cli.events.accumulate import bin_events, trial_counts

    path, truth = stored
    t, p = truth["events"]["t"], truth["events"]["p"]
    with TactileFile(path) as f:
        trial = f.trial("ev")
        by_trial = trial.events.window(0.1, 0.2)
        from_events = trial_counts(trial, bin_s=0.02)
    by_ms = read_events_window(path, "ev", 100, 200)
    np.testing.assert_array_equal(by_trial.t_us, by_ms["t"])
    np.testing.assert_array_equal(by_trial.x, by_ms["x"])
    # bins 5..9 of 20 ms from the origin hold exactly the 100-200 ms window's events
    counts = bin_events(by_trial.t_us, by_trial.p, bin_s=0.02, start_us=T_ORIGIN_US + 100_000,
                        end_us=T_ORIGIN_US + 200_000)
    np.testing.assert_array_equal(counts.positive, from_events.positive[5:10])
    np.testing.assert_array_equal(counts.negative, from_events.negative[5:10])
    inside = (t >= T_ORIGIN_US + 100_000) & (t < T_ORIGIN_US + 200_000)
    assert counts.n_events == inside.sum() and (p[inside] > 0).sum() == counts.positive.sum()


def test_signal_with_rate_channels_units_and_labels(stored):
    path, truth = stored
    with TactileFile(path) as f:
        trial = f.trial("sig")
        assert trial.signal_names == ["acc"] and not trial.has_events
        s = trial.signal("acc")
        np.testing.assert_array_equal(s.data, truth["signal"])
        assert s.data.dtype == np.float32 and s.t_s.dtype == np.float64
        assert s.channel_names == ("ax", "ay", "az")
        assert s.channel_units == ("g", "g", "m/s2")
        assert s.sample_rate_hz == pytest.approx(8000) and s.sample_period_s == 1 / 8000
        np.testing.assert_array_equal(s.sample_labels["motion"].values, truth["motion"])
        assert s.sample_labels["motion"].classes == ("still", "slide", "slip")
        picked = trial.signal("acc", channels=["az", "ax"])
        np.testing.assert_array_equal(picked.data, truth["signal"][:, [2, 0]])
        assert picked.channel_names == ("az", "ax") and picked.channel_units == ("m/s2", "g")
        part = trial.signal("acc", rows=slice(10, 20))
        np.testing.assert_array_equal(part.data, truth["signal"][10:20])
        with pytest.raises(InputError, match=r"channel 'bz' is not a channel of sensor 'acc' "
                                             r"\(channels: ax, ay, az\)"):
            trial.signal("acc", channels=["bz"])
        with pytest.raises(InputError, match=r"/trials/sig: trial has no stream 'gyro' "
                                             r"\(streams: acc\)"):
            trial.signal("gyro")
    legacy = read_signal(path, "sig", "acc")
    assert legacy["sensor"] == "acc"
    np.testing.assert_array_equal(legacy["sample_labels"]["motion"], truth["motion"])


def test_frames_are_read_one_at_a_time(stored):
    path, truth = stored
    with TactileFile(path) as f:
        frames = f.trial("img").frames()
        assert len(frames) == 5 and frames.shape == (H, W, 3)
        np.testing.assert_array_equal(frames.reference, truth["ref"])
        seen = list(frames)
        assert [round(t * 30) for t, _ in seen] == [0, 1, 2, 3, 4]
        for (_, image), want in zip(seen, truth["images"], strict=True):
            np.testing.assert_array_equal(image, want)
        np.testing.assert_array_equal(frames[-1], truth["images"][-1])
        with pytest.raises(InputError, match="trial has no frames"):
            f.trial("sig").frames()


def test_unknown_trial_lists_the_file_trials(stored):
    path, _ = stored
    with TactileFile(path) as f, pytest.raises(
            InputError, match=r"no trial 'nope'; the file has 3 trial\(s\): ev, sig, img"):
        f.trial("nope")


def test_missing_and_not_hdf5_files_are_one_line_errors(tmp_path):
    with pytest.raises(InputError, match="file not found"):
        TactileFile(tmp_path / "missing.h5")
    bad = tmp_path / "bad.h5"
    bad.write_bytes(b"not hdf5 at all")
    with pytest.raises(InputError) as err:
        TactileFile(bad)
    assert "\n" not in str(err.value) and str(bad) in str(err.value)


def test_deleted_dataset_is_reported_with_its_hdf5_path(tmp_path):
    path = tmp_path / "d.h5"
    _file(path, n_events=3000)
    with h5py.File(path, "a") as h5:
        del h5["trials/ev/events/t"]
        del h5["trials/sig/signals/acc/t_s"]
    with TactileFile(path) as f:
        with pytest.raises(InputError, match=r"d.h5, /trials/ev/events: missing") as err:
            f.trial("ev").events  # noqa: B018 (the property reads the group)
        assert "\n" not in str(err.value)
        with pytest.raises(InputError, match=r"/trials/sig/signals/acc: missing"):
            f.trial("sig").signal("acc")


def test_corrupt_chunk_is_one_line_naming_the_dataset(tmp_path):
    path = tmp_path / "c.h5"
    _file(path, n_events=50_000)
    with h5py.File(path, "r") as h5:
        ds = h5["trials/ev/events/x"]
        offset = ds.id.get_chunk_info(0).byte_offset
    raw = bytearray(path.read_bytes())
    raw[offset + 10:offset + 60] = bytes(50)  # zero a run of the gzip stream
    path.write_bytes(bytes(raw))
    with TactileFile(path) as f, pytest.raises(InputError) as err:
        f.trial("ev").events.all()
    message = str(err.value)
    assert "/trials/ev/events" in message and "\n" not in message


def test_the_library_outside_store_does_not_import_h5py():
    """The rule of ARCHITECTURE.md: reading and writing HDF5 go through store/."""
    from pathlib import Path

    import tactile_cli

    root = Path(tactile_cli.__file__).parent
    offenders = [str(p.relative_to(root)) for p in root.rglob("*.py")
                 if "store" not in p.relative_to(root).parts
                 and ("import h5py" in p.read_text() or "h5py." in p.read_text())]
    assert offenders == []
