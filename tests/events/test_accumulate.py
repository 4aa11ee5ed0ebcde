"""Event binning, moving average, trial counts from HDF5 and per-bin labels."""

from __future__ import annotations

import h5py
import numpy as np
import pytest

from tactile_cli.errors import InputError
from tactile_cli.events import (
    CHANNELS,
    EventCounts,
    bin_events,
    centred_moving_average,
    counts_to_labels,
    trial_counts,
)
from tactile_cli.events import accumulate as acc_module
from tactile_cli.store import StoreWriter, TactileFile

from ..factories.event_counts import events_from_counts


def file_counts(path, trial, **kwargs):
    """:func:`trial_counts` of trial ``trial`` of the file ``path``."""
    with TactileFile(path) as tf:
        return trial_counts(tf.trial(trial), **kwargs)


def naive_bins(t_us, p, bin_us, start_us, n_bins):
    pos = [0] * n_bins
    neg = [0] * n_bins
    outside = 0
    for t, q in zip(t_us.tolist(), p.tolist(), strict=True):
        k = (t - start_us) // bin_us if t >= start_us else -1
        if 0 <= k < n_bins and t < start_us + n_bins * bin_us:
            (pos if q > 0 else neg)[k] += 1
        else:
            outside += 1
    return np.array(pos), np.array(neg), outside


def test_bin_events_matches_a_naive_loop_with_edges_and_end():
    rng = np.random.default_rng(0)
    start, bin_us = 1_000_000, 20_000
    t = rng.integers(start - 50_000, start + 1_000_000, 5000)
    # events exactly on bin edges, on the origin and just before it
    t[:40] = start + bin_us * rng.integers(0, 40, 40)
    t[40:45] = [start, start - 1, start + bin_us - 1, start + bin_us, start + 930_000]
    p = rng.choice(np.array([-1, 1], np.int8), t.size)
    end = start + 930_000  # 46.5 bins: the 47th is partial and stops at end
    c = bin_events(t, p, bin_s=0.02, start_us=start, end_us=end)
    assert c.n_bins == 47
    pos, neg, outside = naive_bins(t, p, bin_us, start, 47)
    inside_end = t < end  # the partial last bin counts only events before end_us
    pos2, neg2, _ = naive_bins(t[inside_end], p[inside_end], bin_us, start, 47)
    np.testing.assert_array_equal(c.positive, pos2)
    np.testing.assert_array_equal(c.negative, neg2)
    assert c.n_outside == t.size - int(pos2.sum() + neg2.sum())
    assert (pos >= pos2).all() and outside <= c.n_outside
    np.testing.assert_array_equal(c.net, c.positive - c.negative)
    np.testing.assert_allclose(c.t_s, (np.arange(47) + 0.5) * 0.02)
    assert c.positive.dtype == np.int64 and c.start_us == start and c.bin_s == 0.02
    assert c.end_s == pytest.approx(0.94)


def test_bin_events_without_end_covers_the_last_event():
    rng = np.random.default_rng(1)
    t = np.sort(rng.integers(0, 333_333, 2000))
    t[-1] = 340_000  # exactly on a bin edge: opens bin 17
    p = rng.choice(np.array([-1, 1], np.int8), t.size)
    c = bin_events(t, p, bin_s=0.02)
    assert c.n_bins == 18 and c.n_outside == 0
    pos, neg, _ = naive_bins(t, p, 20_000, 0, 18)
    np.testing.assert_array_equal(c.positive, pos)
    np.testing.assert_array_equal(c.negative, neg)
    assert c.n_events == t.size
    empty = bin_events(np.zeros(0, np.int64), np.zeros(0, np.int8))
    assert empty.n_bins == 0 and empty.n_events == 0


