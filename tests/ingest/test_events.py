"""Event-stream ingest: AEDAT4 (real DVXplorer file), CSV and NPY tables, and the appender.

Round trips compare the stored events with the ground truth the sample writers return;
every bad input must raise one InputError naming the file (and line or index) and leave
no output and no temporary file behind.
"""

from __future__ import annotations

import hashlib
import re
import shutil
from pathlib import Path

import h5py
import numpy as np
import pytest
from typer.testing import CliRunner

from tactile_cli.cli import app
from tactile_cli.errors import InputError
from tactile_cli.ingest import events_table, ingest
from tactile_cli.ingest.events_table import EventTableOptions, PolarityConvention, read_csv_blocks
from tactile_cli.samples.events import make_events, write_events_csv, write_events_npy
from tactile_cli.store import StoreWriter, read_events, read_events_window, validate_file
from tactile_cli.store import writer as writer_module
from tactile_cli.store.writer import Compression

from ..conftest import shared_path

runner = CliRunner()
W, H = 64, 48
DVX = ("aedat4", "dvxplorer_sample.aedat4")


def _opts(**kw) -> EventTableOptions:
    return EventTableOptions(**{"width_px": W, "height_px": H, "chunk_events": 1000, **kw})


@pytest.fixture
def small_chunks(monkeypatch):
    """HDF5 chunks of 1000 events, so small files still span several chunks and a partial
    last one."""
    monkeypatch.setattr(writer_module, "EVENT_CHUNK", 1000)


def _assert_nothing_written(folder: Path, out: Path) -> None:
    assert not out.exists()
    assert [p.name for p in folder.iterdir() if ".tmp-" in p.name] == []


def _stored(out: Path, trial: str) -> dict[str, np.ndarray]:
    return read_events(out, trial)


# -- AEDAT4: the real DVXplorer recording ----------------------------------------------------
def test_dvxplorer_aedat4_ingests_every_event(tmp_path):
    src = shared_path(*DVX)
    out = ingest([src], tmp_path / "dvx.h5")
    assert validate_file(out).ok
    ev = _stored(out, "dvxplorer_sample")
    assert len(ev["t"]) == 111_954
    assert (int(ev["t"][0]), int(ev["t"][-1])) == (1605537493718345, 1605537494308262)
    assert abs(float(np.mean(ev["p"] == 1)) - 0.491) <= 0.001
    assert set(np.unique(ev["p"]).tolist()) == {-1, 1}
    assert ev["x"].max() == 319 and ev["y"].max() == 239
    assert (np.diff(ev["t"]) >= 0).all()
    with h5py.File(out) as f:
        sensor = f["sensors/DVXplorer_DXB00010"].attrs
        assert (sensor["kind"], int(sensor["width_px"]), int(sensor["height_px"])) == \
            ("event_camera", 320, 240)
        assert float(sensor["sample_rate_hz"]) == 0.0
        trial = f["trials/dvxplorer_sample"]
        assert list(trial["signals"]) == ["imu"]  # its IMU too (tests/ingest/test_aedat4_streams)
        assert trial["events"].attrs["sensor"] == "DVXplorer_DXB00010"
        assert abs(float(trial.attrs["duration_s"]) - 0.589917) < 1e-9
        digest = hashlib.sha256(src.read_bytes()).hexdigest()
        assert f["provenance/sources/sha256"].asstr()[0] == digest


def test_aedat4_matches_the_decoder_packet_by_packet(tmp_path):
    import aedat

    src = shared_path(*DVX)
    packets = [pk["events"] for pk in aedat.Decoder(src) if "events" in pk]
    raw = np.concatenate(packets)
    out = ingest([src], tmp_path / "dvx.h5", options={"chunk_events": 5000},
                 compression=Compression(1))
    ev = _stored(out, "dvxplorer_sample")
    np.testing.assert_array_equal(ev["t"], raw["t"].astype(np.int64))
    np.testing.assert_array_equal(ev["x"], raw["x"])
    np.testing.assert_array_equal(ev["y"], raw["y"])
    np.testing.assert_array_equal(ev["p"], np.where(raw["p"], 1, -1))


