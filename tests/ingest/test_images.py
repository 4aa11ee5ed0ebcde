"""Image-sequence folders (visuotactile frames + no-contact reference) through `tactile ingest`."""

from __future__ import annotations

import re

import h5py
import numpy as np
import pytest
from PIL import Image
from typer.testing import CliRunner

from tactile_cli.cli import app
from tactile_cli.errors import InputError
from tactile_cli.ingest import image_sequence, ingest
from tactile_cli.ingest.image_sequence import (
    DEFAULT_FRAME_RATE_HZ,
    load_rgb,
    scan_image_folder,
)
from tactile_cli.natural import natural_key
from tactile_cli.samples.images import write_image_sequence
from tactile_cli.store import StoreWriter, validate_file
from tactile_cli.store.provenance import sha256_of

runner = CliRunner()
W, H = 20, 14  # tiny frames keep the suite fast; DIGIT's are 320 x 240


def _seq(folder, n=5, **kw):
    return write_image_sequence(folder, n_frames=n, width=kw.pop("width", W),
                                height=kw.pop("height", H), seed=kw.pop("seed", 0), **kw)


class RecordingProgress:
    def __init__(self):
        self.total, self.done, self.finished = None, 0, False

    def start(self, total, description):
        self.total = total

    def advance(self, amount=1):
        self.done += amount

    def finish(self):
        self.finished = True


def test_png_round_trip_is_exact_with_sources_and_progress(tmp_path):
    a = _seq(tmp_path / "press_a", n=12, seed=1)
    b = _seq(tmp_path / "press_b", n=3, seed=2)
    progress = RecordingProgress()
    out = ingest([tmp_path / "press_a", tmp_path / "press_b"], tmp_path / "o.h5",
                 labels={"object": "ball"}, progress=progress)
    assert validate_file(out).ok
    assert (progress.total, progress.done, progress.finished) == (15, 15, True)
    with h5py.File(out) as h5:
        sensor = h5["sensors/visuotactile"].attrs
        assert sensor["kind"] == "visuotactile"
        assert (sensor["width_px"], sensor["height_px"]) == (W, H)
        assert sensor["sample_rate_hz"] == DEFAULT_FRAME_RATE_HZ
        assert sorted(h5["trials"]) == ["press_a", "press_b"]
        paths = list(h5["provenance/sources/path"].asstr()[:])
        shas = list(h5["provenance/sources/sha256"].asstr()[:])
        for name, truth in (("press_a", a), ("press_b", b)):
            trial = h5["trials"][name]
            frames = trial["frames"]
            assert frames.attrs["sensor"] == "visuotactile"
            assert frames["images"].dtype == np.uint8
            np.testing.assert_array_equal(frames["images"][()], truth["images"])
            np.testing.assert_array_equal(frames["reference"][()], truth["reference"])
            np.testing.assert_allclose(frames["t_s"][()], truth["t_s"], rtol=0, atol=0)
            assert trial.attrs["frame_rate_assumed_hz"] == 30.0
            assert trial.attrs["duration_s"] == pytest.approx(truth["t_s"][-1])
            assert trial["labels"].attrs["object"] == "ball"
            # source_index: the frames in order, then the reference
            files = [*truth["frame_files"], truth["reference_file"]]
            idx = trial.attrs["source_index"]
            assert [paths[i] for i in idx] == [str(f) for f in files]
            assert [shas[i] for i in idx] == [sha256_of(f) for f in files]


def test_streaming_batches_cross_boundaries_exactly(tmp_path, monkeypatch):
    # 3 frames per write: 10 frames need batches 3+3+3+1
    monkeypatch.setattr(image_sequence, "FRAME_BATCH_BYTES", 3 * W * H * 3)
    truth = _seq(tmp_path / "long", n=10, frame_rate_hz=25.0)
    out = ingest([tmp_path / "long"], tmp_path / "o.h5")
    with h5py.File(out) as h5:
        frames = h5["trials/long/frames"]
        assert frames["images"].chunks == (1, H, W, 3)
        np.testing.assert_array_equal(frames["images"][()], truth["images"])
        np.testing.assert_array_equal(frames["t_s"][()], truth["t_s"])


