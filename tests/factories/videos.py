"""Small videos written with PyAV: lossless (MKV/FFV1, exact pixels) with chosen
presentation timestamps (variable frame rate), and lossy MP4/H.264 at a fixed rate."""

from __future__ import annotations

from fractions import Fraction
from pathlib import Path

import numpy as np


def write_video(path: Path, frames: np.ndarray, pts_ms: list[int] | None = None, *,
                codec: str = "ffv1") -> Path:
    """Write (n, height, width, 3) uint8 RGB ``frames``; ``pts_ms``: each frame's
    presentation time in ms (default 30 fps). ffv1 (pix_fmt bgr0) is lossless;
    libx264 (yuv420p) is not."""
    import av

    n, h, w, _ = frames.shape
    pts_ms = pts_ms if pts_ms is not None else [round(k * 1000 / 30) for k in range(n)]
    base = Fraction(1, 1000)
    with av.open(str(path), "w") as container:
        stream = container.add_stream(codec, rate=1000 if codec == "ffv1" else 30)
        stream.width, stream.height = w, h
        stream.pix_fmt = "bgr0" if codec == "ffv1" else "yuv420p"
        stream.time_base = base
        stream.codec_context.time_base = base if codec == "ffv1" else Fraction(1, 30)
        for k, frame in enumerate(frames):
            vf = av.VideoFrame.from_ndarray(frame, format="rgb24")
            if codec == "ffv1":
                vf.pts, vf.time_base = pts_ms[k], base
            else:
                vf.pts, vf.time_base = k, Fraction(1, 30)
            for packet in stream.encode(vf):
                container.mux(packet)
        for packet in stream.encode():
            container.mux(packet)
    return path


__all__ = ["write_video"]
