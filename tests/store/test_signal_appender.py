"""A sampled stream written in blocks (``TrialWriter.signal``): the same values, times,
filters and trial duration as ``write_signal`` of the whole stream; stamps that go back
counted across blocks and sorted only when asked."""

from __future__ import annotations

from pathlib import Path

import h5py
import numpy as np
import pytest

from tactile_cli.store import validate_file
from tactile_cli.store.writer import Compression, StoreWriter


def _stream(n: int = 50, channels: int = 3) -> tuple[np.ndarray, np.ndarray]:
    rng = np.random.default_rng(0)
    return rng.normal(0, 1, (n, channels)).astype(np.float32), np.arange(n) / 100.0


def _write(path: Path, data: np.ndarray, t_s: np.ndarray, *, blocks: int | None,
           level: int | None = 1, sort: bool = False) -> tuple[Path, int]:
    back = 0
    with StoreWriter(path, command="test", compression=Compression(level)) as w:
        w.add_sensor("pad", kind="pressure", sample_rate_hz=100.0,
                     channel_names=[f"c{i}" for i in range(data.shape[1])])
        trial = w.trial("r")
        if blocks is None:
            trial.write_signal("pad", sensor="pad", data=data, t_s=t_s)
        else:
            appender = trial.signal("pad", sensor="pad", n_channels=data.shape[1])
            for s in range(0, len(t_s), blocks):
                appender.append(data[s:s + blocks], t_s[s:s + blocks])
            back = appender.back
            appender.close(sort=sort)
        if back and not sort:  # the schema refuses times that go back: nothing is written
            w.abort()
            return path, back
        w.commit()
    return path, back


@pytest.mark.parametrize("level", [1, None])
def test_blocks_read_back_as_the_whole_stream(tmp_path, level):
    data, t_s = _stream()
    whole, _ = _write(tmp_path / "whole.h5", data, t_s, blocks=None, level=level)
    blocks, back = _write(tmp_path / "blocks.h5", data, t_s, blocks=7, level=level)
    assert back == 0 and validate_file(blocks).ok
    with h5py.File(whole) as a, h5py.File(blocks) as b:
        for name in ("data", "t_s"):
            x, y = a[f"trials/r/signals/pad/{name}"], b[f"trials/r/signals/pad/{name}"]
            np.testing.assert_array_equal(x[()], y[()])
            assert (x.dtype, x.compression, x.compression_opts) == \
                (y.dtype, y.compression, y.compression_opts)
        assert a["trials/r"].attrs["duration_s"] == b["trials/r"].attrs["duration_s"] == 0.49
        assert b["trials/r/signals/pad"].attrs["sensor"] == "pad"


def test_stamps_that_go_back_across_blocks_are_counted_and_sorted_when_asked(tmp_path):
    data, t_s = _stream(12)
    t_s = t_s[[0, 1, 2, 4, 3, 5, 6, 8, 7, 9, 11, 10]]  # three go back; blocks of 4 split two
    kept, back = _write(tmp_path / "kept.h5", data, t_s, blocks=4)
    assert back == 3 and not kept.exists()  # not sorted: the caller refuses the input
    out, back = _write(tmp_path / "sorted.h5", data, t_s, blocks=4, sort=True)
    order = np.argsort(t_s, kind="stable")
    with h5py.File(out) as f:
        np.testing.assert_array_equal(f["trials/r/signals/pad/t_s"][()], t_s[order])
        np.testing.assert_array_equal(f["trials/r/signals/pad/data"][()], data[order])
    assert validate_file(out).ok


def test_a_block_of_the_wrong_width_is_a_programming_error(tmp_path):
    with StoreWriter(tmp_path / "o.h5", command="test") as w:
        appender = w.trial("r").signal("pad", sensor="pad", n_channels=3)
        with pytest.raises(ValueError, match=r"`data` must be \(k, 3\)"):
            appender.append(np.zeros((2, 4)), np.zeros(2))
        with pytest.raises(ValueError, match="non-finite"):
            appender.append(np.zeros((1, 3)), np.array([np.nan]))
        w.abort()


@pytest.mark.parametrize("level", [1, 6])
def test_whole_chunks_deflated_in_the_pool_read_back_exactly(tmp_path, level, monkeypatch):
    """Chunks of 4 rows (3 channels, 48 bytes): blocks of 4 rows go through the pool and the
    direct chunk write, the last 2 rows through h5py; at level 6 every chunk is byte for
    byte what HDF5's own shuffle + gzip filters write."""
    from tactile_cli.store import writer

    monkeypatch.setattr(writer, "SIGNAL_CHUNK_BYTES", 48)
    data, t_s = _stream(50)
    out, _ = _write(tmp_path / "o.h5", data, t_s, blocks=4, level=level)
    assert validate_file(out).ok
    with h5py.File(out) as f, h5py.File(tmp_path / "ref.h5", "w") as ref:
        ds = f["trials/r/signals/pad/data"]
        assert ds.chunks == (4, 3) and (ds.compression_opts, ds.shuffle) == (level, True)
        np.testing.assert_array_equal(ds[()], data)
        np.testing.assert_array_equal(f["trials/r/signals/pad/t_s"][()], t_s)
        if level != 1:  # level 1 chunks are ISA-L's streams (tests/store/test_frame_chunks.py)
            plain = ref.create_dataset("d", data=data, chunks=(4, 3), compression="gzip",
                                       compression_opts=level, shuffle=True)
            for row in range(0, 48, 4):
                assert ds.id.read_direct_chunk((row, 0)) == \
                    plain.id.read_direct_chunk((row, 0)), row


@pytest.mark.parametrize("fault, where", [("nan", "data: non-finite values"),
                                          ("repeat", "t_s: time does not increase")])
def test_what_the_appender_did_not_verify_the_commit_still_finds(tmp_path, fault, where):
    """Verified on the way in, a stream skips the commit's value scans; a NaN value or a
    repeated stamp is left to those scans, which refuse the file as before."""
    from tactile_cli.errors import SchemaError

    data, t_s = _stream(12)
    if fault == "nan":
        data[7, 1] = np.nan
    else:
        t_s[5] = t_s[4]
    with pytest.raises(SchemaError, match=where):
        _write(tmp_path / "o.h5", data, t_s, blocks=4)
    assert not (tmp_path / "o.h5").exists()
