"""Robot recordings (ROS 1 bags, ROS 2 bags with sqlite3 and mcap storage, standalone MCAP)
written by the real writers, described by `tactile info` and ingested through a topic mapping,
every value and time compared with the messages that went in."""

from __future__ import annotations

import json
from pathlib import Path

import h5py
import numpy as np
import pytest
from typer.testing import CliRunner

from tactile_cli.cli import app
from tactile_cli.errors import InputError
from tactile_cli.ingest import describe_recording, ingest
from tactile_cli.store import validate_file
from tests.factories.robot_recordings import (
    CUSTOM_TYPE,
    HEADER_LAG_NS,
    T0_NS,
    rig_messages,
    typestore,
    write_mcap,
    write_mcap_without_definition,
    write_ros1_bag,
    write_ros2_bag,
)

runner = CliRunner()
KINDS = ("ros1", "ros2-sqlite3", "ros2-mcap", "mcap")

MAPPING = """\
version: 1
time: header
trials:
  marker: {topic: /trial}
  labels: {origin: recorded, dataset: rig_test}
streams:
  - {topic: /digit/image_raw, name: digit, kind: visuotactile, reference: 1}
  - {topic: /taxels, name: taxels, kind: taxel_array, units: kPa}
  - {topic: /ft, name: wrench, kind: force_torque, serial: FT123, calibration: cal.txt}
  - {topic: /pad, name: pad, kind: pressure, fields: ["taxels[*].z", temperature], time: log}
"""


@pytest.fixture(scope="module")
def recordings(tmp_path_factory) -> dict[str, tuple[Path, object]]:
    root = tmp_path_factory.mktemp("robot")
    s1, s2 = typestore(True), typestore(False)
    r1 = rig_messages(s1, ros1=True, events=True)
    r2 = rig_messages(s2, ros1=False)
    return {"ros1": (write_ros1_bag(root / "rig.bag", r1, s1), r1),
            "ros2-sqlite3": (write_ros2_bag(root / "rig_sqlite", r2, s2), r2),
            "ros2-mcap": (write_ros2_bag(root / "rig_mcapbag", r2, s2, storage="mcap"), r2),
            "mcap": (write_mcap(root / "rig.mcap", r2, s2), r2)}


@pytest.fixture()
def mapping(tmp_path) -> Path:
    (tmp_path / "cal.txt").write_text("gain: 1.5\n")
    path = tmp_path / "topics.yaml"
    path.write_text(MAPPING)
    return path


@pytest.mark.parametrize("kind", KINDS)
def test_info_lists_every_topic_with_counts_rates_and_bytes(recordings, kind):
    path, rig = recordings[kind]
    result = runner.invoke(app, ["info", str(path), "--json"])
    assert result.exit_code == 0, result.output
    data = json.loads(result.output)
    assert data["format"] == ("mcap" if kind == "mcap" else "rosbag")
    streams = {s["topic"]: s for s in data["streams"]}
    assert set(streams) == set(rig.topics)
    for topic, (msgtype, msgs) in rig.topics.items():
        assert streams[topic]["count"] == len(msgs)
        assert streams[topic]["message_type"] == msgtype
        assert streams[topic]["size_bytes"] > 0
        assert streams[topic]["t_first_s"] == pytest.approx(msgs[0][0] / 1e9, abs=1e-6)
        assert streams[topic]["span_s"] == pytest.approx((msgs[-1][0] - msgs[0][0]) / 1e9)
    assert streams["/taxels"]["rate_hz"] == pytest.approx(100.0)
    assert streams["/taxels"]["jitter_s"] == 0.0
    assert streams["/digit/image_raw"]["rate_hz"] == pytest.approx(12.5)
    assert streams["/pad"]["type"] == "tactile_rig/TaxelPad"