def test_aedat4_two_files_one_camera_and_sensor_override(tmp_path):
    src = shared_path(*DVX)
    a, b = tmp_path / "a.aedat4", tmp_path / "b.aedat4"
    shutil.copy(src, a)
    shutil.copy(src, b)
    out = ingest([a, b], tmp_path / "two.h5", options={"sensor_name": "left cam"})
    with h5py.File(out) as f:
        assert list(f["sensors"]) == ["left_cam", "left_cam_imu"]  # one IMU sensor for both
        assert sorted(f["trials"]) == ["a", "b"]
        assert f["provenance/sources/path"].shape == (2,)


@pytest.mark.parametrize("damage", ["truncated", "junk", "width"])
def test_aedat4_bad_files(tmp_path, damage):
    src = shared_path(*DVX)
    bad = tmp_path / "bad.aedat4"
    options: dict = {}
    if damage == "truncated":
        bad.write_bytes(src.read_bytes()[:500_000])
        message = r"bad\.aedat4: .*AEDAT4.* cut short"
    elif damage == "junk":
        bad.write_bytes(b"not an event file\n" * 10)
        message = r"bad\.aedat4: not a readable AEDAT4 file \(.*magic"
    else:
        shutil.copy(src, bad)
        options = {"width_px": 640}
        message = r"bad\.aedat4: `width_px` 640 disagrees with the file's sensor size 320x240 px"
    out = tmp_path / "out.h5"
    with pytest.raises(InputError, match=message):
        ingest([bad], out, options=options)
    _assert_nothing_written(tmp_path, out)


# -- round trips -----------------------------------------------------------------------------
@pytest.mark.parametrize("polarity", ["pm1", "01"])
@pytest.mark.parametrize("columns", [("t", "x", "y", "p"), ("p", "y", "t", "x")])
def test_csv_round_trip_is_exact(tmp_path, small_chunks, polarity, columns):
    src = tmp_path / "rec.csv"
    truth = write_events_csv(src, 5_500, width=W, height=H, seed=1, polarity=polarity,
                             columns=columns)
    out = ingest([src], tmp_path / "rec.h5", options=_opts())
    assert validate_file(out).ok
    got = _stored(out, "rec")
    for k in "xytp":
        np.testing.assert_array_equal(got[k], truth[k])
    with h5py.File(out) as f:
        g = f["trials/rec/events"]
        assert g["x"].chunks == (1000,) and g["t"].compression == "gzip" and g["t"].shuffle
        assert (g["x"].dtype, g["y"].dtype, g["t"].dtype, g["p"].dtype) == \
            (np.uint16, np.uint16, np.int64, np.int8)


@pytest.mark.parametrize("polarity", ["pm1", "01", "bool"])
def test_npy_round_trip_is_exact(tmp_path, small_chunks, polarity):
    src = tmp_path / "rec.npy"
    truth = write_events_npy(src, 4_321, width=W, height=H, seed=2,
                             polarity="01" if polarity == "bool" else polarity)
    if polarity == "bool":  # fields in another order, p as bool
        table = np.load(src)
        other = np.empty(len(table), dtype=[("p", "?"), ("x", "<i4"), ("y", "<u2"), ("t", "<u8")])
        for k in "xyt":
            other[k] = table[k]
        other["p"] = table["p"] == 1
        np.save(src, other)
    out = ingest([src], tmp_path / "rec.h5", options=_opts(chunk_events=700))
    assert validate_file(out).ok
    got = _stored(out, "rec")
    for k in "xytp":
        np.testing.assert_array_equal(got[k], truth[k])


