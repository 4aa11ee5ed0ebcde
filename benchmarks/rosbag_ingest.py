"""Robot-recording ingest throughput: `tactile ingest REC --mapping` against the reader
library alone, on the same recording (issue 31, item 4).

One run writes one recording of the simulated press rig (``tactile_cli.samples.robot``):
camera frames ``sensor_msgs/Image`` rgb8 at 30 Hz (320x240 by default), a 4x4
``Float32MultiArray`` and a ``WrenchStamped`` at 1 kHz each, String markers (one trial), as a
ROS 1 bag, a ROS 2 bag (mcap storage) or a standalone MCAP file, then measures in fresh
child processes (imports off the clock):

- **reader alone**: the container reader iterating every message of the three mapped topics
  and deserialising it (rosbags ``AnyReader`` + its typestore for bags; ``mcap``'s reader +
  the same typestore for MCAP), what a user's own export script would do first;
- **reader, raw**: the same reader iterating the same messages without deserialising them:
  the floor of any ingest (``reader_raw_s``, ``ratio_vs_raw`` = ingest / raw rate). The
  ingest reads the rows of the arrays and wrenches straight from the messages' bytes
  (``tactile_cli.ingest.robot_layouts``), so it deserialises only the frames (and each
  topic's first message, to check the raw reader against the deserialiser);
- **tactile ingest**: ``tactile_cli.ingest.ingest`` end to end with
  ``configs/rosbag_tactile_rig.yaml`` (decode, image to RGB, stamps, gzip level 1 frames
  and signal chunks, deflated by ISA-L in the store's thread pool, SHA-256 of the
  recording in a thread beside the reading, schema validation, atomic rename).

``--taxel-grid 20 60`` makes the taxel array 1,200 values (a Tac3D-sized sensor) at 1 kHz,
4.8 MB/s of values: then the arrays, not the frames, make most of the recording, which is
what tests that memory does not grow with a trial's sample rows.

Rates are recording bytes / wall seconds (MB = 10^6 bytes); ``ratio`` = ingest / reader
alone (target >= 0.70); ``peak_rss_mb`` is the ingest child's ``VmHWM`` (target: well under
1 GB for a 2 GB recording, i.e. memory that does not grow with the recording);
``reader_cpu_s``/``ingest_cpu_s`` are each child's user + system CPU seconds over all its
threads (imports included), and ``load_avg_1min`` the machine's 1-minute load average
before the reader and after the ingest: on a shared machine the ratio moves with the load.
The recording sits in the page cache (just written), as for both measurements.

Video (``--video-s``, default 30 s; 0 skips it): the rig's camera as an MP4
(``write_press_video``: MPEG-4 part 2, 30 fps, the same frames size), measured the same way:
PyAV alone demuxing, decoding and converting every frame to RGB (``to_ndarray("rgb24")``,
what any RGB ingest needs), against ``tactile ingest`` of the video; ``video_ratio`` =
ingest / PyAV alone, in frames per second.

    .venv/bin/python benchmarks/rosbag_ingest.py --mb 1024 --container ros1 --json
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
MAPPING = REPO / "configs" / "rosbag_tactile_rig.yaml"
TOPICS = ("/digit/image_raw", "/taxels", "/ft_sensor/wrench")
IMAGE_HW = (240, 320)
IMAGE_HZ, ARRAY_HZ = 30.0, 1000.0
#: Bytes per second of recording (frames dominate): for sizing the recording.
BYTES_PER_S = IMAGE_HZ * (IMAGE_HW[0] * IMAGE_HW[1] * 3 + 120) + ARRAY_HZ * (120 + 200)


def bytes_per_s(taxel_grid: tuple[int, int]) -> float:
    """:data:`BYTES_PER_S` with a taxel array of ``taxel_grid`` values (4 bytes each)."""
    return BYTES_PER_S + ARRAY_HZ * 4 * (taxel_grid[0] * taxel_grid[1] - 16)


def _peak_rss_mb() -> float:
    with open("/proc/self/status") as f:
        for line in f:
            if line.startswith("VmHWM:"):
                return int(line.split()[1]) * 1024 / 1e6
    return float("nan")


def _child(kind: str, src: str, out: str, level: int | None) -> dict[str, float]:
    n = 0
    if kind == "video_reader":
        import av

        start = time.perf_counter()
        with av.open(src) as container:
            for frame in container.decode(container.streams.video[0]):
                frame.to_ndarray(format="rgb24")
                n += 1
        seconds = time.perf_counter() - start
    elif kind == "video_ingest":
        import av  # noqa: F401  (imports off the clock)

        import tactile_cli.ingest.video  # noqa: F401
        from tactile_cli.ingest import ingest
        from tactile_cli.store.writer import Compression

        start = time.perf_counter()
        ingest([src], out, overwrite=True, command="benchmark", compression=Compression(level))
        seconds = time.perf_counter() - start
    elif kind == "reader_raw":
        from tactile_cli.ingest.robot_recording import RobotRecording

        start = time.perf_counter()
        with RobotRecording(Path(src)) as rec:
            for _ in rec.raw_messages(TOPICS):
                n += 1
        seconds = time.perf_counter() - start
    elif kind == "reader":
        from tactile_cli.ingest.robot_recording import RobotRecording

        start = time.perf_counter()
        n = 0
        with RobotRecording(Path(src)) as rec:
            decoders = {t: rec.decoder(t) for t in TOPICS}
            for topic, _, raw in rec.raw_messages(TOPICS):
                decoders[topic](raw)
                n += 1
        seconds = time.perf_counter() - start
    else:
        import tactile_cli.ingest.robot_bag  # noqa: F401  (imports off the clock)
        from tactile_cli.ingest import ingest
        from tactile_cli.ingest.robot_recording import RobotRecording
        from tactile_cli.store.writer import Compression

        with RobotRecording(Path(src)):  # the readers' own imports, off the clock
            pass
        start = time.perf_counter()
        ingest([src], out, options={"mapping": MAPPING}, overwrite=True, command="benchmark",
               compression=Compression(level))
        seconds = time.perf_counter() - start
    import resource

    usage = resource.getrusage(resource.RUSAGE_SELF)  # every thread's, imports included
    return {"seconds": seconds, "messages": n, "peak_rss_mb": _peak_rss_mb(),
            "cpu_s": usage.ru_utime + usage.ru_stime}


def _run_child(kind: str, src: Path, out: Path, level: int | None) -> dict[str, float]:
    proc = subprocess.run([sys.executable, __file__, "--child", kind, str(src), str(out),
                           str(-1 if level is None else level)],
                          capture_output=True, text=True, check=True)
    return json.loads(proc.stdout.strip().splitlines()[-1])


def _size(path: Path) -> int:
    return (sum(p.stat().st_size for p in path.iterdir()) if path.is_dir()
            else path.stat().st_size)


def _video(root: Path, args: argparse.Namespace, level: int | None) -> dict[str, float]:
    """The video comparison: PyAV alone against ``tactile ingest`` of the same MP4."""
    from tactile_cli.samples import robot

    src = robot.write_press_video(root / "press.mp4", seconds=args.video_s, image_hz=IMAGE_HZ,
                                  size_hw=IMAGE_HW, array_hz=100.0, seed=0)
    reader = [_run_child("video_reader", src, root / "x.h5", level) for _ in range(args.repeat)]
    tactile = [_run_child("video_ingest", src, root / "v.h5", level)
               for _ in range(args.repeat)]
    frames = int(reader[0]["messages"])
    reader_s = statistics.median(r["seconds"] for r in reader)
    ingest_s = statistics.median(r["seconds"] for r in tactile)
    return {"video_mb": round(src.stat().st_size / 1e6, 1), "video_frames": frames,
            "video_reader_alone_s": round(reader_s, 2), "video_ingest_s": round(ingest_s, 2),
            "video_reader_alone_fps": round(frames / reader_s, 1),
            "video_ingest_fps": round(frames / ingest_s, 1),
            "video_ratio": round(reader_s / ingest_s, 3),
            "video_peak_rss_mb": round(max(r["peak_rss_mb"] for r in tactile), 1)}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--mb", type=float, default=256.0, help="recording size in MB")
    parser.add_argument("--container", choices=("ros1", "ros2", "mcap"), default="ros1")
    parser.add_argument("--repeat", type=int, default=1)
    parser.add_argument("--json", action="store_true")
    parser.add_argument("--compression", type=int, default=1,
                        help="gzip level of the ingest (-1: none; 1 is the CLI default)")
    parser.add_argument("--video-s", type=float, default=30.0,
                        help="seconds of the MP4 of the video comparison (0: skip it)")
    parser.add_argument("--taxel-grid", type=int, nargs=2, default=(4, 4), metavar=("ROWS", "COLS"),
                        help="taxel array size (20 60: a Tac3D-sized array of 1,200 values at "
                             "1 kHz, where the arrays, not the frames, make most of the bytes)")
    parser.add_argument("--child", nargs=4, metavar=("KIND", "SRC", "OUT", "LEVEL"),
                        help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.child:
        kind, src, out, level = args.child
        print(json.dumps(_child(kind, src, out, None if int(level) < 0 else int(level))))
        return
    from tactile_cli.samples import robot

    grid = tuple(args.taxel_grid)
    seconds = max(1.0, args.mb * 1e6 / bytes_per_s(grid))
    kw = {"seconds": seconds, "n_trials": 1, "image_hz": IMAGE_HZ, "size_hw": IMAGE_HW,
          "array_hz": ARRAY_HZ, "taxel_grid": grid, "seed": 0}
    with tempfile.TemporaryDirectory(prefix="rosbag-bench-") as tmp:
        root = Path(tmp)
        t0 = time.perf_counter()
        src = {"ros1": lambda: robot.write_ros1_bag(root / "rig.bag", **kw),
               "ros2": lambda: robot.write_ros2_bag(root / "rig_ros2", **kw),
               "mcap": lambda: robot.write_mcap(root / "rig.mcap", **kw)}[args.container]()
        write_s = time.perf_counter() - t0
        size = _size(src)
        level = None if args.compression < 0 else args.compression
        load = [os.getloadavg()[0]]
        reader = [_run_child("reader", src, root / "x.h5", level) for _ in range(args.repeat)]
        raw = [_run_child("reader_raw", src, root / "x.h5", level) for _ in range(args.repeat)]
        tactile = [_run_child("ingest", src, root / "o.h5", level) for _ in range(args.repeat)]
        load.append(os.getloadavg()[0])
        out_mb = (root / "o.h5").stat().st_size / 1e6
        (root / "o.h5").unlink()
        video = _video(root, args, level) if args.video_s > 0 else {}
    reader_s = statistics.median(r["seconds"] for r in reader)
    ingest_s = statistics.median(r["seconds"] for r in tactile)
    raw_s = statistics.median(r["seconds"] for r in raw)
    result = {
        "container": args.container, "recording_mb": round(size / 1e6, 1),
        "recording_s": round(seconds, 1), "messages": int(reader[0]["messages"]),
        "image_hw": list(IMAGE_HW), "taxel_grid": list(grid), "write_s": round(write_s, 1),
        "reader_alone_s": round(reader_s, 2), "ingest_s": round(ingest_s, 2),
        "reader_alone_mb_s": round(size / 1e6 / reader_s, 1),
        "ingest_mb_s": round(size / 1e6 / ingest_s, 1),
        "ratio": round(reader_s / ingest_s, 3),
        "reader_raw_s": round(raw_s, 2), "reader_raw_mb_s": round(size / 1e6 / raw_s, 1),
        "ratio_vs_raw": round(raw_s / ingest_s, 3),
        "peak_rss_mb": round(max(r["peak_rss_mb"] for r in tactile), 1),
        "reader_peak_rss_mb": round(max(r["peak_rss_mb"] for r in reader), 1),
        "reader_cpu_s": round(statistics.median(r["cpu_s"] for r in reader), 1),
        "ingest_cpu_s": round(statistics.median(r["cpu_s"] for r in tactile), 1),
        "load_avg_1min": [round(x, 2) for x in load],
        "output_mb": round(out_mb, 1), "compression": args.compression, "repeat": args.repeat,
        **video,
    }
    if args.json:
        print(json.dumps(result, indent=2))
    else:
        for key, value in result.items():
            print(f"{key:>20}: {value}")


if __name__ == "__main__":
    main()