def test_bin_events_other_bin_widths_and_stack():
    rng = np.random.default_rng(2)
    t = rng.integers(0, 100_000, 3000)
    p = rng.choice(np.array([-1, 1], np.int8), t.size)
    for bin_s, bin_us in ((0.001, 1000), (0.0333, 33_300), (0.05, 50_000)):
        c = bin_events(t, p, bin_s=bin_s, end_us=100_000)
        n = -(-100_000 // bin_us)
        pos, neg, _ = naive_bins(t, p, bin_us, 0, n)
        np.testing.assert_array_equal(c.positive, pos)
        np.testing.assert_array_equal(c.negative, neg)
    stacked = c.stack()
    assert stacked.dtype == np.float32 and stacked.shape == (c.n_bins, 3)
    assert EventCounts.CHANNELS == CHANNELS == ("positive", "negative", "net")
    np.testing.assert_array_equal(stacked[:, 2], c.net)


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"p": np.array([1, 0, -1], np.int8)}, "`p` holds 0; polarities must be -1 or +1"),
        ({"t_us": np.array([0.0, 1.0, 2.0])}, "`t_us` must hold integer microseconds"),
        ({"bin_s": 0.0000015}, "`bin_s` (=1.5e-06) must be a whole number of microseconds"),
        ({"bin_s": -0.02}, "`bin_s` (=-0.02) must be positive and at most a day (86400 s)"),
        ({"end_us": 0, "start_us": 5}, "`end_us` (=0) must be later than `start_us` (=5)"),
    ],
)
def test_bin_events_rejects_bad_arguments(kwargs, message):
    args = {"t_us": np.array([0, 1, 2]), "p": np.array([1, -1, 1], np.int8)}
    args.update(kwargs)
    t_us, p = args.pop("t_us"), args.pop("p")
    with pytest.raises(ValueError) as err:
        bin_events(t_us, p, **args)
    assert message in str(err.value)


def naive_moving_average(x, w):
    h = (w - 1) // 2
    out = np.empty(len(x))
    for i in range(len(x)):
        k = min(h, i, len(x) - 1 - i)
        out[i] = np.mean(x[i - k : i + k + 1], axis=0)
    return out


@pytest.mark.parametrize("window", [1, 3, 5, 7, 21])
@pytest.mark.parametrize("n", [1, 2, 6, 50])
def test_centred_moving_average_matches_a_naive_loop(window, n):
    x = np.random.default_rng(n).normal(size=n) * 100
    np.testing.assert_allclose(centred_moving_average(x, window), naive_moving_average(x, window),
                               rtol=1e-12, atol=1e-9)


def test_centred_moving_average_is_unbiased_and_works_per_column():
    line = np.arange(30, dtype=float) * 3 + 7  # a straight line is its own centred average
    np.testing.assert_allclose(centred_moving_average(line, 5), line)
    two = np.stack([line, -2 * line], axis=1)
    np.testing.assert_allclose(centred_moving_average(two, 7), two)
    assert centred_moving_average(np.zeros(0), 5).shape == (0,)
    with pytest.raises(ValueError, match="must be an odd whole number >= 1"):
        centred_moving_average(line, 4)
    with pytest.raises(ValueError, match="must be an odd whole number >= 1"):
        centred_moving_average(line, 0)


def _write_event_file(path, trials, *, origin=None):
    """trials: name -> events dict; origin: t_origin_us for every trial (None: writer's)."""
    with StoreWriter(path, command="test") as w:
        w.add_sensor("cam", kind="event_camera", sample_rate_hz=0, width_px=64, height_px=48)
        for name, ev in trials.items():
            tw = w.trial(name, labels={"force_level": 3, "force_grade": "small"},
                         annotations=[(0.0, 0.5, "approach"), (0.5, 1.0, "Press "),
                                      (1.0, 1.5, "slip"), (1.5, 9.0, "release")])
            app = tw.events("cam")
            for a in range(0, ev["t"].size, 7000):  # several appends
                sl = slice(a, a + 7000)
                app.append(ev["x"][sl], ev["y"][sl], ev["t"][sl], ev["p"][sl])
            app.close(t_origin_us=origin)
        w.add_sensor("acc", kind="accelerometer", sample_rate_hz=10, channel_names=["a"],
                     channel_units="g")
        w.trial("no_events").write_signal("acc", sensor="acc", data=np.zeros((5, 1)),
                                          t_s=np.arange(5) / 10)
        w.commit()
    return path


