"""Deflate for the frame chunks the store compresses itself (:class:`~.writer.FrameAppender`).

HDF5's gzip filter stores each chunk as a zlib stream (deflate with the zlib header and
Adler-32) and reads any valid one back, whoever made it. At gzip level 1, the toolkit's
default, camera frames are deflated with ISA-L (the ``isal`` package, Intel's
Intelligent Storage Acceleration Library) at its level 1: on 320x240 RGB frames it runs
about 6 times as fast as zlib's level 1 (200 against 34 MB/s on the simulated rig's frames,
300 against 48 MB/s on real GelSight Mini frames, one core) for 6 to 12 % more bytes
(0.706 against 0.666, and 0.482 against 0.428, of the raw size). Deflating noisy frames
with zlib cost twice the CPU time a ROS bag reader needs to read them, and was what kept a
robot-recording ingest at a quarter of the reader's rate. Other levels (2-9) use zlib at
that level, byte for byte what HDF5's own filter writes.

The stored values are the same either way (a round trip is exact); the compressed bytes of
a level-1 chunk are ISA-L's, which may differ between CPU families (ISA-L picks its code by
the instruction set). They do not depend on the thread pool's size: each chunk is
compressed alone. Measured by ``benchmarks/rosbag_ingest.py``; see benchmarks/RESULTS.md.
"""

from __future__ import annotations

import zlib

from isal import isal_zlib

#: The gzip level deflated with ISA-L (the toolkit's default level).
FAST_LEVEL = 1


def deflate_chunk(data: bytes, level: int) -> bytes:
    """``data`` (a chunk's raw bytes) as a zlib stream for HDF5's gzip filter at ``level``
    (1-9): ISA-L's level 1 at level 1, zlib at the others."""
    if level == FAST_LEVEL:
        return isal_zlib.compress(data, 1)
    return zlib.compress(data, level)


__all__ = ["FAST_LEVEL", "deflate_chunk"]