def test_several_csv_files_are_trials_of_one_sensor(tmp_path):
    a = write_events_csv(tmp_path / "a.csv", 300, width=W, height=H, seed=3)
    b = write_events_csv(tmp_path / "b.csv", 200, width=W, height=H, seed=4, polarity="01")
    out = ingest([tmp_path / "a.csv", tmp_path / "b.csv"], tmp_path / "ab.h5",
                 options=_opts(sensor_name="dvs"))
    with h5py.File(out) as f:
        assert list(f["sensors"]) == ["dvs"] and sorted(f["trials"]) == ["a", "b"]
        # each trial points at its own source (hashed while the file was parsed)
        paths = f["provenance/sources/path"].asstr()[()].tolist()
        for name in ("a", "b"):
            (index,) = f[f"trials/{name}"].attrs["source_index"]
            assert paths[index] == str(tmp_path / f"{name}.csv")
        digest = hashlib.sha256((tmp_path / "b.csv").read_bytes()).hexdigest()
        b_index = paths.index(str(tmp_path / "b.csv"))
        assert f["provenance/sources/sha256"].asstr()[b_index] == digest
    np.testing.assert_array_equal(_stored(out, "a")["t"], a["t"])
    np.testing.assert_array_equal(_stored(out, "b")["p"], b["p"])


def test_csv_blocks_and_trailing_blank_lines(tmp_path):
    src = tmp_path / "rec.csv"
    truth = write_events_csv(src, 20_000, width=W, height=H, seed=5)
    with open(src, "ab") as f:
        f.write(b"\n\n  \n")  # blank lines at the very end are ignored
    blocks = list(read_csv_blocks(src, block_bytes=1 << 16))
    assert len(blocks) > 5
    assert blocks[0][0] == 2
    for (line, cols, _), (next_line, _, _) in zip(blocks, blocks[1:], strict=False):
        assert next_line == line + len(cols["t"])
    np.testing.assert_array_equal(np.concatenate([c["t"] for _, c, _ in blocks]), truth["t"])
    assert sum(n for _, _, n in blocks) <= src.stat().st_size


def test_csv_last_line_without_newline(tmp_path):
    src = tmp_path / "rec.csv"
    src.write_bytes(b"t,x,y,p\n10,1,2,0\n12,3,4,1")
    got = _stored(ingest([src], tmp_path / "o.h5", options=_opts()), "rec")
    assert got["t"].tolist() == [10, 12] and got["p"].tolist() == [-1, 1]


# -- the appender writes standard chunks -----------------------------------------------------
@pytest.mark.parametrize("level", [1, 4, 9])
def test_direct_chunks_equal_hdf5s_own_filters(tmp_path, small_chunks, level):
    ev = make_events(3_456, width=W, height=H, seed=6)
    out = tmp_path / "ours.h5"
    with StoreWriter(out, command="test", compression=Compression(level)) as w:
        w.add_sensor("cam", kind="event_camera", sample_rate_hz=0, width_px=W, height_px=H)
        appender = w.trial("r").events("cam")
        for s in range(0, 3_456, 777):
            appender.append(ev["x"][s:s + 777], ev["y"][s:s + 777], ev["t"][s:s + 777],
                            ev["p"][s:s + 777])
        assert appender.close() == 3_456
        w.commit()
    assert validate_file(out).ok
    with h5py.File(out) as f, h5py.File(tmp_path / "ref.h5", "w") as ref:
        g = f["trials/r/events"]
        for k, dtype in (("x", np.uint16), ("y", np.uint16), ("t", np.int64), ("p", np.int8)):
            np.testing.assert_array_equal(g[k][()], ev[k])
            plain = ref.create_dataset(k, data=ev[k].astype(dtype), chunks=(1000,),
                                       maxshape=(None,), compression="gzip",
                                       compression_opts=level, shuffle=True)
            for start in range(0, 3_456, 1000):
                assert g[k].id.read_direct_chunk((start,)) == \
                    plain.id.read_direct_chunk((start,)), (k, start)


