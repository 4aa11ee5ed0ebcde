"""Repeated and out-of-order time stamps: the policies of a mapping's ``time.stamps``
(refuse, drop_repeats, keep_last, spread), with exact resulting times and counts, the note
and the stream attributes that report them, and the real fabric set that needed them."""

from __future__ import annotations

import json
from pathlib import Path

import h5py
import numpy as np
import pytest
import yaml
from typer.testing import CliRunner

from tactile_cli.cli import app
from tactile_cli.errors import InputError
from tactile_cli.ingest import ingest
from tactile_cli.ingest.stamps import StampError, settle_stamps, stamp_stats
from tactile_cli.store import validate_file

from ..conftest import shared_path

runner = CliRunner()

#: 0, 1, 1 (repeated), 2, 1.5 (out of order), 3
T = np.array([0.0, 1.0, 1.0, 2.0, 1.5, 3.0])


def test_stats_count_repeated_and_out_of_order_stamps():
    st = stamp_stats(T)
    assert (st.n, st.n_repeated, st.n_out_of_order) == (6, 1, 1)
    assert (st.first_repeated, st.first_out_of_order) == (2, 4)
    assert st.rate_hz == 1.0  # 1 / the median positive interval
    assert st.jitter_s == pytest.approx(np.std(np.diff(T)))
    clean = stamp_stats(np.arange(5) / 30)
    assert (clean.n_late, clean.first_repeated, clean.jitter_s) == (0, None, 0.0)
    assert stamp_stats(np.array([4.0])).rate_hz is None


@pytest.mark.parametrize(("policy", "keep", "t"), [
    ("drop_repeats", [0, 1, 3, 5], [0, 1, 2, 3]),
    ("keep_last", [0, 2, 4, 5], [0, 1, 2, 3]),
    ("spread", None, [0, 1, 1.5, 2, 2.5, 3]),
])
def test_each_policy_gives_exact_increasing_times(policy, keep, t):
    got = settle_stamps(T, policy)
    assert (got.n_repeated, got.n_out_of_order) == (1, 1)
    assert (None if got.keep is None else got.keep.tolist()) == keep
    assert got.t.tolist() == t
    assert got.n_dropped == (0 if keep is None else 2)
    assert np.all(np.diff(got.t) > 0)


def test_refuse_and_the_edges_of_spread():
    with pytest.raises(StampError, match="1 repeated and 1 out-of-order"):
        settle_stamps(T, "refuse")
    same = settle_stamps(np.array([0.0, 1.0]), "refuse")
    assert same.keep is None and same.t.tolist() == [0.0, 1.0] and same.n_dropped == 0
    # the last group spreads over the interval before it (the fabric logger's last stamp)
    assert settle_stamps(np.array([0.0, 28.0, 56.0, 56.0]), "spread").t.tolist() == \
        [0.0, 28.0, 56.0, 70.0]
    # one stamp for every sample: only a given interval can spread them
    assert settle_stamps(np.full(4, 5.0), "spread", last_interval=2.0).t.tolist() == \
        [5.0, 5.5, 6.0, 6.5]
    with pytest.raises(StampError, match="no interval to spread"):
        settle_stamps(np.full(4, 5.0), "spread")


# -- through a mapping ---------------------------------------------------------------------------
def _recording(root: Path, policy: str | None, *, a_rows: str) -> Path:
    """Two trials: a.csv (``a_rows``, time t in s, value v, phase a/b) and a clean b.csv;
    returns the mapping, with ``time.stamps: policy`` unless policy is None."""
    root.mkdir(parents=True, exist_ok=True)
    (root / "a.csv").write_text("t,v,phase\n" + a_rows)
    (root / "b.csv").write_text("t,v,phase\n0,1,a\n1,2,a\n2,3,b\n")
    time = {"column": "t", "unit": "s"}
    if policy is not None:
        time["stamps"] = policy
    mapping = {"version": 1, "trials": {"layout": "file", "glob": "*.csv"},
               "streams": [{"name": "s", "file": "{stem}.csv", "kind": "pressure",
                            "channels": ["v"], "units": "kPa", "time": time,
                            "sample_labels": [{"name": "phase", "column": "phase",
                                               "classes": ["a", "b"]}]}]}
    path = root.parent / "map.yaml"
    path.write_text(yaml.safe_dump(mapping, sort_keys=False))
    return path


REPEATED = "0,10,a\n1,11,a\n1,12,b\n2,13,b\n"
BACKWARDS = "0,10,a\n2,11,a\n1,12,b\n3,13,b\n"