def test_natural_name_order(tmp_path):
    names = ["frame_10.png", "frame_2.png", "Frame_1.png", "frame_02.png", "frame_9b.png"]
    assert sorted(names, key=natural_key) == [
        "Frame_1.png", "frame_02.png", "frame_2.png", "frame_9b.png", "frame_10.png"]
    _seq(tmp_path / "seq", n=12)
    found = scan_image_folder(tmp_path / "seq")
    assert [p.name for p in found.frames] == [f"frame_{k}.png" for k in range(12)]
    assert found.reference.name == "reference.png"


@pytest.mark.parametrize("mode", ["L", "RGBA"])
def test_grayscale_and_alpha_become_rgb(tmp_path, mode):
    truth = _seq(tmp_path / "seq", n=4, mode=mode)
    with Image.open(truth["frame_files"][0]) as im:
        assert im.mode == mode
    out = ingest([tmp_path / "seq"], tmp_path / "o.h5")
    with h5py.File(out) as h5:
        images = h5["trials/seq/frames/images"][()]
        np.testing.assert_array_equal(images, truth["images"])
        np.testing.assert_array_equal(h5["trials/seq/frames/reference"][()], truth["reference"])
    if mode == "L":
        assert (images[..., 0] == images[..., 2]).all()


def test_palette_with_transparency_converts_without_warning(tmp_path):
    # warnings are errors in this suite, so Pillow's palette-transparency warning would fail
    pal = Image.new("P", (W, H), 1)
    pal.putpalette([0, 0, 0, 10, 200, 30] + [0] * 762)
    pal.info["transparency"] = 0
    pal.save(tmp_path / "p.png", transparency=0)
    rgb = load_rgb(tmp_path / "p.png")
    assert rgb.shape == (H, W, 3) and (rgb == [10, 200, 30]).all()


def test_jpg_frames_are_read_approximately(tmp_path):
    truth = _seq(tmp_path / "seq", n=3, fmt="jpg")
    out = ingest([tmp_path / "seq"], tmp_path / "o.h5")  # folder of .jpg auto-detected
    with h5py.File(out) as h5:
        images = h5["trials/seq/frames/images"][()].astype(float)
    assert images.shape == truth["images"].shape
    assert np.abs(images - truth["images"]).mean() < 6  # lossy, but the same picture


def test_timestamps_csv_one_column_is_honoured(tmp_path):
    truth = _seq(tmp_path / "seq", n=6, frame_rate_hz=60.0)
    t_s = np.array([0.0, 0.01, 0.03, 0.031, 0.05, 0.2])
    # overwrite the sample's file with uneven times, without a header row
    (tmp_path / "seq" / "timestamps.csv").write_text("\n".join(map(repr, t_s.tolist())) + "\n")
    out = ingest([tmp_path / "seq"], tmp_path / "o.h5")
    with h5py.File(out) as h5:
        trial = h5["trials/seq"]
        np.testing.assert_array_equal(trial["frames/t_s"][()], t_s)
        assert "frame_rate_assumed_hz" not in trial.attrs
        assert trial.attrs["duration_s"] == pytest.approx(0.2)
        paths = h5["provenance/sources/path"].asstr()[:]
        assert paths[trial.attrs["source_index"][-1]] == str(tmp_path / "seq" / "timestamps.csv")
    assert truth["timestamps_file"].name == "timestamps.csv"


def test_timestamps_csv_file_column_maps_by_name(tmp_path):
    _seq(tmp_path / "seq", n=11)
    rows = [f"frame_{k}.png,{k / 100!r}" for k in range(11)]
    rows.reverse()  # row order does not matter when files are named
    (tmp_path / "seq" / "timestamps.csv").write_text("file,t_s\n" + "\n".join(rows) + "\n")
    found = scan_image_folder(tmp_path / "seq")
    np.testing.assert_array_equal(found.t_s, np.arange(11) / 100)
    assert found.frame_rate_assumed_hz is None


