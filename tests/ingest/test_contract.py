"""The input-format contract: every registered format keeps it, options are typed per format,
and an option the chosen format does not take is refused in one line naming the formats that
take it (library and CLI)."""

from __future__ import annotations

import inspect
import re
import subprocess
import sys
from pathlib import Path

import pytest
from pydantic import ValidationError
from typer.testing import CliRunner

from tactile_cli.cli import app
from tactile_cli.errors import InputError
from tactile_cli.ingest import (
    FORMATS,
    CommonOptions,
    FormatOptions,
    IngestFormat,
    detect_format,
    format_options,
    ingest,
    parse_options,
)
from tactile_cli.ingest.events_table import EventTableOptions
from tactile_cli.ingest.image_sequence import ImageFolderOptions
from tactile_cli.ingest.registry import formats_taking, option_names
from tactile_cli.samples import write_all

runner = CliRunner()


@pytest.fixture(scope="module")
def samples(tmp_path_factory) -> Path:
    root = tmp_path_factory.mktemp("contract") / "raw"
    write_all(root, seed=0, n_events=500)
    return root


def test_every_registered_format_keeps_the_contract():
    assert list(FORMATS) == ["aedat4", "events-npy", "events-csv", "rosbag", "mcap", "video",
                             "images", "accel-tree", "mapped-csv"]
    for name, fmt in FORMATS.items():
        assert isinstance(fmt, IngestFormat) and fmt.name == name
        assert fmt.title and fmt.summary and "\n" not in fmt.summary
        for method in ("sniff", "describe", "read"):
            assert callable(getattr(fmt, method)), (name, method)
            assert not getattr(getattr(type(fmt), method), "__isabstractmethod__", False)
        assert list(inspect.signature(fmt.read).parameters) == ["inputs", "options", "writer",
                                                                "progress"]
        assert list(inspect.signature(fmt.describe).parameters) == ["path", "options"]
        assert issubclass(fmt.Options, FormatOptions)
        assert fmt.Options.model_config["extra"] == "forbid"
        fmt.Options()  # every option has a default: what `tactile info` describes with
        with pytest.raises(ValidationError, match="colour"):
            fmt.Options(colour="red")
        assert all(s.startswith(".") and s == s.lower() for s in fmt.suffixes)
    # the shared options are one model, and no format repeats them
    assert set(CommonOptions.model_fields) == {"labels", "annotations", "trial_labels"}
    assert not set(CommonOptions.model_fields) & set(option_names())


def test_a_format_without_a_method_cannot_be_made():
    class Half(IngestFormat[FormatOptions]):
        name, title, summary, Options = "half", "half", "half", FormatOptions

        def sniff(self, path: Path) -> bool:
            return False

    with pytest.raises(TypeError, match="abstract"):
        Half()  # type: ignore[abstract]


@pytest.mark.slow
def test_sniffing_is_by_suffix_header_bytes_and_layout(samples, tmp_path):
    expect = {samples / "events.csv": "events-csv", samples / "events.npy": "events-npy",
              samples / "accel_tree": "accel-tree", samples / "visuotactile": "images",
              samples / "visuotactile" / "press_01": "images", samples / "taxel": "mapped-csv"}
    for path, name in expect.items():
        assert detect_format([path]).name == name, path
        assert FORMATS[name].sniff(path)
    # an .npy array without its suffix is known by its magic bytes, an AEDAT4 file by its
    renamed = tmp_path / "events.bin"
    renamed.write_bytes((samples / "events.npy").read_bytes())
    assert detect_format([renamed]).name == "events-npy"
    aedat = tmp_path / "rec.dat"
    aedat.write_bytes(b"#!AER-DAT4.0\r\n" + bytes(8))
    assert detect_format([aedat]).name == "aedat4"
    # a mapping makes a CSV file a mapped table, and claims a suffix nothing sniffs
    table = tmp_path / "grasps.txt"
    table.write_text("a,b\n1,2\n")
    assert detect_format([samples / "events.csv"], options={"mapping": "m.yaml"}).name == \
        "mapped-csv"
    assert detect_format([table], options={"mapping": "m.yaml"}).name == "mapped-csv"
    with pytest.raises(InputError, match=r"grasps\.txt: unknown format \(suffix '\.txt'\)"):
        detect_format([table])
    # sniffing never raises, whatever the path
    for fmt in FORMATS.values():
        assert fmt.sniff(tmp_path / "missing" / "x") in (True, False)


def test_options_are_typed_per_format():
    images = FORMATS["images"]
    opts = format_options(images, {"frame_rate_hz": "25", "reference": "first"})
    assert isinstance(opts, ImageFolderOptions) and opts.frame_rate_hz == 25.0
    assert format_options(FORMATS["events-csv"], EventTableOptions(width_px=4)).width_px == 4
    with pytest.raises(InputError, match=r"^`frame_rate_hz` \(=fast\): Input should be a valid "
                                         r"number"):
        format_options(images, {"frame_rate_hz": "fast"})
    with pytest.raises(InputError, match="options EventTableOptions belong to the format.s. "
                                         "events-npy, events-csv, not to images"):
        format_options(images, EventTableOptions())