def test_info_with_mapping_names_streams_trials_and_topics_left_out(recordings, mapping):
    path, _ = recordings["ros1"]
    summary = describe_recording(path, options={"mapping": mapping})
    assert [t.name for t in summary.trials] == ["press_a", "rig_2"]
    assert summary.trials[0].duration_s == pytest.approx(0.15)
    assert summary.trials[0].counts["taxels"] == 15  # log times 0.05 .. 0.19 s
    assert summary.dropped == ["topic /dvs/events (dvs_msgs/EventArray, 5 messages): not in the "
                               "mapping"]


@pytest.mark.parametrize("block_bytes", [None, 64], ids=["one-piece", "2-row-blocks"])
@pytest.mark.parametrize("kind", KINDS)
def test_ingest_round_trips_every_value_and_stamp(recordings, mapping, tmp_path, kind,
                                                  block_bytes, monkeypatch):
    """Also with sampled streams written in blocks of 2-3 rows (as a long trial is, in
    blocks of 256 KiB of values): the same values and stamps."""
    if block_bytes is not None:
        from tactile_cli.ingest import robot_bag

        monkeypatch.setattr(robot_bag, "SIGNAL_CHUNK_BYTES", block_bytes)
    path, rig = recordings[kind]
    notes: list[str] = []
    out = ingest([path], tmp_path / "o.h5", options={"mapping": mapping}, on_note=notes.append)
    assert validate_file(out).ok
    taxel_log = np.array([t for t, _ in rig.topics["/taxels"][1]])
    ft_log = np.array([t for t, _ in rig.topics["/ft"][1]])
    img_log = np.array([t for t, _ in rig.topics["/digit/image_raw"][1]])
    pad_log = np.array([t for t, _ in rig.topics["/pad"][1]])
    with h5py.File(out) as h5:
        assert list(h5["trials"]) == ["press_a", _stem(path) + "_2"]
        for name, (start, end) in zip(h5["trials"], [(50, 200), (250, 450)], strict=True):
            t0, t1 = T0_NS + start * 1_000_000, T0_NS + end * 1_000_000
            trial = h5["trials"][name]
            assert trial.attrs["time_origin_unix_s"] == t0 / 1e9
            assert dict(trial["labels"].attrs) == {"origin": "recorded", "dataset": "rig_test"}
            # taxels: no header, so log times; values exact (float32 in, float32 out)
            sel = (taxel_log >= t0) & (taxel_log < t1)
            sig = trial["signals/taxels"]
            np.testing.assert_array_equal(sig["data"][:], rig.taxels[sel])
            np.testing.assert_array_equal(sig["t_s"][:], (taxel_log[sel] - t0) / 1e9)
            # wrench: header stamps (log - 2 ms), in N and N m
            hdr = ft_log - HEADER_LAG_NS
            sel = (hdr >= t0) & (hdr < t1)
            np.testing.assert_array_equal(trial["signals/wrench/data"][:],
                                          rig.wrench[sel].astype(np.float32))
            np.testing.assert_array_equal(trial["signals/wrench/t_s"][:], (hdr[sel] - t0) / 1e9)
            # the custom type by field paths, log time as the mapping says
            sel = (pad_log >= t0) & (pad_log < t1)
            expect = np.column_stack([rig.custom[sel][:, :, 2],
                                      30 + np.flatnonzero(sel).astype(np.float32)])
            np.testing.assert_array_equal(trial["signals/pad/data"][:], expect.astype(np.float32))
            # frames: header stamps, reference = frame 1 of the trial, kept in the sequence
            hdr = img_log - HEADER_LAG_NS
            sel = (hdr >= t0) & (hdr < t1)
            np.testing.assert_array_equal(trial["frames/images"][:], rig.frames[sel])
            np.testing.assert_array_equal(trial["frames/t_s"][:], (hdr[sel] - t0) / 1e9)
            np.testing.assert_array_equal(trial["frames/reference"][:], rig.frames[sel][1])
            assert trial.attrs["topics_left_out"] == (  # the marker topic is not left out
                "/dvs/events (dvs_msgs/EventArray, 5 messages)" if kind == "ros1" else "none")
        wrench = h5["sensors/wrench"]
        assert list(wrench["channel_names"].asstr()[:]) == [
            "force_x", "force_y", "force_z", "torque_x", "torque_y", "torque_z"]
        assert list(wrench["channel_units"].asstr()[:]) == ["N"] * 3 + ["N m"] * 3
        assert wrench.attrs["serial"] == "FT123"
        assert wrench.attrs["frame_id"] == "ft_link"
        assert wrench.attrs["calibration_text"] == "gain: 1.5\n"
        assert wrench.attrs["sample_rate_hz"] == 100.0
        assert wrench.attrs["gaps"] == 0
        taxels = h5["sensors/taxels"]
        assert list(taxels["channel_names"].asstr()[:]) == [
            "row0_col0", "row0_col1", "row0_col2", "row1_col0", "row1_col1", "row1_col2"]
        assert list(taxels["channel_units"].asstr()[:]) == ["kPa"] * 6
        assert list(h5["sensors/pad/channel_names"].asstr()[:]) == [
            "taxels[0].z", "taxels[1].z", "taxels[2].z", "taxels[3].z", "temperature"]
        assert h5["sensors/digit"].attrs["frame_id"] == "digit_DG123"
        assert (h5["sensors/digit"].attrs["width_px"], h5["sensors/digit"].attrs["height_px"]) \
            == (8, 6)
    assert any(n.startswith("wrench (/ft): 35 samples, 100 Hz median") for n in notes)
    assert any("taxels (/taxels): 15 message(s) outside every trial" in n for n in notes)


