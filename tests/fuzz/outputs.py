"""Issue 33's classes for the event-chain commands and their neighbours (accumulate,
fit-fos, frames, centroids, slip-rate, grade, synth, plot, samples) in the damaged-input
corpus: an output that is an input or holds one, an output folder the system refuses, and
numbers that imply absurd work.

The inputs are valid copies (``{IN}``); every case must be refused in one line before any
work, and the runner checks that ``{IN}`` and every ``{BASE}`` path a case names are
byte-identical afterwards. Unwritable places are folders of ``/sys``, which refuses new
files even to root (a read-only mount, as `chattr +i` folders are, without privileges).
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

REFUSE = "refuse"
EITHER = "either"

EV = "{BASE}/h5/events.h5"
ROIS = "{BASE}/cfg/rois_marker_scene.yaml"
FIT = ["--no-write", "--no-order", "--kind", "press", "--max-steps", "8"]
NO_PROGRESS = ["--no-progress"]
#: a folder no process may create files in (sysfs)
UNWRITABLE = "/sys/tactile-fuzz"


def add_output_cases(add: Callable[..., object], case: Callable[..., None], base: Path) -> None:
    """The cases, through build_corpus's ``add`` (a valid copy) and ``case``."""
    cfg = base / "cfg"
    # an output that is the input, or a folder that holds it, with and without --overwrite
    d = add("sacred", base / "h5" / "events.h5", "events.h5", "output-is-input", "sacred",
            None)
    for command, argv in [
        ("accumulate", ["accumulate", "{IN}", "--out", "{IN}", "--overwrite", *NO_PROGRESS]),
        ("accumulate", ["accumulate", "{IN}", "--csv", "{IN}", *NO_PROGRESS]),
        ("accumulate", ["accumulate", "{IN}", "--plot", "{IN}/..", "--overwrite",
                        *NO_PROGRESS]),
        ("fit-fos", ["fit-fos", "{IN}", *FIT, "--csv", "{IN}", "--overwrite"]),
        ("fit-fos", ["fit-fos", "{IN}", *FIT, "--plot", "{IN}/.."]),
        ("centroids", ["centroids", "{IN}", "--rois", ROIS, "--out", "{IN}", "--overwrite",
                       *NO_PROGRESS]),
        ("frames", ["frames", "{IN}", "--out", "{IN}/..", "--overwrite", "--sheet-only"]),
        ("slip-rate", ["slip-rate", "{IN}", "--rois", ROIS, "--plot", "{IN}/.."]),
        ("grade", ["grade", "{IN}", "--calibrate", "--out", "{IN}", "--overwrite"]),
        ("grade", ["grade", "{IN}", "--plot", "{IN}/.."]),
        ("plot", ["plot", "{IN}", "--out", "{IN}/.."]),
        ("synth", ["synth", "--fits", "{IN}", "--out", "{IN}", "--overwrite", "--n", "3",
                   *NO_PROGRESS]),
    ]:
        case(d, command, argv, REFUSE)
    for name, src, command, argv in [
        ("rois.yaml", cfg / "rois_marker_scene.yaml", "centroids",
         ["centroids", EV, "--rois", "{IN}", "--out", "{IN}", "--overwrite", *NO_PROGRESS]),
        ("rois.yaml", cfg / "rois_marker_scene.yaml", "frames",
         ["frames", EV, "--rois", "{IN}", "--out", "{IN}/..", "--sheet-only"]),
        ("grade.yaml", cfg / "grade_marker.yaml", "grade",
         ["grade", EV, "--config", "{IN}", "--calibrate", "--out", "{IN}", "--overwrite"]),
        ("synth.yaml", cfg / "synth_fos.yaml", "synth",
         ["synth", "--config", "{IN}", "--out", "{IN}", "--overwrite", "--n", "3",
          *NO_PROGRESS]),
        ("curves/fos_curve.csv", base / "fos_curve.csv", "fit-fos",
         ["fit-fos", "{IN}/..", "--model", "step", "--no-order", "--csv", "{IN}/../fits.csv"]),
        ("curves/fos_curve.csv", base / "fos_curve.csv", "fit-fos",
         ["fit-fos", "{IN}", "--model", "step", "--no-order", "--csv", "{IN}", "--overwrite"]),
    ]:
        d = add("sacred", src, name, f"{command}-output-is-input-{Path(name).name}", "sacred",
                None)
        case(d, command, argv, REFUSE)

    # output folders the system refuses (nothing is created, nothing is left)
    for i, (command, argv) in enumerate([
        ("accumulate", ["accumulate", EV, "--csv", f"{UNWRITABLE}.csv", *NO_PROGRESS]),
        ("accumulate", ["accumulate", EV, "--plot", UNWRITABLE, *NO_PROGRESS]),
        ("fit-fos", ["fit-fos", EV, *FIT, "--csv", f"{UNWRITABLE}.csv"]),
        ("fit-fos", ["fit-fos", EV, *FIT, "--plot", UNWRITABLE]),
        ("centroids", ["centroids", EV, "--rois", ROIS, "--out", f"{UNWRITABLE}.h5",
                       *NO_PROGRESS]),
        ("frames", ["frames", EV, "--out", UNWRITABLE, "--sheet-only"]),
        ("slip-rate", ["slip-rate", EV, "--rois", ROIS, "--plot", UNWRITABLE]),
        ("grade", ["grade", "{BASE}/grade_table.csv", "--calibrate", "--out",
                   f"{UNWRITABLE}.yaml"]),
        ("grade", ["grade", EV, "--plot", UNWRITABLE]),
        ("synth", ["synth", "--n", "3", "--out", f"{UNWRITABLE}.h5", *NO_PROGRESS]),
        ("plot", ["plot", EV, "--out", UNWRITABLE]),
        ("samples", ["samples", UNWRITABLE, "--n-events", "1000"]),
    ]):
        d = add("unwritable", base / "annotations.csv", "unused", f"{command}-{i}",
                "clash", None)
        case(d, command, argv, REFUSE)

    # numbers: non-finite ones are refused when the command line is parsed; sizes that
    # imply absurd work are refused with their cost; harmless extremes may run
    numbers = [
        ("frames", ["frames", EV, "--out", "{OUT}/f", "--window-ms", "0.001"], REFUSE),
        ("frames", ["frames", EV, "--out", "{OUT}/f", "--window-ms", "1e-9"], REFUSE),
        ("frames", ["frames", EV, "--out", "{OUT}/f", "--median", "100001"], REFUSE),
        ("frames", ["frames", EV, "--out", "{OUT}/f", "--start-s", "-1"], REFUSE),
        ("frames", ["frames", EV, "--out", "{OUT}/f", "--end-s", "1e300"], REFUSE),
        ("frames", ["frames", EV, "--out", "{OUT}/f", "--window-ms", "nan"], REFUSE),
        ("frames", ["frames", EV, "--out", "{OUT}/f", "--sheet-only", "--window-ms", "400",
                    "--sheet-max", "1000000000000"], EITHER),
        ("accumulate", ["accumulate", EV, "--smooth", "1000000001", *NO_PROGRESS], EITHER),
        ("accumulate", ["accumulate", EV, "--bin-ms", "1e300", *NO_PROGRESS], EITHER),
        ("accumulate", ["accumulate", EV, "--bin-ms", "inf", *NO_PROGRESS], REFUSE),
        ("fit-fos", ["fit-fos", EV, *FIT[:-1], "1000000000"], EITHER),
        ("fit-fos", ["fit-fos", EV, *FIT, "--press-duration", "1e300"], EITHER),
        ("fit-fos", ["fit-fos", EV, *FIT, "--bin-ms", "1e-300"], REFUSE),
        ("fit-fos", ["fit-fos", EV, *FIT, "--rtol", "inf"], REFUSE),
        ("fit-fos", ["fit-fos", "{BASE}/h5/taxel.h5", "--stream", "taxels", "--regions",
                     "detect", "--max-curves", "2"], REFUSE),
        ("synth", ["synth", "--n", "1000000000", "--out", "{OUT}/s.h5", *NO_PROGRESS],
         REFUSE),
        ("synth", ["synth", "--n", "500", "--bin-ms", "0.001", "--out", "{OUT}/s.h5",
                   *NO_PROGRESS], REFUSE),
        ("samples", ["samples", "{OUT}/s", "--n-events", "1000000000000"], REFUSE),
        ("samples", ["samples", "{OUT}/s", "--n-events", "1000", "--seed", "-1"], REFUSE),
        ("grade", ["grade", EV, "--overlap", "1e-300"], REFUSE),
        ("plot", ["plot", EV, "--out", "{OUT}/p", "--max-trials", "1000000000000"], EITHER),
    ]
    for i, (command, argv, expect) in enumerate(numbers):
        d = add("numbers", base / "annotations.csv", "unused", f"{command}-{i}", "clash", None)
        case(d, command, argv, expect)


__all__ = ["add_output_cases"]
