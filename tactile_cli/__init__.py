"""tactile-cli: tactile-sensing research from raw recordings to trained, evaluated models.

The library API (importable in a notebook without the CLI)::

    import tactile_cli as tc
    tc.ingest(["rec.aedat4"], "rec.h5")
    tc.describe_recording("rec.aedat4").streams      # what tactile info RAW prints
    tc.validate_file("rec.h5").ok
    with tc.TactileFile("rec.h5") as f:
        for trial in f:
            trial.labels, trial.annotations

Each chain's main verbs are here too (``tc.accumulate_file``, ``tc.fit_fos_file``,
``tc.train_run``, ...); they are imported when first used, so ``import tactile_cli`` does not
load torch or JAX.
"""

from __future__ import annotations

import importlib
from typing import Any

from ._version import __version__ as __version__
from .errors import InputError as InputError
from .errors import SchemaError as SchemaError
from .errors import TactileError as TactileError
from .ingest import describe_recording as describe_recording
from .ingest import ingest as ingest
from .store import StoreWriter as StoreWriter
from .store import TactileFile as TactileFile
from .store import Trial as Trial
from .store import open_file as open_file
from .store import read_events as read_events
from .store import read_events_window as read_events_window
from .store import read_signal as read_signal
from .store import summarize as summarize
from .store import validate_file as validate_file

#: The main verbs of every chain and method, by the module that defines them.
_VERBS = {
    # the event-camera chain (paper 000)
    "simulate_marker_events": "scene.marker_events",
    "accumulate_file": "events.recording",
    "estimate_slip_rates": "spatial.slip_rate",
    "slip_rate_report": "spatial.pipeline",
    "write_frames": "spatial.pipeline",
    "write_centroid_file": "spatial.stream",
    "synthesize": "synth",
    # the accelerometer-fingertip chain (paper 001)
    "simulate_vibro_slip": "accel.simulate",
    "prepare_file": "accel.prepare",
    "detection_delay": "accel.delay",
    # the active-vibration chain (paper 003)
    "simulate_vibrotouch": "vibro.simulate",
    "model_spectra": "vibro.model",
    "model_file": "vibro.pipeline",
    "detect_contacts": "vibro.pipeline",
    "detect_contact_file": "vibro.pipeline",
    "find_band": "vibro.pipeline",
    "follow_input": "vibro.stream",
    # the taxel-array chain (paper 004)
    "simulate_taxel_slip": "taxel.simulate",
    "slip_interface": "taxel.pipeline",
    "slip_interface_file": "taxel.pipeline",
    "write_taxel_features": "taxel.pipeline",
    # the visuotactile chain (paper 002)
    "simulate_digit_press": "visuotactile.simulate",
    "simulate_digit_avoidance": "visuotactile.avoidance",
    "write_normal_labels": "visuotactile.calibrate",
    "heightmap_file": "visuotactile.heightmap",
    "slip_signal_file": "visuotactile.slip",
    "monitor_input": "visuotactile.monitor_replay",
    # features of any multichannel stream
    "write_stream_features": "spectral.stream_features",
    # methods any stream enters
    "fit_fos_file": "fos.fit_file",
    "fit_files": "fos.fit_files",
    "grade_trials": "grade.grading",
    "grade_files": "grade.pipeline",
    "train_run": "learn.pipeline",
    "evaluate_run": "learn.pipeline",
    "compare": "learn.compare",
    "compare_runs": "learn.compare",
    "export_run": "learn.export",
    "perturb_evaluate": "learn.perturb",
    "perturb_runs": "learn.perturb",
    "run_sweep": "learn.sweep",
    "seed_spread": "learn.seed_spread",
    "evaluate_spread": "learn.spread_eval",
    "build_report": "learn.report",
    "quicklook": "plots.quicklook",
    "write_quicklook": "plots.quicklook",
}


def __getattr__(name: str) -> Any:
    if name in _VERBS:
        value = getattr(importlib.import_module(f".{_VERBS[name]}", __name__), name)
        globals()[name] = value
        return value
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted([*globals(), *_VERBS])