def _stem(path: Path) -> str:
    return path.name if path.is_dir() else path.stem


def test_events_from_a_ros1_event_array_are_exact(recordings, tmp_path):
    path, rig = recordings["ros1"]
    mapping = tmp_path / "m.yaml"
    mapping.write_text("streams:\n  - {topic: /dvs/events, name: dvs, kind: event_camera}\n"
                       "  - {topic: /taxels, name: taxels, kind: taxel_array}\n")
    out = ingest([path], tmp_path / "e.h5", options={"mapping": mapping})
    events = [e for _, m in rig.topics["/dvs/events"][1] for e in m.events]
    with h5py.File(out) as h5:
        ev = h5["trials/rig/events"]
        np.testing.assert_array_equal(ev["x"][:], [e.x for e in events])
        np.testing.assert_array_equal(ev["y"][:], [e.y for e in events])
        np.testing.assert_array_equal(
            ev["t"][:], [(e.ts.sec * 10**9 + e.ts.nanosec) // 1000 for e in events])
        np.testing.assert_array_equal(ev["p"][:], [1 if e.polarity else -1 for e in events])
        assert ev.attrs["t_origin_us"] == T0_NS // 1000
        assert (h5["sensors/dvs"].attrs["width_px"], h5["sensors/dvs"].attrs["height_px"]) \
            == (32, 24)
        # one trial: the whole recording, every taxel message in it
        assert h5["trials/rig/signals/taxels/data"].shape == (50, 6)
        assert "/trial (std_msgs/String, 4 messages)" in h5["trials/rig"].attrs["topics_left_out"]


def test_trials_from_a_csv_of_time_ranges(recordings, tmp_path):
    path, rig = recordings["mcap"]
    mapping = tmp_path / "m.yaml"
    mapping.write_text("streams:\n  - {topic: /taxels, name: taxels, kind: taxel_array}\n")
    ranges = tmp_path / "trials.csv"
    ranges.write_text("start_s,end_s,trial,object\n0.0,0.1,touch_1,ball\n0.3,0.35,touch_2,cube\n")
    out = ingest([path], tmp_path / "c.h5", options={"mapping": mapping, "trials_from": ranges})
    with h5py.File(out) as h5:
        assert list(h5["trials"]) == ["touch_1", "touch_2"]
        np.testing.assert_array_equal(h5["trials/touch_1/signals/taxels/data"][:], rig.taxels[:10])
        np.testing.assert_array_equal(h5["trials/touch_2/signals/taxels/data"][:],
                                      rig.taxels[30:35])
        assert h5["trials/touch_2/labels"].attrs["object"] == "cube"


# -- errors: one line, exit 2, nothing written ---------------------------------------------
def _refuse(args: list[str], out: Path) -> str:
    result = runner.invoke(app, args)
    assert result.exit_code == 2, result.output
    assert not out.exists()
    lines = result.output.strip().splitlines()
    assert len(lines) == 1, result.output
    return lines[0]


def test_a_topic_the_recording_lacks_lists_its_topics(recordings, tmp_path):
    path, _ = recordings["ros2-sqlite3"]
    mapping = tmp_path / "m.yaml"
    mapping.write_text("streams:\n  - {topic: /gelsight, name: gs, kind: visuotactile}\n")
    out = tmp_path / "o.h5"
    line = _refuse(["ingest", str(path), "--mapping", str(mapping), "--out", str(out)], out)
    assert line == (f"tactile: error: {mapping}: the mapping names topic /gelsight, which the "
                    f"recording {path} lacks; its topics: /digit/image_raw, /ft, /pad, /taxels, "
                    "/trial")


def test_a_field_path_that_does_not_exist(recordings, tmp_path):
    path, _ = recordings["ros1"]
    mapping = tmp_path / "m.yaml"
    mapping.write_text("streams:\n  - {topic: /pad, name: p, kind: pressure, "
                       "fields: ['taxels[*].w']}\n")
    out = tmp_path / "o.h5"
    line = _refuse(["ingest", str(path), "--mapping", str(mapping), "--out", str(out)], out)
    assert line == (f"tactile: error: {path}: field path 'taxels[*].w' of topic /pad: "
                    "geometry_msgs/Vector3 has no field 'w' (its fields: x, y, z)")


def test_a_wrong_kind_for_the_message_type(recordings, tmp_path):
    path, _ = recordings["mcap"]
    mapping = tmp_path / "m.yaml"
    mapping.write_text("streams:\n  - {topic: /ft, name: ft, kind: visuotactile}\n")
    with pytest.raises(InputError, match="topic /ft holds geometry_msgs/WrenchStamped, not "
                       "images"):
        ingest([path], tmp_path / "o.h5", options={"mapping": mapping})


def test_a_mapping_key_error_names_the_key_and_line(recordings, tmp_path):
    path, _ = recordings["mcap"]
    mapping = tmp_path / "m.yaml"
    mapping.write_text("streams:\n  - topic: /ft\n    name: ft\n    kind: force\n")
    out = tmp_path / "o.h5"
    line = _refuse(["ingest", str(path), "--mapping", str(mapping), "--out", str(out)], out)
    assert line.startswith(f"tactile: error: {mapping}, line 4: `streams.0.kind`: unknown sensor "
                           "kind 'force'; use one of: event_camera,")


def test_a_message_type_without_a_definition(tmp_path):
    path = write_mcap_without_definition(tmp_path / "nodef.mcap")
    mapping = tmp_path / "m.yaml"
    mapping.write_text("streams:\n  - {topic: /pad, name: p, kind: pressure}\n")
    out = tmp_path / "o.h5"
    line = _refuse(["ingest", str(path), "--mapping", str(mapping), "--out", str(out)], out)
    assert line == (f"tactile: error: {path}: message type {CUSTOM_TYPE} (topic /pad) has no "
                    "definition in the recording and is not a standard ROS type; record with "
                    "the definitions stored (ros2 bag record does; rosbags needs `msgdef=`) or "
                    "leave the topic out of the mapping")
    # info still lists it, marked unreadable
    summary = describe_recording(path)
    assert [(s.name, s.readable) for s in summary.streams] == [("/pad", False)]


@pytest.mark.parametrize("kind", ["ros1", "mcap"])
def test_a_recording_cut_short_is_one_line(recordings, tmp_path, kind):
    path, _ = recordings[kind]
    cut = tmp_path / f"cut{path.suffix}"
    data = path.read_bytes()
    cut.write_bytes(data[:len(data) * 2 // 3])
    mapping = tmp_path / "m.yaml"
    mapping.write_text("streams:\n  - {topic: /taxels, name: t, kind: taxel_array}\n")
    out = tmp_path / "o.h5"
    line = _refuse(["ingest", str(cut), "--mapping", str(mapping), "--out", str(out)], out)
    assert line.startswith(f"tactile: error: {cut}: ")
    assert "the file is damaged or was cut short" in line or "no summary section" in line
    info = runner.invoke(app, ["info", str(cut)])
    assert info.exit_code == 2 and len(info.output.strip().splitlines()) == 1


def test_ingest_without_a_mapping_says_how(recordings, tmp_path):
    path, _ = recordings["ros1"]
    out = tmp_path / "o.h5"
    line = _refuse(["ingest", str(path), "--out", str(out)], out)
    assert line.startswith(f"tactile: error: {path}: a robot recording needs a topic mapping to "
                           "be ingested: pass --mapping topics.yaml")


def test_trials_from_flag_reaches_the_cli(recordings, tmp_path):
    path, rig = recordings["ros2-mcap"]
    mapping = tmp_path / "m.yaml"
    mapping.write_text("streams:\n  - {topic: /taxels, name: taxels, kind: taxel_array}\n")
    ranges = tmp_path / "trials.csv"
    ranges.write_text("start_s,end_s\n0.1,0.2\n")
    out = tmp_path / "o.h5"
    result = runner.invoke(app, ["ingest", str(path), "--mapping", str(mapping), "--trials-from",
                                 str(ranges), "--out", str(out), "--no-progress"])
    assert result.exit_code == 0, result.output
    with h5py.File(out) as h5:
        assert list(h5["trials"]) == ["rig_mcapbag_1"]
        np.testing.assert_array_equal(h5["trials/rig_mcapbag_1/signals/taxels/data"][:],
                                      rig.taxels[10:20])


def test_a_missing_optional_reader_says_which_extra_to_install():
    from tactile_cli.ingest.robot_recording import require_robot_extra

    with pytest.raises(InputError) as exc:
        require_robot_extra("ROS bags", ("rosbags", "no_such_reader_module"))
    assert str(exc.value) == ("reading ROS bags needs no_such_reader_module, which is not "
                              "installed; install the robot extra: pip install "
                              "'tactile-cli[robot]'")


def test_a_corrupt_mcap_chunk_is_one_line(recordings, tmp_path):
    from mcap.reader import make_reader

    path, _ = recordings["mcap"]
    with open(path, "rb") as f:
        chunk = make_reader(f).get_summary().chunk_indexes[0]
    data = bytearray(path.read_bytes())
    data[chunk.chunk_start_offset + chunk.chunk_length - 16] ^= 0xFF  # inside its records
    bad = tmp_path / "bad.mcap"
    bad.write_bytes(bytes(data))
    mapping = tmp_path / "m.yaml"
    mapping.write_text("streams:\n  - {topic: /taxels, name: t, kind: taxel_array}\n")
    out = tmp_path / "o.h5"
    line = _refuse(["ingest", str(bad), "--mapping", str(mapping), "--out", str(out)], out)
    assert line.startswith(f"tactile: error: {bad}: cannot read the recording (")
    assert line.endswith("the file is damaged or was cut short (a recorder killed before it "
                         "closed the file): re-index it (`rosbag reindex`, `ros2 bag reindex`, "
                         "`mcap recover`) or record it again")
