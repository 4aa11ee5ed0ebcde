"""Frames written by the appender's deflate pool and direct chunk writes: an exact round
trip; at gzip level 1 ISA-L's zlib streams (which HDF5's filter reads), at other levels the
same bytes as HDF5's own shuffle + gzip filters; and the same file content whatever the
pool size."""

from __future__ import annotations

import zlib
from pathlib import Path

import h5py
import numpy as np
import pytest
from isal import isal_zlib

from tactile_cli.store import validate_file
from tactile_cli.store.writer import Compression, EventAppender, StoreWriter

SHAPE = (24, 32, 3)


def _frames(n: int = 11) -> np.ndarray:
    rng = np.random.default_rng(3)
    smooth = np.linspace(0, 200, SHAPE[0] * SHAPE[1] * 3).reshape(SHAPE)
    return (smooth[None] + rng.integers(0, 40, (n, *SHAPE))).astype(np.uint8)


def _write(path: Path, frames: np.ndarray, level: int | None) -> Path:
    with StoreWriter(path, command="test", compression=Compression(level)) as w:
        w.add_sensor("cam", kind="visuotactile", sample_rate_hz=30.0, width_px=SHAPE[1],
                     height_px=SHAPE[0])
        appender = w.trial("r").frames("cam", reference=frames[0])
        for s in range(0, len(frames), 4):  # batches of 4, the last partial
            appender.append(frames[s:s + 4], np.arange(s, min(s + 4, len(frames))) / 30)
        assert appender.close() == len(frames)
        w.commit()
    return path


def _chunks(path: Path) -> list[bytes]:
    with h5py.File(path) as f:
        ds = f["trials/r/frames/images"]
        return [ds.id.read_direct_chunk((i, 0, 0, 0))[1] for i in range(len(ds))]


@pytest.mark.parametrize("level", [1, 6])
def test_frame_chunks_decode_through_hdf5s_filters_and_round_trip(tmp_path, level):
    frames = _frames()
    out = _write(tmp_path / "ours.h5", frames, level)
    assert validate_file(out).ok
    with h5py.File(out) as f, h5py.File(tmp_path / "ref.h5", "w") as ref:
        ds = f["trials/r/frames/images"]
        assert (ds.compression, ds.compression_opts, ds.shuffle) == ("gzip", level, True)
        np.testing.assert_array_equal(ds[()], frames)
        np.testing.assert_array_equal(f["trials/r/frames/t_s"][()], np.arange(11) / 30)
        plain = ref.create_dataset("images", data=frames, chunks=(1, *SHAPE),
                                   maxshape=(None, *SHAPE), compression="gzip",
                                   compression_opts=level, shuffle=True)
        for i in range(len(frames)):
            mask, chunk = ds.id.read_direct_chunk((i, 0, 0, 0))
            assert mask == 0 and zlib.decompress(chunk) == frames[i].tobytes(), i
            if level == 1:  # ISA-L's stream, not zlib's: a different, valid encoding
                assert chunk == isal_zlib.compress(frames[i].tobytes(), 1), i
            else:
                assert (mask, chunk) == plain.id.read_direct_chunk((i, 0, 0, 0)), i


def test_uncompressed_frames_round_trip(tmp_path):
    frames = _frames(5)
    out = _write(tmp_path / "raw.h5", frames, None)
    with h5py.File(out) as f:
        assert f["trials/r/frames/images"].compression is None
        np.testing.assert_array_equal(f["trials/r/frames/images"][()], frames)


def test_frame_chunks_do_not_depend_on_the_pool_size(tmp_path, monkeypatch):
    frames = _frames(13)
    chunks = []
    for workers in (1, 2):
        monkeypatch.setattr(EventAppender, "_pool_size", staticmethod(lambda w=workers: w))
        monkeypatch.setattr(EventAppender, "_pool", None)  # a fresh pool of that size
        chunks.append(_chunks(_write(tmp_path / f"w{workers}.h5", frames, 1)))
        pool = EventAppender._pool
        assert pool is not None and pool._max_workers == workers
        pool.shutdown()
    assert chunks[0] == chunks[1]