def test_uncompressed_store(tmp_path, small_chunks):
    src = tmp_path / "rec.npy"
    truth = write_events_npy(src, 2_500, width=W, height=H, seed=7)
    out = ingest([src], tmp_path / "raw.h5", options=_opts(), compression=Compression(None))
    with h5py.File(out) as f:
        assert f["trials/rec/events/t"].compression is None
    np.testing.assert_array_equal(_stored(out, "rec")["t"], truth["t"])
    assert validate_file(out).ok


# -- the millisecond index -------------------------------------------------------------------
def test_ms_to_idx_windows_match_a_brute_force_mask(tmp_path, small_chunks):
    src = tmp_path / "sparse.csv"
    # about one event per 0.7 ms: many milliseconds hold none, some several
    truth = write_events_csv(src, 6_000, width=W, height=H, seed=8, mean_dt_us=700)
    out = ingest([src], tmp_path / "s.h5", options=_opts(chunk_events=500))
    t = truth["t"]
    origin = int(t[0])
    with h5py.File(out) as f:
        g = f["trials/sparse/events"]
        idx = g["ms_to_idx"][()]
        assert int(g.attrs["ms_index_origin_us"]) == origin
    edges = origin + 1000 * np.arange(len(idx))
    np.testing.assert_array_equal(idx, np.searchsorted(t, edges, side="left"))
    assert len(idx) == (int(t[-1]) - origin) // 1000 + 1
    rng = np.random.default_rng(0)
    for t0_ms in [0, 1, len(idx) - 3, *rng.integers(0, len(idx), 20).tolist()]:
        t1_ms = t0_ms + int(rng.integers(1, 60))
        window = read_events_window(out, "sparse", t0_ms, t1_ms)
        mask = (t >= origin + 1000 * t0_ms) & (t < origin + 1000 * t1_ms)
        for k in "xytp":
            np.testing.assert_array_equal(window[k], truth[k][mask])


# -- bad inputs ------------------------------------------------------------------------------
def _csv_with(tmp_path: Path, line_no: int, edit) -> Path:
    """An otherwise valid 0/1 CSV whose line ``line_no`` (1 = header) is ``edit(line)``."""
    src = tmp_path / "bad.csv"
    write_events_csv(src, 8_000, width=W, height=H, seed=9, polarity="01")
    lines = src.read_text().splitlines()
    lines[line_no - 1] = edit(lines[line_no - 1])
    src.write_text("\n".join(lines) + "\n")
    return src


def _fields(line: str) -> list[int]:
    return [int(v) for v in line.split(",")]


LATE = 6_500  # a line in the third block (``_opts`` makes 64 KiB blocks: about 2,600 lines)
BAD_CSV = {
    "missing column": (1, lambda s: "t,x,y", r"line 1: missing column 'p'"),
    "extra column": (1, lambda s: "t,x,y,p,q", r"line 1: unexpected column 'q'"),
    "duplicate column": (1, lambda s: "t,x,y,p,x", r"line 1: a column is named twice"),
    "no header": (1, lambda s: "5,1,2,0", r"line 1: missing columns 't', 'x', 'y', 'p'.*header"),
    "short row": (LATE, lambda s: s.rsplit(",", 1)[0], rf"line {LATE}: short line: 3 fields"),
    "extra field": (LATE, lambda s: s + ",9", rf"line {LATE}: extra field: 5 fields"),
    "trailing comma": (LATE, lambda s: s + ",", rf"line {LATE}: extra field: 5 fields"),
    "extra field on the first row": (2, lambda s: s + ",9", r"line 2: extra field"),
    "non-numeric": (LATE, lambda s: ",".join([s.split(",")[0], "a1", *s.split(",")[2:]]),
                    rf"line {LATE}: x = 'a1' is not an integer"),
    "float": (LATE, lambda s: s.replace(",", ".5,", 1),
              rf"line {LATE}: t = '\d+\.5' is not an integer"),
    "empty line": (LATE, lambda s: "", rf"line {LATE}: empty line"),
    "t backwards": (LATE, lambda s: ",".join(map(str, [_fields(s)[0] - 50, *_fields(s)[1:]])),
                    rf"line {LATE}: timestamp \d+ us is earlier than the previous"),
    "x outside": (LATE, lambda s: ",".join(map(str, [_fields(s)[0], W, *_fields(s)[2:]])),
                  rf"line {LATE}: x = {W} is outside the sensor \(width {W} px\)"),
    "y negative": (LATE, lambda s: ",".join(map(str, [*_fields(s)[:2], -1, _fields(s)[3]])),
                   rf"line {LATE}: y = -1 is outside the sensor"),
    "polarity 2": (LATE, lambda s: ",".join(map(str, [*_fields(s)[:3], 2])),
                   rf"line {LATE}: polarity 2 is outside this file's convention 0/1"),
    "mixing 0 and -1": (LATE, lambda s: ",".join(map(str, [*_fields(s)[:3], -1])),
                        rf"line {LATE}: polarity -1 mixes conventions: this file uses 0/1 "
                        r"\(from line \d+\)"),
}


