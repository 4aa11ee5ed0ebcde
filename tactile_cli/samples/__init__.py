"""Small synthetic raw recordings of every format `tactile ingest` reads.

Used by the tests (round trips: known content in, same content out), by `tactile samples`
and by `make demo`. Each writer returns the ground truth it wrote, so a caller can compare
after ingest. Everything is deterministic for a given seed.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from ..interrupt import raise_if_requested
from ..store.outdir import check_output_folder, output_folder
from .events import write_events_csv as write_events_csv
from .events import write_events_npy as write_events_npy
from .images import write_image_sequence as write_image_sequence
from .signals import write_accel_tree as write_accel_tree
from .signals import write_taxel_recording as write_taxel_recording

EVENT_WIDTH, EVENT_HEIGHT = 640, 480
#: Events per event recording at most: each is held in memory (~40 bytes while the CSV
#: is formatted) and written twice (~20 bytes of CSV, 13 of NPY).
MAX_EVENTS = 20_000_000
_BYTES_PER_EVENT = 75


def write_all(out_dir: str | Path, *, seed: int = 0, n_events: int = 200_000) -> dict[str, Any]:
    """Write one small recording of every input format but AEDAT4 under ``out_dir``.

    Layout (the command that ingests each is in the returned ``commands``)::

        events.csv          t,x,y,p events, polarity 0/1, 640x480
        events.npy          structured array t,x,y,p, polarity -1/+1, 640x480
        accel_tree/         object/orientation/speed/data.csv, 8 kHz (paper 001 layout)
        taxel/              4x4 taxel CSVs at 100 Hz and their mapping taxels.yaml
        visuotactile/press_01, press_02   PNG frames + reference.png
        robot/              press.bag (ROS 1), press_ros2/ (ROS 2, mcap storage), press.mcap,
                            press.mp4 and the topic mapping topics.yaml (two presses each);
                            written when the `robot` extra (rosbags, mcap, av) is installed

    Returns ``{"paths": {...}, "commands": {name: [args after "tactile"]}}``.
    """
    from ..config_file import format_bytes
    from ..errors import InputError

    if not 1 <= n_events <= MAX_EVENTS:
        raise InputError(f"`n_events` (={n_events}) must be 1 to {MAX_EVENTS:,} (sample "
                         f"recordings; {n_events:,} would take about "
                         f"{format_bytes(max(n_events, 0) * _BYTES_PER_EVENT)} of memory and "
                         "disk)")
    if seed < 0:
        raise InputError(f"`seed` (={seed}) must be >= 0")
    out = check_output_folder(out_dir, merge=True)  # added to; a file there is refused
    # written into a hidden folder beside ``out_dir``, moved in when every file is
    with output_folder(out, merge=True) as tmp:
        geometry = ["--width", str(EVENT_WIDTH), "--height", str(EVENT_HEIGHT)]
        write_events_csv(
            tmp / "events.csv",
            n_events,
            width=EVENT_WIDTH,
            height=EVENT_HEIGHT,
            seed=seed,
            polarity="01",
            mean_dt_us=5,
        )
        write_events_npy(
            tmp / "events.npy",
            n_events,
            width=EVENT_WIDTH,
            height=EVENT_HEIGHT,
            seed=seed + 1,
            mean_dt_us=5,
        )
        write_accel_tree(tmp / "accel_tree", seconds=0.5, seed=seed)
        raise_if_requested()
        taxel = write_taxel_recording(tmp / "taxel", seed=seed)
        mapping = out / Path(taxel["mapping"]).relative_to(tmp)  # where it will be
        for k in (1, 2):
            write_image_sequence(
                tmp / "visuotactile" / f"press_{k:02d}",
                n_frames=12,
                width=160,
                height=120,
                seed=seed + k,
                frame_rate_hz=30.0,
            )
        import importlib.util

        from .robot import write_robot_samples

        # the robot recordings need the optional `robot` extra (rosbags, mcap, av)
        with_robot = all(importlib.util.find_spec(m) is not None
                         for m in ("rosbags", "mcap", "mcap_ros2", "av"))
        if with_robot:
            write_robot_samples(tmp / "robot", seed=seed)
        robot = out / "robot"  # where it will be
    return {
        "paths": {"root": out},
        "commands": {
            "events_csv": ["ingest", str(out / "events.csv"), *geometry],
            "events_npy": ["ingest", str(out / "events.npy"), *geometry],
            "accel": ["ingest", str(out / "accel_tree"), "--format", "accel-tree"],
            "taxel": ["ingest", str(out / "taxel"), "--mapping", str(mapping)],
            "visuotactile": [
                "ingest",
                str(out / "visuotactile" / "press_01"),
                str(out / "visuotactile" / "press_02"),
            ],
            **({"ros1_bag": ["ingest", str(robot / "press.bag"), "--mapping",
                             str(robot / "topics.yaml")],
                "ros2_bag": ["ingest", str(robot / "press_ros2"), "--mapping",
                             str(robot / "topics.yaml")],
                "mcap": ["ingest", str(robot / "press.mcap"), "--mapping",
                         str(robot / "topics.yaml")],
                "video": ["ingest", str(robot / "press.mp4")]} if with_robot else {}),
        },
    }
