"""Issue 35, items 2-3 on real GelSight lifts (../shared/data/gelsight_slip): the static
check, ``--scale auto`` and the imprint retention on four lifts of two objects, ingested
as a user would (skips without the data). The whole set's figures:
benchmarks/slip_gelsight.py and benchmarks/slip_imprint_gelsight.py."""

from __future__ import annotations

import csv
from pathlib import Path

import numpy as np
import pytest

from tactile_cli.ingest import ingest
from tactile_cli.visuotactile.imprint import slip_imprint_file
from tactile_cli.visuotactile.slip import slip_signal_file
from tests.conftest import shared_path

#: (object, lift folder, slipped) from objectNNN_result.dat
LIFTS = (("object001", "067_00_mm", False), ("object001", "067_30_mm", True),
         ("object002", "065_00_mm", False), ("object002", "065_50_mm", True))


@pytest.fixture(scope="module")
def lifts_h5(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The four lifts ingested with their labels (skips without the data)."""
    tmp_path = tmp_path_factory.mktemp("lifts")
    root = shared_path("gelsight_slip")
    for obj, lift, slipped in LIFTS:  # the labels are the .dat files' own
        key = lift.removesuffix("_mm")
        outcome = next(line.split()[1] for line in
                       (root / f"{obj}_result.dat").read_text().splitlines()
                       if line.split() and line.split()[6] == key)
        assert (outcome in ("fail", "slip")) == slipped
    labels = tmp_path / "labels.csv"
    with open(labels, "w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(["trial", "object", "slip", "slip_onset_s"])
        w.writerows([lift, obj, "slip" if s else "no_slip", 0.0 if s else ""]
                    for obj, lift, s in LIFTS)
    return ingest([root / obj / lift for obj, lift, _ in LIFTS], tmp_path / "lifts.h5",
                  options={"reference": "first"}, trial_labels=labels)


@pytest.mark.slow
def test_real_lifts_static_start_and_scale_auto(lifts_h5: Path) -> None:
    res = slip_signal_file(lifts_h5, source="intensity", n_static=3, scale="auto")
    assert len(res.trials) == 4
    # the first frames of these lifts are static (camera noise of about 200 summed colour
    # units, spread under 0.2): the false alarms come from the lift's own motion later
    for t in res.trials:
        st = t.detection.static
        assert st is not None and st.static and st.spread is not None and st.spread < 0.2
        assert 150 < np.mean(t.detection.signal[1:4]) < 300
        assert t.detection.peak_ratio() > 4  # every lift moves: held ones too
    cv = res.scale_cv["intensity"]
    assert cv.group_by == "object" and [f.group for f in cv.folds] == ["object001",
                                                                       "object002"]
    assert cv.rates.n_slip + cv.rates.n_no_slip == 4
    lo, hi = cv.accuracy_interval
    assert 0 <= lo <= cv.rates.accuracy <= hi <= 1


@pytest.mark.slow
def test_real_lifts_imprint_kept_when_held_and_lost_when_slipped(lifts_h5: Path) -> None:
    """``tactile slip-imprint`` on the same four lifts: the held lifts keep their grasp
    imprint (change under 0.01), the slipped ones lose it (over 0.04), so the threshold
    learned on one object decides the other's two lifts right (issue 35; the 20-lift
    figures: benchmarks/slip_imprint_gelsight.py)."""
    res = slip_imprint_file(lifts_h5)
    change = {t.trial: t.imprint.change for t in res.trials}
    for _, lift, slipped in LIFTS:
        assert (change[lift] > 0.04) if slipped else (change[lift] < 0.01), (lift, change)
    cv = res.threshold_cv
    assert cv is not None and cv.group_by == "object" and cv.correct == 4
    assert all(0.01 < f.threshold < 0.04 for f in cv.folds)