@pytest.mark.parametrize("case", list(BAD_CSV))
def test_bad_csv_names_file_and_line_and_writes_nothing(tmp_path, case):
    line_no, edit, message = BAD_CSV[case]
    src = _csv_with(tmp_path, line_no, edit)
    out = tmp_path / "out.h5"
    with pytest.raises(InputError, match=rf"^{re.escape(str(src))}, {message}") as info:
        ingest([src], out, options=_opts())
    assert "\n" not in str(info.value)
    _assert_nothing_written(tmp_path, out)


def test_absurd_time_span_is_an_error_not_a_huge_index(tmp_path):
    def jump(line: str) -> str:
        t, *rest = _fields(line)
        return ",".join(map(str, [t + 25 * 3600 * 10**6, *rest]))

    src = _csv_with(tmp_path, 8_001, jump)  # the last line: 25 h after the first event
    with pytest.raises(InputError, match=rf"^{re.escape(str(src))}, line 8001: timestamp \d+ us "
                       r"is 25\.0 h after the first event .*are the times in microseconds\?"):
        ingest([src], tmp_path / "o.h5", options=_opts())
    _assert_nothing_written(tmp_path, tmp_path / "o.h5")


def test_late_bad_line_is_past_the_first_blocks(tmp_path):
    """The bad-line cases really exercise line numbers carried across blocks."""
    src = _csv_with(tmp_path, 2, lambda s: s)
    block_bytes = max(events_table._MAX_LINE_BYTES,
                      _opts().chunk_events * events_table._CSV_BYTES_PER_EVENT)
    starts = [line for line, _, _ in read_csv_blocks(src, block_bytes=block_bytes)]
    assert len(starts) >= 3 and starts[2] <= LATE


def test_float_or_nan_columns_are_refused_by_the_appender(tmp_path):
    with StoreWriter(tmp_path / "o.h5", command="test") as w:
        w.add_sensor("cam", kind="event_camera", sample_rate_hz=0, width_px=W, height_px=H)
        appender = w.trial("r").events("cam")
        x = np.array([1.0, 2.5, 3.0])
        with pytest.raises(InputError, match=r"^f\.csv, line 8: x = 2\.5 is not a whole number"):
            appender.append(x, x, np.arange(3), np.ones(3), source="f.csv", first_row=7,
                            row_label="line")
        with pytest.raises(InputError, match=r"line 9: t = nan is not a whole number"):
            appender.append(np.ones(3), np.ones(3), np.array([1.0, 2.0, np.nan]), np.ones(3),
                            source="f.csv", first_row=7, row_label="line")
        appender.append(np.ones(3), np.ones(3), np.array([1.0, 2.0, 3.0]), np.ones(3))
        assert appender.close() == 3