def test_epoch_timestamps_are_rebased_with_their_origin_recorded(tmp_path):
    _seq(tmp_path / "seq", n=3)
    (tmp_path / "seq" / "timestamps.csv").write_text(
        "file,t_unix_s\nframe_0.png,1700000000.5\nframe_1.png,1700000000.75\n"
        "frame_2.png,1700000001.5\n")
    out = ingest([tmp_path / "seq"], tmp_path / "o.h5")
    assert validate_file(out).ok
    with h5py.File(out) as h5:
        trial = h5["trials/seq"]
        np.testing.assert_array_equal(trial["frames/t_s"][()], [0.0, 0.25, 1.0])
        assert trial.attrs["time_origin_unix_s"] == 1700000000.5
        assert trial.attrs["duration_s"] == 1.0


@pytest.mark.parametrize(("text", "message"), [
    ("t_s\n0\n0.1\n", r"has 2 times but the folder has 3 frames"),
    ("t_s\n0\n0.2\n0.1\n", r"frame frame_2\.png \(t_s = 0\.1\) is earlier than the frame before"),
    ("t_s\n0\nabc\n0.2\n", r"timestamps\.csv, line 3: 'abc' is not a time in seconds"),
    ("t_s\n0\nnan\n0.2\n", r"line 3: time 'nan' is not finite"),
    ("file,t_s\nframe_0.png,0\nframe_1.png,0.1\nframe_9.png,0.2\n",
     r"line 4: names 'frame_9\.png', which is not a frame"),
    ("file,t_s\nframe_0.png,0\nframe_1.png,0.1\n", r"has no time for frame\(s\) frame_2\.png"),
])
def test_bad_timestamps_are_input_errors(tmp_path, text, message):
    _seq(tmp_path / "seq", n=3)
    (tmp_path / "seq" / "timestamps.csv").write_text(text)
    with pytest.raises(InputError, match=message):
        scan_image_folder(tmp_path / "seq")


def test_missing_or_ambiguous_reference(tmp_path):
    truth = _seq(tmp_path / "seq", n=3)
    truth["reference_file"].unlink()
    with pytest.raises(InputError, match=r"seq: no reference \(no-contact\) frame found; name it "
                                         r"reference\.png \(accepted names: reference, ref, "
                                         r"background, no_contact.*, or pass "
                                         r"`reference='first'` \(the first frame is the "
                                         r"no-contact one\) or `reference=NAME`$"):
        ingest([tmp_path / "seq"], tmp_path / "o.h5")
    Image.fromarray(truth["reference"]).save(tmp_path / "seq" / "Background.png")
    Image.fromarray(truth["reference"]).save(tmp_path / "seq" / "no_contact.jpg")
    with pytest.raises(InputError, match=r"several reference frames \(Background\.png, "
                                         r"no_contact\.jpg\); keep exactly one"):
        scan_image_folder(tmp_path / "seq")
    assert not (tmp_path / "o.h5").exists()


def test_explicit_reference_file(tmp_path):
    truth = _seq(tmp_path / "seq", n=3)
    shared = tmp_path / "shared_ref.png"
    truth["reference_file"].rename(shared)
    found = scan_image_folder(tmp_path / "seq", reference=shared, frame_rate_hz=15.0)
    assert found.reference == shared and len(found.frames) == 3
    np.testing.assert_array_equal(found.t_s, np.arange(3) / 15.0)
    assert found.frame_rate_assumed_hz is None


def test_mismatched_frame_size_names_file_and_both_sizes(tmp_path):
    _seq(tmp_path / "seq", n=4)
    bad = tmp_path / "seq" / "frame_2.png"
    Image.fromarray(np.zeros((H + 1, W, 3), dtype=np.uint8)).save(bad)
    with pytest.raises(InputError) as info:
        ingest([tmp_path / "seq"], tmp_path / "o.h5")
    message = str(info.value)
    assert message.startswith(f"{bad}: image is {W}x{H + 1} px")
    assert f"{tmp_path / 'seq' / 'reference.png'} is {W}x{H} px" in message


def test_folders_of_different_sizes_are_refused(tmp_path):
    _seq(tmp_path / "a", n=2)
    _seq(tmp_path / "b", n=2, width=W + 4)
    with pytest.raises(InputError,
                       match=rf"b/reference\.png: image is {W + 4}x{H} px .* is {W}x{H}"):
        ingest([tmp_path / "a", tmp_path / "b"], tmp_path / "o.h5")