@pytest.mark.parametrize(("policy", "rows", "t_s", "v", "phase", "counts"), [
    ("drop_repeats", REPEATED, [0, 1, 2], [10, 11, 13], [0, 0, 1], (1, 0, 1)),
    ("keep_last", REPEATED, [0, 1, 2], [10, 12, 13], [0, 1, 1], (1, 0, 1)),
    ("spread", REPEATED, [0, 1, 1.5, 2], [10, 11, 12, 13], [0, 0, 1, 1], (1, 0, 0)),
    ("drop_repeats", BACKWARDS, [0, 2, 3], [10, 11, 13], [0, 0, 1], (0, 1, 1)),
    ("keep_last", BACKWARDS, [0, 2, 3], [10, 12, 13], [0, 1, 1], (0, 1, 1)),
    ("spread", BACKWARDS, [0, 2, 2.5, 3], [10, 11, 12, 13], [0, 0, 1, 1], (0, 1, 0)),
])
def test_mapping_policy_ingests_exact_times_and_records_counts(tmp_path, policy, rows, t_s, v,
                                                              phase, counts):
    mapping = _recording(tmp_path / "raw", policy, a_rows=rows)
    notes: list[str] = []
    out = ingest([tmp_path / "raw"], tmp_path / "o.h5", options={"mapping": mapping},
                 on_note=notes.append)
    assert validate_file(out).ok
    with h5py.File(out) as f:
        a = f["trials/a/signals/s"]
        assert a["t_s"][()].tolist() == t_s
        assert a["data"][:, 0].tolist() == v
        assert a["sample_labels/phase"][()].tolist() == phase
        attrs = {k: a.attrs[k] for k in ("stamps_repeated", "stamps_out_of_order",
                                         "stamps_dropped")}
        assert tuple(int(x) for x in attrs.values()) == counts
        assert a.attrs["stamps_policy"] == policy
        b = f["trials/b/signals/s"]  # the clean trial says the policy met nothing
        assert (b.attrs["stamps_repeated"], b.attrs["stamps_out_of_order"],
                b.attrs["stamps_dropped"]) == (0, 0, 0)
        assert b["t_s"][()].tolist() == [0, 1, 2]
    what = "1 repeated" if counts[0] else "1 out of order"
    assert len(notes) == 1
    assert notes[0].startswith(f"stream 's': 1 of 2 trial(s) had repeated or out-of-order time "
                               f"stamps (a {what}); `stamps: {policy}`: ")


def test_refuse_is_the_default_and_names_the_line(tmp_path):
    mapping = _recording(tmp_path / "raw", None, a_rows=REPEATED)
    out = tmp_path / "o.h5"
    with pytest.raises(InputError) as info:
        ingest([tmp_path / "raw"], out, options={"mapping": mapping})
    assert str(info.value) == (
        f"{tmp_path / 'raw' / 'a.csv'}, line 4, column 't': time stamp 1.0 repeats the one on "
        "line 3; timestamps must increase; or give `streams.s.time.stamps` in the mapping "
        "(drop_repeats, keep_last or spread) to keep the recording")
    assert not out.exists()
    _recording(tmp_path / "raw", None, a_rows=BACKWARDS)
    with pytest.raises(InputError, match=r"a\.csv, line 4, column 't': time goes back from 2\.0 "
                                         r"\(line 3\) to 1\.0; timestamps must not decrease"):
        ingest([tmp_path / "raw"], out, options={"mapping": mapping})


def test_cli_prints_the_note_and_info_counts_before_ingest(tmp_path):
    mapping = _recording(tmp_path / "raw", None, a_rows=REPEATED)
    info = runner.invoke(app, ["info", str(tmp_path / "raw"), "--mapping", str(mapping),
                               "--json"])
    assert info.exit_code == 0, info.output
    data = json.loads(info.output)
    (stream,) = data["streams"]
    assert (stream["count"], stream["repeated_stamps"], stream["out_of_order_stamps"]) == \
        (7, 1, 0)
    assert data["notes"] == [
        "stream 's': 1 of 2 trial(s) have repeated or out-of-order time stamps: a (1 repeated, "
        "0 out of order); an ingest refuses them; give `streams.s.time.stamps` (drop_repeats, "
        "keep_last or spread) in the mapping to keep them"]
    mapping = _recording(tmp_path / "raw", "spread", a_rows=REPEATED)
    out = tmp_path / "o.h5"
    result = runner.invoke(app, ["ingest", str(tmp_path / "raw"), "--mapping", str(mapping),
                                 "--out", str(out), "--no-progress"])
    assert result.exit_code == 0, result.output
    assert result.stderr.strip().splitlines() == [
        "tactile: note: stream 's': 1 of 2 trial(s) had repeated or out-of-order time stamps (a "
        "1 repeated); `stamps: spread`: every sample kept, spread evenly between neighbouring "
        "stamps (each trial records them in the stream attributes stamps_repeated, "
        "stamps_out_of_order, stamps_dropped)"]


