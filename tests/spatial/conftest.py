"""Fixtures of the spatial tests; the factories are in :mod:`tests.factories.strip_events`."""

from __future__ import annotations

from pathlib import Path

import pytest

from ..factories.strip_events import make_strip_events, write_trials


@pytest.fixture(scope="module")
def strip_file(tmp_path_factory) -> Path:
    """Three trials at 0.002, 0.004 (the paper's) and 0.006 m/s; one with a camera clock
    that does not start at 0."""
    speeds = {"slow": (0.002, 0), "paper": (0.004, 7_000_000), "fast": (0.006, 0)}
    trials = {name: make_strip_events(slip_speed_m_s=v, origin_us=o, seed=i)
              for i, (name, (v, o)) in enumerate(speeds.items())}
    return write_trials(tmp_path_factory.mktemp("spatial") / "strips.h5", trials)