def test_csv_without_geometry_or_events(tmp_path):
    src = tmp_path / "rec.csv"
    write_events_csv(src, 10, width=W, height=H, seed=1)
    with pytest.raises(InputError, match="pass `width_px` and `height_px`"):
        ingest([src], tmp_path / "o.h5")
    src.write_text("t,x,y,p\n\n")
    with pytest.raises(InputError, match=rf"^{src}, line 2: no events after the header"):
        ingest([src], tmp_path / "o.h5", options=_opts())
    _assert_nothing_written(tmp_path, tmp_path / "o.h5")


def _npy(tmp_path: Path, table: np.ndarray) -> Path:
    src = tmp_path / "bad.npy"
    np.save(src, table)
    return src


def _events_table(n: int = 2_000, dtype=None) -> np.ndarray:
    ev = make_events(n, width=W, height=H, seed=10)
    table = np.empty(n, dtype=dtype or [("t", "<i8"), ("x", "<u2"), ("y", "<u2"), ("p", "i1")])
    for k in table.dtype.names:
        if k in ev:
            table[k] = ev[k]
    return table


def _with(table: np.ndarray, field: str, index: int, value) -> np.ndarray:
    table[field][index] = value
    return table


BAD_NPY = {
    "plain 2-D array": (lambda: np.zeros((10, 4), np.int64),
                        r"a plain int64 array of shape \(10, 4\), not a structured"),
    "missing field": (lambda: _events_table(dtype=[("t", "<i8"), ("x", "<u2"), ("y", "<u2")]),
                      r"missing field 'p'"),
    "extra field": (lambda: _events_table(dtype=[("t", "<i8"), ("x", "<u2"), ("y", "<u2"),
                                                 ("p", "i1"), ("q", "f4")]),
                    r"unexpected field 'q'"),
    "float t": (lambda: _events_table(dtype=[("t", "<f8"), ("x", "<u2"), ("y", "<u2"),
                                             ("p", "i1")]),
                r"field 't' has dtype float64; expected integer microseconds"),
    "x outside": (lambda: _with(_events_table(), "x", 1_500, W),
                  rf"index 1500: x = {W} is outside"),
    "t backwards": (lambda: _with(_events_table(), "t", 1_500, 0), r"index 1500: timestamp 0 us"),
    "polarity 2": (lambda: _with(_events_table(), "p", 1_234, 2),
                   r"index 1234: polarity 2 is outside this file's convention -1/\+1"),
    "mixing 0 and -1": (lambda: _with(_events_table(), "p", 1_234, 0),
                        r"index 1234: polarity 0 mixes conventions"),
    "2-D structured": (lambda: _events_table().reshape(40, 50), r"has shape \(40, 50\)"),
}


@pytest.mark.parametrize("case", list(BAD_NPY))
def test_bad_npy_names_file_and_writes_nothing(tmp_path, case):
    make, message = BAD_NPY[case]
    src = _npy(tmp_path, make())
    out = tmp_path / "out.h5"
    with pytest.raises(InputError, match=rf"^{re.escape(str(src))}(, |: ){message}"):
        ingest([src], out, options=_opts())
    _assert_nothing_written(tmp_path, out)


def test_npy_not_an_array_or_truncated(tmp_path):
    junk = tmp_path / "junk.npy"
    junk.write_bytes(b"definitely not numpy")
    with pytest.raises(InputError, match=rf"^{junk}: not a readable \.npy array"):
        ingest([junk], tmp_path / "o.h5", options=_opts())
    src = tmp_path / "cut.npy"
    write_events_npy(src, 1_000, width=W, height=H, seed=1)
    src.write_bytes(src.read_bytes()[:-100])
    with pytest.raises(InputError, match=rf"^{src}: (file is truncated|not a readable)"):
        ingest([src], tmp_path / "o.h5", options=_opts())
    _assert_nothing_written(tmp_path, tmp_path / "o.h5")