def test_width_option_must_match_the_frames(tmp_path):
    _seq(tmp_path / "seq", n=2)
    with pytest.raises(InputError, match=rf"`width_px` is 320 px but the frames are {W}x{H} px"):
        ingest([tmp_path / "seq"], tmp_path / "o.h5", options={"width_px": 320})


@pytest.mark.parametrize(("damage", "message"), [
    (lambda b: b[: len(b) // 2], "cannot decode the image .*truncated"),
    (lambda b: b"not an image at all", "is not a PNG or JPG image Pillow can read"),
])
def test_corrupt_frame_names_the_file(tmp_path, damage, message):
    _seq(tmp_path / "seq", n=4)
    bad = tmp_path / "seq" / "frame_3.png"
    bad.write_bytes(damage(bad.read_bytes()))
    with pytest.raises(InputError, match=rf"^{re.escape(str(bad))}: {message}") as info:
        ingest([tmp_path / "seq"], tmp_path / "o.h5")
    assert "\n" not in str(info.value)


def test_16_bit_and_unsupported_formats_are_refused(tmp_path):
    _seq(tmp_path / "seq", n=2)
    wide = tmp_path / "seq" / "frame_1.png"
    Image.fromarray(np.full((H, W), 40000, dtype=np.uint16)).save(wide)
    with pytest.raises(InputError, match=r"frame_1\.png: is a 16-bit or floating-point image"):
        ingest([tmp_path / "seq"], tmp_path / "o.h5")
    wide.unlink()
    Image.new("RGB", (W, H)).save(tmp_path / "seq" / "frame_5.bmp")
    with pytest.raises(InputError, match=r"frame_5\.bmp: \.bmp images are not read"):
        scan_image_folder(tmp_path / "seq")


def test_reference_only_folder_and_file_input(tmp_path):
    truth = _seq(tmp_path / "seq", n=1)
    truth["frame_files"][0].unlink()
    with pytest.raises(InputError, match="no frames besides the reference reference.png"):
        scan_image_folder(tmp_path / "seq")
    with pytest.raises(InputError, match="reads folders of PNG/JPG frames"):
        ingest([truth["reference_file"]], tmp_path / "o.h5", format="images")


def test_write_frames_in_memory_matches_the_appender(tmp_path):
    truth = write_image_sequence(tmp_path / "seq", n_frames=3, width=W, height=H, seed=4)
    with StoreWriter(tmp_path / "o.h5", command="test") as w:
        s = w.add_sensor("cam", kind="visuotactile", sample_rate_hz=30, width_px=W, height_px=H)
        w.trial("t").write_frames(sensor=s, images=truth["images"], t_s=truth["t_s"],
                                  reference=truth["reference"])
        with pytest.raises(ValueError, match="`images` must be"):
            w.trial("u").write_frames(sensor=s, images=truth["images"].astype(np.int16),
                                      t_s=truth["t_s"], reference=truth["reference"])
        del w.h5["trials/u"]
        w.commit()
    with h5py.File(tmp_path / "o.h5") as h5:
        np.testing.assert_array_equal(h5["trials/t/frames/images"][()], truth["images"])


def test_cli_good_run_validates(tmp_path):
    _seq(tmp_path / "press", n=4)
    out = tmp_path / "o.h5"
    result = runner.invoke(app, ["ingest", str(tmp_path / "press"), "--out", str(out),
                                 "--sensor", "digit", "--no-progress"])
    assert result.exit_code == 0, result.output
    assert f"wrote {out}" in result.output
    with h5py.File(out) as h5:
        assert h5["trials/press/frames"].attrs["sensor"] == "digit"
    check = runner.invoke(app, ["validate", str(out)])
    assert check.exit_code == 0 and "valid" in check.output


def test_cli_bad_run_is_one_line_exit_2_and_writes_nothing(tmp_path):
    _seq(tmp_path / "press", n=4)
    (tmp_path / "press" / "frame_1.png").write_bytes(b"\x89PNG broken")
    out_dir = tmp_path / "out"
    out_dir.mkdir()
    out = out_dir / "o.h5"
    result = runner.invoke(app, ["ingest", str(tmp_path / "press"), "--out", str(out),
                                 "--no-progress"])
    assert result.exit_code == 2
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1
    assert lines[0].startswith(f"tactile: error: {tmp_path / 'press' / 'frame_1.png'}: ")
    assert "Traceback" not in result.output
    assert list(out_dir.iterdir()) == []  # neither the output nor a temporary file


def test_cli_fps_sets_the_frame_times(tmp_path):
    write_image_sequence(tmp_path / "press", n_frames=5, width=8, height=6, seed=0)
    out = tmp_path / "o.h5"
    args = ["ingest", str(tmp_path / "press"), "--fps", "50", "--out", str(out)]
    result = CliRunner().invoke(app, args)
    assert result.exit_code == 0, result.output
    with h5py.File(out) as h5:
        np.testing.assert_allclose(h5["trials/press/frames/t_s"][()], np.arange(5) / 50.0)
        assert "frame_rate_assumed_hz" not in h5["trials/press"].attrs


def test_cli_notes_the_assumed_frame_rate(tmp_path):
    _seq(tmp_path / "press", n=3)
    out = tmp_path / "o.h5"
    result = runner.invoke(app, ["ingest", str(tmp_path / "press"), "--out", str(out),
                                 "--no-progress"])
    assert result.exit_code == 0, result.output
    assert result.stderr.splitlines() == [
        "tactile: note: press has no timestamps.csv: frames taken as evenly spaced at 30 Hz "
        "(DIGIT's rate; recorded as the trial attribute frame_rate_assumed_hz); give the real "
        "rate with --fps HZ, or a timestamps.csv (t_s per frame) in the folder"]
    with h5py.File(out) as h5:
        assert h5["trials/press"].attrs["frame_rate_assumed_hz"] == DEFAULT_FRAME_RATE_HZ
    # a rate given, or timestamps in the folder: nothing assumed, no note
    given = runner.invoke(app, ["ingest", str(tmp_path / "press"), "--fps", "25", "--out",
                                str(tmp_path / "g.h5"), "--no-progress"])
    assert given.exit_code == 0 and given.stderr == ""
    (tmp_path / "press" / "timestamps.csv").write_text("t_s\n0\n0.1\n0.2\n")
    timed = runner.invoke(app, ["ingest", str(tmp_path / "press"), "--out",
                                str(tmp_path / "t.h5"), "--no-progress"])
    assert timed.exit_code == 0 and timed.stderr == ""


def test_folder_of_sequence_folders_is_one_trial_each(tmp_path):
    for name, n in (("press_10", 2), ("press_2", 3), ("press_1", 4)):
        _seq(tmp_path / "digit" / name, n=n)
    (tmp_path / "digit" / "README.txt").write_text("three presses\n")  # files are not trials
    (tmp_path / "digit" / "press_2" / "timestamps.csv").write_text("t_s\n0\n0.05\n0.1\n")
    out = tmp_path / "o.h5"
    result = runner.invoke(app, ["ingest", str(tmp_path / "digit"), "--out", str(out),
                                 "--no-progress"])
    assert result.exit_code == 0, result.output
    note = result.stderr.strip()
    assert note.startswith("tactile: note: 2 folders (press_1, press_10) have no timestamps.csv")
    assert validate_file(out).ok
    with h5py.File(out) as h5:
        assert list(h5["trials"]) == ["press_1", "press_2", "press_10"]  # natural order
        assert [h5[f"trials/{t}/frames/images"].shape[0] for t in h5["trials"]] == [4, 3, 2]
        np.testing.assert_allclose(h5["trials/press_2/frames/t_s"][()], [0, 0.05, 0.1])


def test_folder_of_sequence_folders_refuses_a_subfolder_without_frames(tmp_path):
    _seq(tmp_path / "digit" / "press_1", n=2)
    (tmp_path / "digit" / "calibration").mkdir()
    (tmp_path / "digit" / "calibration" / "gel.yaml").write_text("a: 1\n")
    with pytest.raises(InputError, match=r"digit: holds image-sequence folders \(press_1, \.\.\.\) "
                                         r"and calibration/, which has no PNG/JPG frames"):
        ingest([tmp_path / "digit"], tmp_path / "o.h5")
    (tmp_path / "empty").mkdir()
    with pytest.raises(InputError, match=r"empty: cannot tell the format of a folder"):
        ingest([tmp_path / "empty"], tmp_path / "o.h5")