@pytest.mark.parametrize(("fmt", "key", "message"), [
    ("events-csv", "frame_rate_hz", "`frame_rate_hz` is not an option of the event CSV format "
                                    "(events-csv); formats that take it: images"),
    ("images", "skip_unknown", "`skip_unknown` is not an option of the image-sequence folder "
                               "format (images); formats that take it: aedat4"),
    ("accel-tree", "colour", "`colour` is not an option of any format; the options of "
                             "accel-tree: `sample_rate_hz`"),
    ("events-npy", "labels", "`labels` is an option every format shares, not an option of "
                             "events-npy: give it to `ingest` itself"),
])
def test_unknown_option_is_refused_with_its_key(fmt, key, message):
    with pytest.raises(InputError, match="^" + re.escape(message)):
        format_options(FORMATS[fmt], {key: "1"})
    assert formats_taking("width_px") == ["aedat4", "events-npy", "events-csv", "images"]


def test_wrong_option_refused_before_anything_is_written(samples, tmp_path):
    out = tmp_path / "o.h5"
    with pytest.raises(InputError, match=r"`px_per_mm` is not an option of the event NPY"):
        ingest([samples / "events.npy"], out, options={"width_px": 640, "height_px": 480,
                                                        "px_per_mm": 16})
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize(("args", "line"), [
    (["{raw}/events.csv", "--width", "640", "--height", "480", "--fps", "30"],
     "--fps is not an option of the event CSV format (events-csv); formats that take it: "
     "images"),
    (["{raw}/visuotactile/press_01", "--skip-unknown"],
     "--skip-unknown is not an option of the image-sequence folder format (images); formats "
     "that take it: aedat4"),
    (["{raw}/accel_tree", "--format", "accel-tree", "--sensor", "acc"],
     "--sensor is not an option of the accelerometer CSV tree format (accel-tree); formats "
     "that take it: aedat4, events-npy, events-csv, video, images"),
    (["{raw}/events.npy", "--width", "640", "-O", "width_px=320"],
     "--option sets --width a second time (--width is given already)"),
    (["{raw}/events.npy", "-O", "chunk"], "--option 'chunk' must look like key=value"),
])
def test_cli_wrong_option_is_one_line(samples, tmp_path, args, line):
    out = tmp_path / "o.h5"
    result = runner.invoke(app, ["ingest", *[a.format(raw=samples) for a in args], "--out",
                                 str(out), "--no-progress"])
    assert result.exit_code == 2
    assert result.stderr.strip().splitlines() == [f"tactile: error: {line}"]
    assert not out.exists()


def test_cli_option_flag_reaches_options_without_a_flag(samples, tmp_path):
    """``-O KEY=VALUE`` sets a format option that has no flag of its own (values as text,
    converted by the format's model); the file records the options the format used."""
    import json

    import h5py

    out = tmp_path / "acc.h5"
    result = runner.invoke(app, ["ingest", str(samples / "accel_tree"), "-O",
                                 "sample_rate_hz=4000", "--out", str(out), "--no-progress"])
    assert result.exit_code == 0, result.output
    with h5py.File(out) as f:
        assert f["sensors/accel"].attrs["sample_rate_hz"] == 4000.0
        config = json.loads(f.attrs["config_json"])
        assert (config["format"], config["options"]) == ("accel-tree",
                                                         {"sample_rate_hz": 4000.0})
    assert parse_options(["a=1", " b = x "], {"c": None, "d": 2}) == {"d": 2, "a": "1",
                                                                      "b": "x"}


def test_help_lists_the_formats_and_which_take_each_flag():
    text = runner.invoke(app, ["ingest", "--help"], env={"COLUMNS": "200"}).output
    flat = " ".join(text.replace("│", " ").split())  # rich wraps inside a box
    for fmt in FORMATS.values():
        assert f"{fmt.name}: " in flat
    assert "Frame rate of image folders" in flat and "Formats: images." in flat
    assert "chunk_events (aedat4, events-npy, events-csv); sample_rate_hz (accel-tree)" in flat


@pytest.mark.slow
def test_import_and_help_stay_light():
    """The registry imports every format module, so none may import pandas, Pillow or the
    AEDAT4 decoder at import time."""
    code = ("import sys, tactile_cli, tactile_cli.cli; "
            "from tactile_cli.ingest.registry import FORMATS; "
            "print(sorted(m for m in ('pandas', 'PIL', 'aedat', 'torch', 'jax') "
            "if m in sys.modules)); print(len(FORMATS))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True)
    assert out.stdout.split() == ["[]", str(len(FORMATS))]