def test_polarity_convention_is_fixed_by_the_first_0_or_minus_1():
    conv = PolarityConvention()
    assert conv.to_pm1(np.array([1, 1]), path="f", first_row=2, row_label="line").tolist() == [1, 1]
    assert conv.name is None
    out = conv.to_pm1(np.array([1, 0, 1]), path="f", first_row=4, row_label="line")
    assert out.tolist() == [1, -1, 1] and out.dtype == np.int8
    assert (conv.name, conv.where) == ("0/1", "line 5")
    with pytest.raises(InputError, match=r"^f, line 9: polarity -1 mixes conventions.*line 5"):
        conv.to_pm1(np.array([1, -1]), path="f", first_row=8, row_label="line")
    with pytest.raises(InputError, match=r"^f, line 3: polarity 5 is neither 0/1 nor -1/\+1"):
        PolarityConvention().to_pm1(np.array([1, 5]), path="f", first_row=2, row_label="line")


def test_failed_ingest_leaves_an_existing_output_untouched(tmp_path):
    good = tmp_path / "good.csv"
    write_events_csv(good, 1_000, width=W, height=H, seed=11)
    out = ingest([good], tmp_path / "out.h5", options=_opts())
    before = hashlib.sha256(out.read_bytes()).hexdigest()
    bad = _csv_with(tmp_path, LATE, lambda s: s + ",9")
    with pytest.raises(InputError, match="extra field"):
        ingest([good, bad], out, options=_opts(), overwrite=True)
    assert hashlib.sha256(out.read_bytes()).hexdigest() == before
    assert [p.name for p in tmp_path.iterdir() if ".tmp-" in p.name] == []


# -- through the CLI -------------------------------------------------------------------------
@pytest.mark.parametrize("case", ["short row", "polarity 2", "t backwards"])
def test_cli_bad_csv_exits_2_with_one_line(tmp_path, case):
    line_no, edit, message = BAD_CSV[case]
    src = _csv_with(tmp_path, line_no, edit)
    out = tmp_path / "out.h5"
    result = runner.invoke(app, ["ingest", str(src), "--out", str(out), "--width", str(W),
                                 "--height", str(H)])
    assert result.exit_code == 2
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and "Traceback" not in result.output
    assert lines[0].startswith(f"tactile: error: {src}, line ")
    _assert_nothing_written(tmp_path, out)


def test_cli_missing_geometry_and_unknown_format(tmp_path):
    src = tmp_path / "rec.csv"
    write_events_csv(src, 10, width=W, height=H, seed=1)
    result = runner.invoke(app, ["ingest", str(src), "--out", str(tmp_path / "o.h5")])
    assert result.exit_code == 2
    assert result.stderr.strip() == (f"tactile: error: {src}: event CSV files do not record the "
                                     "sensor size; pass --width and --height (pixels), e.g. "
                                     "--width 320 --height 240")
    result = runner.invoke(app, ["ingest", str(src), "--out", str(tmp_path / "o.h5"),
                                 "--format", "evt3"])
    assert result.exit_code == 2 and "unknown format 'evt3'" in result.stderr
    _assert_nothing_written(tmp_path, tmp_path / "o.h5")


def test_cli_ingests_csv_and_npy(tmp_path):
    truth = write_events_npy(tmp_path / "rec.npy", 3_000, width=W, height=H, seed=12,
                             polarity="01")
    out = tmp_path / "rec.h5"
    result = runner.invoke(app, ["ingest", str(tmp_path / "rec.npy"), "--out", str(out),
                                 "--width", str(W), "--height", str(H), "--compression", "1",
                                 "--no-progress"])
    assert result.exit_code == 0, result.stderr
    assert f"wrote {out}" in result.output
    np.testing.assert_array_equal(_stored(out, "rec")["p"], truth["p"])