@pytest.mark.parametrize(("time", "message"), [
    ({"sample_rate_hz": 10, "stamps": "spread"},
     "`file`, `epoch`, `scale_s` and `stamps` describe a time `column`; give `column` too"),
    ({"column": "t", "stamps": "sort"}, "Input should be 'refuse', 'drop_repeats', 'keep_last' "
                                        "or 'spread'"),
])
def test_a_policy_belongs_to_a_time_column(tmp_path, time, message):
    mapping = _recording(tmp_path / "raw", None, a_rows=REPEATED)
    doc = yaml.safe_load(mapping.read_text())
    doc["streams"][0]["time"] = time
    mapping.write_text(yaml.safe_dump(doc))
    with pytest.raises(InputError, match=message.replace("(", r"\(").replace(")", r"\)")):
        ingest([tmp_path / "raw"], tmp_path / "o.h5", options={"mapping": mapping})


def test_real_fabric_files_with_one_repeated_stamp(tmp_path):
    """Two files of the fabric set repeat their last millisecond stamp once (a logger at
    28 ms steps); the default refuses them, naming the line; drop_repeats keeps both trials
    with one sample fewer and says so."""
    root = shared_path("fabric_slide")
    files = [root / "BeigeCotton_F120_V20mmps_0.csv", root / "WovenFabric_F150_V-120mmps_0.csv",
             root / "BeigeCotton_F120_V120mmps_1.csv"]
    doc = {"version": 1, "trials": {"layout": "file", "glob": "*.csv"},
           "streams": [{"name": "fingertip", "file": "{stem}.csv", "kind": "taxel_array",
                        "channels": ["channel*"], "units": "counts",
                        "time": {"column": "timestamp", "unit": "ms"}}]}
    mapping = tmp_path / "fabric.yaml"
    mapping.write_text(yaml.safe_dump(doc))
    with pytest.raises(InputError, match=r"BeigeCotton_F120_V20mmps_0\.csv, line 1061, column "
                                         r"'timestamp': time stamp 4087248\.0 repeats"):
        ingest(files, tmp_path / "refused.h5", options={"mapping": mapping})
    doc["streams"][0]["time"]["stamps"] = "drop_repeats"
    mapping.write_text(yaml.safe_dump(doc))
    notes: list[str] = []
    out = ingest(files, tmp_path / "fabric.h5", options={"mapping": mapping},
                 on_note=notes.append)
    assert notes == [
        "left out: BeigeCotton_F120_V20mmps_0.csv: 2 column(s) no stream reads: proximity1, "
        "proximity2 (read in the first trial's files; every trial's share their columns)",
        "stream 'fingertip': 2 of 3 trial(s) had repeated or out-of-order time stamps "
        "(BeigeCotton_F120_V20mmps_0 1 repeated, WovenFabric_F150_V-120mmps_0 1 repeated); "
        "`stamps: drop_repeats`: 2 sample(s) dropped, the first of each stamp kept (each trial "
        "records them in the stream attributes stamps_repeated, stamps_out_of_order, "
        "stamps_dropped)"]
    with h5py.File(out) as f:
        sig = f["trials/BeigeCotton_F120_V20mmps_0/signals/fingertip"]
        assert sig["data"].shape == (1059, 16) and sig.attrs["stamps_repeated"] == 1
        assert np.all(np.diff(sig["t_s"][()]) > 0)
        assert f["trials/WovenFabric_F150_V-120mmps_0/signals/fingertip/data"].shape == (177, 16)
        assert f.attrs["columns_left_out"] == ("BeigeCotton_F120_V20mmps_0.csv: 2 column(s) no "
                                               "stream reads: proximity1, proximity2")


def test_shipped_fabric_mapping_keeps_the_files_with_a_repeated_stamp(tmp_path):
    """configs/fabric_slide.yaml names the policy the set needs: its two files with one
    repeated stamp ingest (the first sample of the stamp kept), with the set's labels."""
    root = shared_path("fabric_slide")
    files = [root / "BeigeCotton_F120_V20mmps_0.csv", root / "WovenFabric_F150_V-120mmps_0.csv"]
    mapping = Path(__file__).resolve().parents[2] / "configs" / "fabric_slide.yaml"
    out = ingest(files, tmp_path / "fabric.h5", options={"mapping": mapping})
    with h5py.File(out) as f:
        sig = f["trials/BeigeCotton_F120_V20_0/signals/cpm"]
        assert sig["data"].shape == (1059, 17) and sig.attrs["stamps_dropped"] == 1
        labels = f["trials/WovenFabric_F150_V-120_0/labels"].attrs
        assert (labels["fabric"], labels["force"], labels["speed"], labels["rep"]) == \
            ("WovenFabric", "150", "-120", "0")