def test_trial_counts_equals_bin_events_read_in_blocks(tmp_path, monkeypatch):
    rng = np.random.default_rng(3)
    pos = rng.poisson(300, 100)
    neg = rng.poisson(120, 100)
    start = 1_700_000_000_000_000  # an epoch clock: the trial starts at its first event
    ev = events_from_counts(pos, neg, rng, start_us=start + 4321)
    f = _write_event_file(tmp_path / "e.h5", {"rec": ev}, origin=start)
    monkeypatch.setattr(acc_module, "READ_BLOCK", 4096)  # many blocks
    c = file_counts(f, "rec")
    ref = bin_events(ev["t"], ev["p"], start_us=start)
    np.testing.assert_array_equal(c.positive, ref.positive)
    np.testing.assert_array_equal(c.negative, ref.negative)
    assert c.start_us == start and c.n_outside == 0 and c.n_events == ev["t"].size
    # the events were placed 4.3 ms late: the last ones open a 101st bin
    assert c.n_bins == ref.n_bins == 101 and c.end_s == pytest.approx(2.02)
    with h5py.File(f) as h5:
        assert h5["trials/rec/events"].attrs["t_origin_us"] == start


def test_trial_counts_origin_defaults_and_skips_events_before_it(tmp_path):
    rng = np.random.default_rng(4)
    pos, neg = rng.poisson(50, 40), rng.poisson(20, 40)
    ev = events_from_counts(pos, neg, rng, start_us=0)
    f = _write_event_file(tmp_path / "e.h5", {"rec": ev})  # times from 0: origin 0
    c = file_counts(f, "rec")
    np.testing.assert_array_equal(c.positive, pos)
    np.testing.assert_array_equal(c.negative, neg)
    # an origin after some events: those are counted as outside, the rest re-binned
    with h5py.File(f, "r+") as h5:
        h5["trials/rec/events"].attrs["t_origin_us"] = 30_500
        h5["trials/rec"].attrs["duration_s"] = (int(ev["t"][-1]) - 30_500) * 1e-6
    late = file_counts(f, "rec")
    ref = bin_events(ev["t"], ev["p"], start_us=30_500, end_us=int(ev["t"][-1]) + 1)
    np.testing.assert_array_equal(late.positive, ref.positive)
    assert late.n_outside == int((ev["t"] < 30_500).sum()) > 0
    # files from before t_origin_us existed: the first event is time 0
    with h5py.File(f, "r+") as h5:
        del h5["trials/rec/events"].attrs["t_origin_us"]
        first = int(h5["trials/rec/events"].attrs["ms_index_origin_us"])
    old = file_counts(f, "rec")
    assert old.start_us == first


def test_trial_counts_errors(tmp_path):
    rng = np.random.default_rng(5)
    ev = events_from_counts(rng.poisson(5, 10), rng.poisson(5, 10), rng)
    f = _write_event_file(tmp_path / "e.h5", {"rec": ev})
    with pytest.raises(InputError) as err:
        file_counts(f, "nope")
    assert str(err.value) == f"{f}: no trial 'nope'; the file has 2 trial(s): rec, no_events"
    with pytest.raises(InputError) as err:
        file_counts(f, "no_events")
    assert str(err.value) == (f"{f}, /trials/no_events: trial has no events (event counts "
                              "need an event-camera recording)")
    text = tmp_path / "x.h5"
    text.write_text("not hdf5")
    with pytest.raises(InputError, match="not a readable HDF5 file"):
        file_counts(text, "rec")


def test_counts_to_labels_by_bin_centre():
    t = (np.arange(10) + 0.5) * 0.1
    ann = [(0.0, 0.3, "approach"), (0.3, 0.56, " PRESS"), (0.56, 0.7, "slip"),
           (0.7, 0.9, "release"), (0.2, 0.4, "contact")]  # "contact" is no action
    labels = counts_to_labels(t, ann)
    np.testing.assert_array_equal(labels, [0, 0, 0, 1, 1, 1, 2, 3, 3, -1])
    assert labels.dtype == np.int8
    assert (counts_to_labels(t, []) == -1).all()
