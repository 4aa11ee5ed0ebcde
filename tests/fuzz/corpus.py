"""A seeded corpus of damaged inputs and the command runs made on them (issue 20).

:func:`build_bases` writes valid inputs once (raw recordings of every format from
``tactile samples``, the real AEDAT4 sample when ../shared/data has it, small tactile HDF5
files of each kind, configs and a tiny trained run folder); :func:`build_corpus` copies
them and damages each copy in one way (truncation, byte flips in compressed chunks and in
metadata, deleted and retyped datasets and attributes, NaN/inf and absurd numbers,
unsorted or out-of-range events, non-UTF-8 bytes, broken YAML, damaged run folders,
clashing outputs, symlink loops) and returns one :class:`Case` per command run on a
damaged input. The same seed gives the same corpus.

Each case says what a correct command does with it: ``refuse`` (exit 2 with one line;
``validate`` may instead exit 1 with its report, since the file is readable but invalid) or
``either`` (exit 0 is allowed too: the damage is harmless to that command, such as a
flipped byte in a dataset ``info`` never reads, or the case is a baseline). Whatever the
expectation, a run must never end in a traceback, a hang, a multi-line error, a leftover
output or a changed input (see runner.py).
"""

from __future__ import annotations

import json
import os
import shutil
import sys
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from pathlib import Path

import h5py
import numpy as np

REPO = Path(__file__).resolve().parents[2]
AEDAT4 = REPO.parent / "shared" / "data" / "aedat4" / "dvxplorer_sample.aedat4"

REFUSE = "refuse"
EITHER = "either"


@dataclass(frozen=True)
class Case:
    """One command run on one damaged input.

    ``argv`` holds the placeholders ``{IN}`` (the damaged input, copied into the run's
    scratch folder first), ``{OUT}`` (the scratch output folder), ``{BASE}`` (the valid
    inputs, never written) and ``{RUN}`` (a fresh copy of the valid run folder).
    ``clash`` names paths under ``{OUT}`` to create before the run: ``"file:x"`` a file,
    ``"dir:x"`` a folder."""

    id: str
    command: str
    argv: tuple[str, ...]
    damaged: str  # the damaged input's folder name under corpus/
    mutation: str
    expect: str  # REFUSE or EITHER
    clash: tuple[str, ...] = ()


@dataclass
class Damaged:
    """One damaged input: ``name`` is its folder under corpus/, ``entry`` the path inside
    it that the commands get (a file or a folder)."""

    name: str
    entry: str
    mutation: str
    kind: str  # the base it came from
    role: str  # what part of it is damaged (decides which commands must refuse)
    harmless: bool = False


# --------------------------------------------------------------------------- the bases

def _tactile(argv: list[str], cwd: Path) -> None:
    from .runner import run_argv

    res = run_argv(argv, cwd=cwd, timeout_s=300)
    if res.code != 0:
        raise RuntimeError(f"building the fuzz bases: tactile {' '.join(argv)} failed "
                           f"({res.code}): {res.stderr[-2000:]}")


TINY_TRAIN = {
    "version": 1, "seed": 0,
    "data": {"stream": "event_counts", "channels": ["net"], "window": 10, "stride": 4,
             "pad": "zero", "transform": "signed_log1p",
             "targets": [{"name": "action"}],
             "split": {"val_fraction": 0.25, "test_fraction": 0.0}},
    "model": {"family": "mlp", "hidden": [8]},
    "optim": {"lr": 0.01, "batch_size": 64, "epochs": 1, "patience": 0, "threads": 1},
}


def build_bases(root: Path) -> Path:
    """Valid inputs under ``root/base`` (built once; about 20 s, and about 40 s more for
    the sensor chains, see chains.py). Returns that folder."""
    base = root / "base"
    if (base / ".complete").exists():
        return base
    if base.exists():
        shutil.rmtree(base)
    base.mkdir(parents=True)
    sys.path.insert(0, str(REPO)) if str(REPO) not in sys.path else None
    from tests.factories.action_files import make_action_file, make_event_file

    _tactile(["samples", str(base / "raw"), "--seed", "0", "--n-events", "3000"], base)
    raw = base / "raw"
    # smaller raw trees: two accelerometer runs, cut to 400 rows each
    for extra in ("aluminum",):
        shutil.rmtree(raw / "accel_tree" / extra)
    for csv in (raw / "accel_tree").rglob("data.csv"):
        lines = csv.read_bytes().splitlines(keepends=True)[:400]
        csv.write_bytes(b"".join(lines))
    if AEDAT4.exists():
        shutil.copyfile(AEDAT4, raw / "events.aedat4")
    if (raw / "robot").exists():
        from .robot_cases import write_robot_cases

        write_robot_cases(raw / "robot_cases")

    h5 = base / "h5"
    h5.mkdir()
    make_event_file(h5 / "events.h5", n_trials=2, seed=1)
    make_action_file(h5 / "counts.h5", n_trials=8, seed=0)
    ing = [
        (["ingest", str(raw / "events.csv"), "--width", "640", "--height", "480",
          "--out", str(h5 / "events_csv.h5")]),
        (["ingest", str(raw / "accel_tree"), "--format", "accel-tree",
          "--out", str(h5 / "accel.h5")]),
        (["ingest", str(raw / "taxel"), "--mapping", str(raw / "taxel" / "taxels.yaml"),
          "--out", str(h5 / "taxel.h5")]),
        (["ingest", str(raw / "visuotactile" / "press_01"), "--out", str(h5 / "visuo.h5")]),
    ]
    for argv in ing:
        _tactile(argv, base)

    # companion CSVs of ingest and grade, and the configs
    (base / "annotations.csv").write_text(
        "trial,start_s,end_s,label\nevents,0.0,0.01,press\nevents,0.01,0.02,slip\n")
    (base / "trial_labels.csv").write_text("trial,force_level\nevents,3\n")
    (base / "grade_table.csv").write_text(
        "trial,area,level\n" + "".join(f"t{i},{20000 + 2500 * i},{i + 1}\n" for i in range(12)))
    t = np.arange(0, 1.0, 0.02)
    x = 100 * (1 - np.exp(-t / 0.2))
    (base / "fos_curve.csv").write_text(
        "t_s,x\n" + "".join(f"{a:.3f},{b:.6f}\n" for a, b in zip(t, x, strict=True)))
    cfg = base / "cfg"
    cfg.mkdir()
    import yaml

    (cfg / "train.yaml").write_text(yaml.safe_dump(TINY_TRAIN, sort_keys=False))
    for name in ("grade_marker.yaml", "rois_marker_scene.yaml", "synth_fos.yaml"):
        shutil.copyfile(REPO / "configs" / name, cfg / name)
    shutil.copyfile(raw / "taxel" / "taxels.yaml", cfg / "taxels.yaml")

    _tactile(["train", str(cfg / "train.yaml"), "--data", str(h5 / "counts.h5"),
              "--out", str(base / "run"), "--no-progress"], base)
    _tactile(["evaluate", str(base / "run"), "--data", str(h5 / "counts.h5"),
              "--no-latency", "--name", "counts"], base)
    _tactile(["seed-spread", str(cfg / "train.yaml"), "--data", str(h5 / "counts.h5"),
              "--cv", "2", "--seeds", "0,1", "--workers", "0", "--out", str(base / "spread"),
              "--no-progress", "--no-plot"], base)
    from .chains import build_chain_bases

    build_chain_bases(base, _tactile, REPO)
    (base / ".complete").write_text("ok\n")
    return base


# ----------------------------------------------------------------- file-level damage

def _truncate(path: Path, frac: float) -> None:
    data = path.read_bytes()
    path.write_bytes(data[: max(0, int(len(data) * frac))])


def _flip(path: Path, offsets, rng: np.random.Generator) -> None:
    data = bytearray(path.read_bytes())
    for off in offsets:
        if 0 <= off < len(data):
            data[off] ^= int(rng.integers(1, 256))
    path.write_bytes(bytes(data))


def _chunk_ranges(path: Path) -> dict[str, list[tuple[int, int, bool]]]:
    """dataset path -> [(file offset, size, compressed)] of its chunks."""
    out: dict[str, list[tuple[int, int, bool]]] = {}
    with h5py.File(path, "r") as f:
        def visit(name, obj):
            if isinstance(obj, h5py.Dataset) and obj.chunks is not None:
                ranges = []
                for i in range(obj.id.get_num_chunks()):
                    info = obj.id.get_chunk_info(i)
                    if info.byte_offset is not None and info.size > 0:
                        ranges.append((int(info.byte_offset), int(info.size),
                                       obj.compression is not None))
                if ranges:
                    out["/" + name] = ranges
        f.visititems(visit)
    return out


# -------------------------------------------------------------------- HDF5 damage

def _decodes_as_before(base: Path, damaged: Path, mutation: str) -> bool:
    """Whether the dataset whose chunk a ``flip-chunk`` mutation changed still decodes, bit
    for bit, to the base file's data. A deflate stream can absorb a changed byte (bits
    the decoder never reads, such as code lengths of unused symbols), and zlib's checksum
    covers the decoded data, not the stream: such a file holds no corrupt data, so
    accepting it is right (seen once, in the t column of events_csv.h5, seed 0)."""
    dotted = mutation.split("flip-chunk", 1)[1].rsplit("-", 1)[0]
    # the dataset whose path, dots for slashes, the mutation names (trial names may hold dots)
    ds = next((d for d in _chunk_ranges(base) if d.replace("/", ".") == dotted),
              dotted.replace(".", "/"))
    try:
        with h5py.File(base, "r") as fb, h5py.File(damaged, "r") as fd:
            return bool(np.array_equal(fb[ds][()], fd[ds][()]))
    except (OSError, KeyError, RuntimeError, ValueError):
        return False


def _first(group: h5py.Group) -> str:
    return sorted(group.keys())[0]


def _h5_nodes(path: Path) -> dict[str, str]:
    """Named places of a base file: trial, sensor, events group, signal group."""
    with h5py.File(path, "r") as f:
        trial = _first(f["trials"])
        sensor = _first(f["sensors"])
        tg = f["trials"][trial]
        nodes = {"trial": f"/trials/{trial}", "sensor": f"/sensors/{sensor}"}
        if "events" in tg:
            nodes["events"] = f"/trials/{trial}/events"
            if "t" not in tg["events"]:  # one group per sensor
                nodes["events"] += "/" + _first(tg["events"])
        if "signals" in tg:
            nodes["signal"] = f"/trials/{trial}/signals/{_first(tg['signals'])}"
            sg = tg["signals"][_first(tg["signals"])]
            if "sample_labels" in sg and len(sg["sample_labels"]):
                nodes["sample_labels"] = (nodes["signal"] + "/sample_labels/"
                                          + _first(sg["sample_labels"]))
        if "frames" in tg:
            nodes["frames"] = f"/trials/{trial}/frames"  # the group: its images are retyped
        if "annotations" in tg:
            nodes["annotations"] = f"/trials/{trial}/annotations"
        if "labels" in tg and len(tg["labels"].attrs):
            nodes["labels"] = f"/trials/{trial}/labels"
    return nodes


def _replace(f: h5py.File, path: str, data) -> None:
    attrs = dict(f[path].attrs)
    del f[path]
    ds = f.create_dataset(path, data=data)
    for k, v in attrs.items():
        ds.attrs[k] = v


def _h5_mutations(path: Path, rng: np.random.Generator, n_random: int
                  ) -> Iterator[tuple[str, str, Callable[[Path], None], bool]]:
    """(mutation, role, apply(copy), harmless) for a base HDF5 file."""
    nodes = _h5_nodes(path)
    yield "none", "meta", lambda p: None, True  # the baseline: every command accepts it
    for frac in (0.0, 0.05, 0.3, 0.7, 0.97):
        yield f"truncate-{frac:g}", "root", (lambda p, fr=frac: _truncate(p, fr)), False
    yield "flip-signature", "root", (lambda p: _flip(p, [0, 1, 2], rng)), False
    yield "flip-superblock", "root", (lambda p: _flip(p, range(8, 40, 3), rng)), False
    size = path.stat().st_size
    chunks = _chunk_ranges(path)
    chunk_bytes = {o for ranges in chunks.values() for off, n, _ in ranges
                   for o in range(off, off + n)}
    # byte flips inside compressed chunks: zlib's checksum makes every one detectable
    for ds, ranges in sorted(chunks.items()):
        compressed = [r for r in ranges if r[2]]
        if not compressed:
            continue
        role = _role_of(ds, nodes)
        for k in range(max(1, n_random // 2)):
            off, n, _ = compressed[int(rng.integers(0, len(compressed)))]
            where = [off + int(rng.integers(n // 4, max(n // 4 + 1, 3 * n // 4)))]
            yield (f"flip-chunk{ds.replace('/', '.')}-{k}", role,
                   (lambda p, w=where: _flip(p, w, rng)), False)
    # byte flips outside the chunks (object headers, heaps, free space): may be harmless
    for k in range(n_random):
        offs = [int(o) for o in rng.integers(48, size, 8) if int(o) not in chunk_bytes][:2]
        yield f"flip-meta-{k}", "meta", (lambda p, w=offs: _flip(p, w, rng)), True

    def edit(fn):
        def apply(p: Path) -> None:
            with h5py.File(p, "r+") as f:
                fn(f)
        return apply

    yield "del-schema_version", "root", edit(lambda f: f.attrs.__delitem__("schema_version")), False
    yield "retype-schema_version-int", "root", edit(
        lambda f: f.attrs.__setitem__("schema_version", 7)), False
    yield "schema_version-99.0", "root", edit(
        lambda f: f.attrs.__setitem__("schema_version", "99.0")), False
    yield "del-trials", "root", edit(lambda f: f.__delitem__("trials")), False
    yield "del-sensors", "root", edit(lambda f: f.__delitem__("sensors")), False
    yield "del-provenance-sha", "provenance", edit(
        lambda f: f.__delitem__("provenance/sources/sha256")), False
    s = nodes["sensor"]
    yield "del-sensor-kind", "sensor", edit(lambda f: f[s].attrs.__delitem__("kind")), False
    yield "sensor-kind-bogus", "sensor", edit(
        lambda f: f[s].attrs.__setitem__("kind", "toaster")), False
    yield "sensor-kind-int", "sensor", edit(lambda f: f[s].attrs.__setitem__("kind", 3)), False
    for value, tag in (("fast", "str"), (float("nan"), "nan"), (float("inf"), "inf"),
                       (-100.0, "neg"), (1e300, "1e300"), (np.array([1.0, 2.0]), "array")):
        yield (f"sensor-rate-{tag}", "sensor", edit(
            lambda f, v=value: f[s].attrs.__setitem__("sample_rate_hz", v)), False)
    yield "del-trial-attrs-duration", "trial_attr", edit(
        lambda f: f[nodes["trial"]].attrs.__delitem__("duration_s")), False
    yield "trial-duration-str", "trial_attr", edit(
        lambda f: f[nodes["trial"]].attrs.__setitem__("duration_s", "long")), False
    yield "trial-split-int", "split", edit(
        lambda f: f[nodes["trial"]].attrs.__setitem__("split", 5)), False
    yield "trial-split-bogus", "split", edit(
        lambda f: f[nodes["trial"]].attrs.__setitem__("split", "holiday")), False
    if "labels" in nodes:
        lab = nodes["labels"]
        yield "labels-array", "labels", edit(
            lambda f: f[lab].attrs.__setitem__("force_level", np.zeros((3, 3)))), False
    if "events" in nodes:
        e = nodes["events"]
        yield "events-width-str", "sensor", edit(
            lambda f: f[s].attrs.__setitem__("width_px", "wide")), False
        yield "events-width-0", "sensor", edit(
            lambda f: f[s].attrs.__setitem__("width_px", 0)), False
        yield "events-height-neg", "sensor", edit(
            lambda f: f[s].attrs.__setitem__("height_px", -480)), False
        yield "del-sensor-width", "sensor", edit(
            lambda f: f[s].attrs.__delitem__("width_px")), False
        for col in ("t", "x", "y", "p"):
            yield f"del-events-{col}", "events", edit(
                lambda f, c=col: f.__delitem__(f"{e}/{c}")), False
        yield "events-t-str", "events", edit(
            lambda f: _replace(f, f"{e}/t", np.array([b"a"] * f[f"{e}/t"].shape[0]))), False
        yield "events-x-float-nan", "events", edit(
            lambda f: _replace(f, f"{e}/x", np.full(f[f"{e}/x"].shape, np.nan))), False
        yield "events-x-2d", "events", edit(
            lambda f: _replace(f, f"{e}/x", np.zeros((f[f"{e}/x"].shape[0], 2), np.uint16))), False
        yield "events-short-y", "events", edit(
            lambda f: _replace(f, f"{e}/y", f[f"{e}/y"][: f[f"{e}/y"].shape[0] // 2])), False
        yield "events-unsorted", "events", edit(
            lambda f: _replace(f, f"{e}/t", f[f"{e}/t"][()][::-1])), False
        yield "events-x-65535", "events", edit(
            lambda f: _replace(f, f"{e}/x", np.full(f[f"{e}/x"].shape, 65535, np.uint16))), False
        yield "events-y-beyond", "events", edit(
            lambda f: _replace(f, f"{e}/y", f[f"{e}/y"][()].astype(np.int64) + 5000)), False
        yield "events-p-7", "events", edit(
            lambda f: _replace(f, f"{e}/p", np.full(f[f"{e}/p"].shape, 7, np.int8))), False
        yield "events-t-neg", "events", edit(
            lambda f: _replace(f, f"{e}/t", f[f"{e}/t"][()].astype(np.int64) - 10**15)), False
        yield "events-t-origin-str", "events", edit(
            lambda f: f[e].attrs.__setitem__("t_origin_us", "noon")), False
    if "signal" in nodes:
        g = nodes["signal"]
        yield "del-signal-data", "signal", edit(lambda f: f.__delitem__(f"{g}/data")), False
        yield "del-signal-t_s", "signal", edit(lambda f: f.__delitem__(f"{g}/t_s")), False
        yield "signal-data-str", "signal", edit(
            lambda f: _replace(f, f"{g}/data", np.full(f[f"{g}/data"].shape, b"x"))), False
        yield "signal-data-1d", "signal", edit(
            lambda f: _replace(f, f"{g}/data", f[f"{g}/data"][()].reshape(-1))), False
        yield "signal-data-3d", "signal", edit(
            lambda f: _replace(f, f"{g}/data", f[f"{g}/data"][()][..., None])), False
        yield "signal-data-nan", "signal", edit(
            lambda f: _replace(f, f"{g}/data", _with(f[f"{g}/data"][()], np.nan))), False
        yield "signal-data-inf", "signal", edit(
            lambda f: _replace(f, f"{g}/data", _with(f[f"{g}/data"][()], np.inf))), False
        yield "signal-data-1e38", "signal", edit(  # absurd but finite: accepting it is fine
            lambda f: _replace(f, f"{g}/data", _with(f[f"{g}/data"][()], 3e38))), True
        yield "signal-data-short", "signal", edit(
            lambda f: _replace(f, f"{g}/data", f[f"{g}/data"][: 3])), False
        yield "signal-t-reversed", "signal", edit(
            lambda f: _replace(f, f"{g}/t_s", f[f"{g}/t_s"][()][::-1])), False
        yield "signal-t-constant", "signal", edit(
            lambda f: _replace(f, f"{g}/t_s", np.zeros(f[f"{g}/t_s"].shape))), False
        yield "signal-t-nan", "signal", edit(
            lambda f: _replace(f, f"{g}/t_s", _with(f[f"{g}/t_s"][()], np.nan))), False
        yield "signal-rate-0", "signal", edit(
            lambda f: f[g].attrs.__setitem__("sample_rate_hz", 0.0)), False
        yield "signal-rate-neg", "signal", edit(
            lambda f: f[g].attrs.__setitem__("sample_rate_hz", -50.0)), False
        yield "signal-sensor-missing", "signal", edit(
            lambda f: f[g].attrs.__setitem__("sensor", "nobody")), False
        yield "channel_units-int", "channels", edit(
            lambda f: _replace(f, f"{s}/channel_units",
                               np.arange(f[f"{s}/channel_units"].shape[0]))), False
        yield "channel_names-int", "channels", edit(
            lambda f: _replace(f, f"{s}/channel_names",
                               np.arange(f[f"{s}/channel_names"].shape[0]))), False
        yield "channel_names-short", "channels", edit(
            lambda f: _replace(f, f"{s}/channel_names", np.array(
                [b"a", b"b", b"c"][: max(1, f[f"{s}/channel_names"].shape[0] - 1)]
                if f[f"{s}/channel_names"].shape[0] > 1 else [b"a", b"b"]))), False
        yield "del-channel_names", "channels", edit(
            lambda f: f.__delitem__(f"{s}/channel_names")), False
    if "sample_labels" in nodes:
        sl = nodes["sample_labels"]
        yield "sample_labels-beyond", "sample_labels", edit(
            lambda f: _replace(f, sl, np.full(f[sl].shape, 99, f[sl].dtype))), False
        yield "sample_labels-neg", "sample_labels", edit(
            lambda f: _replace(f, sl, np.full(f[sl].shape, -3, f[sl].dtype))), False
        yield "sample_labels-float", "sample_labels", edit(
            lambda f: _replace(f, sl, np.full(f[sl].shape, 0.5))), False
        yield "sample_labels-short", "sample_labels", edit(
            lambda f: _replace(f, sl, f[sl][:2])), False
        yield "sample_labels-classes-int", "sample_labels", edit(
            lambda f: f[sl].attrs.__setitem__("classes", np.arange(4))), False
        yield "sample_labels-del-classes", "label_target", edit(  # valid as a numeric label
            lambda f: f[sl].attrs.__delitem__("classes")), False
    if "annotations" in nodes:
        a = nodes["annotations"]
        yield "annotations-deleted-start", "annotations", edit(lambda f: _del_first(f, a)), False
        yield "annotations-end-before-start", "annotations", edit(
            lambda f: _annot(f, a, lambda s_, e_: (e_, s_))), False
        yield "annotations-nan", "annotations", edit(
            lambda f: _annot(f, a, lambda s_, e_: (s_ * np.nan, e_))), False
        yield "annotations-beyond", "annotations", edit(
            lambda f: _annot(f, a, lambda s_, e_: (s_ + 1e6, e_ + 1e6))), False
    if "frames" in nodes:
        fr = nodes["frames"]
        yield "frames-data-str", "frames", edit(lambda f: _retype_frames(f, fr)), False


def _with(arr: np.ndarray, value: float) -> np.ndarray:
    out = np.array(arr, dtype=np.float64 if arr.dtype.kind != "f" else arr.dtype, copy=True)
    out.reshape(-1)[out.size // 2] = value
    return out


def _del_first(f: h5py.File, group: str) -> None:
    g = f[group]
    for name in g:
        del g[name]
        return
    for key in g.attrs:
        del g.attrs[key]
        return


def _annot(f: h5py.File, group: str, fn) -> None:
    g = f[group]
    if isinstance(g, h5py.Group) and "start_s" in g and "end_s" in g:
        s_, e_ = fn(g["start_s"][()].astype(np.float64), g["end_s"][()].astype(np.float64))
        _replace(f, f"{group}/start_s", s_)
        _replace(f, f"{group}/end_s", e_)
    else:  # another layout: damage every numeric dataset in it
        for name, ds in list(g.items()):
            if isinstance(ds, h5py.Dataset) and ds.dtype.kind in "fiu":
                _replace(f, f"{group}/{name}", ds[()].astype(np.float64) * np.nan)


def _retype_frames(f: h5py.File, group: str) -> None:
    g = f[group]
    for name, ds in list(g.items()) if isinstance(g, h5py.Group) else []:
        if isinstance(ds, h5py.Dataset) and ds.ndim >= 2:
            _replace(f, f"{group}/{name}", np.full(ds.shape[:1], b"img"))
            return


def _role_of(ds: str, nodes: dict[str, str]) -> str:
    for role in ("sample_labels", "events", "signal", "frames", "annotations"):
        if role in nodes and ds.startswith(nodes[role]):
            return role
    if "/trials/" in ds:  # another trial's data: `plot --max-trials 1` never reads it
        for role in ("events", "signals", "frames"):
            if f"/{role}/" in ds or ds.endswith(f"/{role}"):
                return {"signals": "signal"}.get(role, role) + "_other"
    if ds.startswith("/sensors"):
        return "channels"
    if ds.startswith("/provenance"):
        return "provenance"
    return "root"


# ------------------------------------------------------------------- text damage

NON_UTF8 = b"\xff\xfe\xc3\x28\xa0\xa1"


def _edit_text(fn: Callable[[list[bytes]], list[bytes]]) -> Callable[[Path], None]:
    def apply(p: Path) -> None:
        lines = p.read_bytes().splitlines(keepends=True)
        p.write_bytes(b"".join(fn(lines)))
    return apply


def _row(i: int, fn: Callable[[bytes], bytes]):
    def edit(lines: list[bytes]) -> list[bytes]:
        k = min(i, len(lines) - 1)
        lines[k] = fn(lines[k])
        return lines
    return edit


def _cell(row: bytes, col: int, value: bytes) -> bytes:
    cells = row.rstrip(b"\r\n").split(b",")
    cells[col % len(cells)] = value
    return b",".join(cells) + b"\n"


def _csv_mutations(first_col_numeric: bool = True):
    """(mutation, apply) damaging a CSV table whose every row must be read."""
    yield "empty", lambda p: p.write_bytes(b"")
    yield "header-only", _edit_text(lambda ls: ls[:1])
    yield "cut-mid-row", lambda p: p.write_bytes(p.read_bytes().rstrip(b"\n")[:-3])
    yield "non-utf8-row", _edit_text(_row(3, lambda r: r[:2] + NON_UTF8 + r[2:]))
    yield "non-utf8-header", _edit_text(_row(0, lambda r: NON_UTF8 + r))
    yield "text-in-number", _edit_text(_row(4, lambda r: _cell(r, 1, b"banana")))
    yield "nan-cell", _edit_text(_row(5, lambda r: _cell(r, 1, b"nan")))
    yield "inf-cell", _edit_text(_row(5, lambda r: _cell(r, 1, b"inf")))
    yield "missing-cell", _edit_text(_row(6, lambda r: b",".join(r.split(b",")[:-1]) + b"\n"))
    yield "extra-cell", _edit_text(_row(6, lambda r: r.rstrip(b"\n") + b",1,2\n"))
    yield "header-renamed", _edit_text(_row(0, lambda r: r.replace(r.split(b",")[1], b"zzz", 1)))
    yield "nul-bytes", _edit_text(_row(2, lambda r: b"\x00" * 5 + r))
    yield "binary-garbage", lambda p: p.write_bytes(bytes(range(256)) * 8)


def _yaml_mutations(keys: list[tuple[str, str]]):
    """(mutation, apply) for a YAML config; ``keys`` are (dotted key, absurd value text)
    pairs that the config must refuse."""
    yield "yaml-syntax", lambda p: p.write_bytes(p.read_bytes() + b"\n  bad: [unclosed\n")
    yield "yaml-tab-indent", lambda p: p.write_bytes(b"a:\n\t- b\n" + p.read_bytes())
    yield "yaml-unknown-key", lambda p: _yaml_set(p, "surprise_key", 1)
    yield "yaml-empty", lambda p: p.write_bytes(b"")
    yield "yaml-list", lambda p: p.write_bytes(b"- 1\n- 2\n")
    yield "yaml-scalar", lambda p: p.write_bytes(b"42\n")
    yield "yaml-non-utf8", lambda p: p.write_bytes(NON_UTF8 + p.read_bytes())
    yield "yaml-cut", _truncate_text
    yield "yaml-anchor-bomb", lambda p: p.write_bytes(_BOMB)
    for key, value in keys:
        yield f"yaml-{key}={value}", (lambda p, k=key, v=value: _yaml_set(p, k, v, raw=True))


_BOMB = b"a: &a [x, x, x, x, x, x, x, x, x]\n" + b"".join(
    f"{c}: &{c} [*{p}, *{p}, *{p}, *{p}, *{p}, *{p}, *{p}, *{p}, *{p}]\n".encode()
    for p, c in zip("abcdefgh", "bcdefghi", strict=True))


def _replace_text(old: str, new: str) -> Callable[[Path], None]:
    def apply(p: Path) -> None:
        text = p.read_text()
        assert old in text, f"{p} has no {old!r} to replace"
        p.write_text(text.replace(old, new))
    return apply


def _truncate_text(p: Path) -> None:
    data = p.read_bytes()
    p.write_bytes(data[: len(data) // 2])


def _yaml_set(p: Path, dotted: str, value, raw: bool = False) -> None:
    import yaml

    doc = yaml.safe_load(p.read_text())
    node = doc
    keys = dotted.split(".")
    for k in keys[:-1]:
        node = node[int(k)] if isinstance(node, list) else node.setdefault(k, {})
    node[keys[-1]] = yaml.safe_load(str(value)) if raw else value
    p.write_text(yaml.safe_dump(doc, sort_keys=False))


# ---------------------------------------------------------------- command tables

#: chain commands that read every trial's stream, frames, annotations of the file
_SIGNAL_READERS = {"accel-prepare", "features", "detect-delay", "slip-interface",
                   "detect-contact", "slip-signal"}
_FRAME_READERS = {"normal-labels", "heightmap", "slip-signal", "slip-imprint", "monitor"}
# detect-contact scores contact trials (the first is one) by their label contact_s and
# reads annotations of touch trials only
_ANNOTATION_READERS = {"slip-interface"}


def _chain_readers() -> dict[str, set[str]]:
    from .chains import EXTRA_READERS

    return EXTRA_READERS


#: role of the damage -> commands that read it (and so must refuse); "*" every command
H5_READERS = {
    "root": "*",
    "sensor": "*",
    "provenance": {"validate"},
    "trial_attr": {"validate", "info"},
    "split": {"validate", "train"},
    "labels": {"validate"},
    "events": {"validate", "plot", "accumulate", "fit-fos", "frames", "centroids", "slip-rate",
               "grade", "train", "evaluate"},
    "signal": {"validate", "plot", "grade", "train", "evaluate", "perturb",
               *_SIGNAL_READERS},
    "channels": {"validate", "plot", "train", "evaluate", "perturb", "grade",
                 *_SIGNAL_READERS},
    "sample_labels": {"validate", "train", "evaluate", "perturb", "detect-delay",
                      "features"},
    "events_other": {"validate", "accumulate", "fit-fos", "frames", "centroids", "slip-rate",
                     "grade", "train", "evaluate"},
    "signal_other": {"validate", "grade", "train", "evaluate", "perturb",
                     *_SIGNAL_READERS},
    "frames_other": {"validate", *_FRAME_READERS},
    # the runs' classification target
    "label_target": {"train", "evaluate", "perturb", "detect-delay"},
    "annotations": {"validate", "slip-rate", "fit-fos", *_ANNOTATION_READERS},
    "frames": {"validate", "plot", *_FRAME_READERS},
    "meta": set(),  # a flipped byte in metadata may land in free space
    **_chain_readers(),
}

#: damaged training configs that `seed-spread` is also run on (`train` gets every one)
SPREAD_MUTATIONS = ("yaml-syntax", "yaml-empty", "yaml-model.family=transformer",
                    "yaml-optim.lr=.nan", "yaml-version=99", "yaml-data.stream=nope")

H5_COMMANDS = {
    "events": [
        ("info", ["info", "{IN}"]),
        ("validate", ["validate", "{IN}"]),
        ("plot", ["plot", "{IN}", "--out", "{OUT}/plot", "--max-trials", "1"]),
        ("accumulate", ["accumulate", "{IN}", "--segment", "--out", "{OUT}/acc.h5",
                        "--no-progress"]),
        ("fit-fos", ["fit-fos", "{IN}", "--no-write", "--no-order", "--kind", "press",
                     "--max-steps", "8", "--json"]),
        ("frames", ["frames", "{IN}", "--out", "{OUT}/frames", "--sheet-only",
                    "--window-ms", "400", "--sheet-max", "2"]),
        ("centroids", ["centroids", "{IN}", "--rois", "{BASE}/cfg/rois_marker_scene.yaml",
                       "--out", "{OUT}/c.h5", "--no-progress"]),
        ("slip-rate", ["slip-rate", "{IN}", "--rois", "{BASE}/cfg/rois_marker_scene.yaml",
                       "--json"]),
        ("grade", ["grade", "{IN}", "--json"]),
        ("train", ["train", "{BASE}/cfg/train.yaml", "--data", "{IN}", "--out", "{OUT}/run",
                   "--no-progress"]),
        ("evaluate", ["evaluate", "{RUN}", "--data", "{IN}", "--no-latency", "--name", "x"]),
    ],
    "counts": [
        ("info", ["info", "{IN}"]),
        ("validate", ["validate", "{IN}"]),
        ("plot", ["plot", "{IN}", "--out", "{OUT}/plot", "--max-trials", "1"]),
        ("grade", ["grade", "{IN}", "--json"]),
        ("train", ["train", "{BASE}/cfg/train.yaml", "--data", "{IN}", "--out", "{OUT}/run",
                   "--no-progress"]),
        ("evaluate", ["evaluate", "{RUN}", "--data", "{IN}", "--no-latency", "--name", "x"]),
        ("perturb", ["perturb", "{RUN}", "--data", "{IN}", "--kinds", "noise",
                     "--levels", "noise=10", "--name", "x"]),
    ],
    **{kind: [("info", ["info", "{IN}"]), ("validate", ["validate", "{IN}"]),
              ("plot", ["plot", "{IN}", "--out", "{OUT}/plot", "--max-trials", "1"])]
       for kind in ("events_csv", "accel", "taxel", "visuo")},
}
# the sensor chains: their commands on the ingested kinds above and on their own files
H5_COMMANDS["accel"] += [
    ("accel-prepare", ["accel-prepare", "{IN}", "--segment-s", "0.02", "--out", "{OUT}/p.h5",
                       "--no-progress"]),
    ("features", ["features", "spectral", "{IN}", "--stream", "accel", "--window-s", "0.01",
                  "--hop-s", "0.005", "--nperseg", "16", "--out", "{OUT}/f.h5",
                  "--no-progress"])]
H5_COMMANDS["taxel"] += [
    ("features", ["features", "spectral", "{IN}", "--stream", "taxels", "--window-s", "0.2",
                  "--hop-s", "0.1", "--nperseg", "8", "--out", "{OUT}/f.h5", "--no-progress"])]
H5_COMMANDS["visuo"] += [
    ("slip-signal", ["slip-signal", "{IN}", "--source", "intensity", "--n-static", "3",
                     "--no-progress"]),
    ("monitor", ["monitor", "{IN}", "--n-static", "3", "--no-progress"]),
    ("slip-imprint", ["slip-imprint", "{IN}", "--threshold", "0.05", "--no-progress"])]
_CHECK = [("info", ["info", "{IN}"]), ("validate", ["validate", "{IN}"])]
H5_COMMANDS.update({
    "prepared": [*_CHECK, ("detect-delay", [
        "detect-delay", "{BASE}/chains/run_vibro", "--data", "{IN}", "--split", "all",
        "--json"])],
    "taxel_scene": [*_CHECK,
                    ("slip-interface", ["slip-interface", "{IN}", "--folds", "2", "--json",
                                        "--no-progress"]),
                    ("features", ["features", "spectral", "{IN}", "--out", "{OUT}/f.h5",
                                  "--no-progress"])],
    "vibrotouch": [*_CHECK, ("detect-contact", ["detect-contact", "{IN}", "--json"])],
    "calib": [*_CHECK, ("normal-labels", ["normal-labels", "{IN}", "--out", "{OUT}/p.h5",
                                          "--flat-per-press", "200", "--no-progress"])],
    "press": [*_CHECK,
              ("heightmap", ["heightmap", "{IN}", "--model", "{BASE}/chains/run_normals",
                             "--workers", "1", "--out", "{OUT}/h.h5", "--no-progress"]),
              ("slip-signal", ["slip-signal", "{IN}", "--source", "intensity",
                               "--no-progress"]),
              ("monitor", ["monitor", "{IN}", "--no-progress"])],
    "heightmap": [*_CHECK, ("slip-signal", ["slip-signal", "{IN}", "--json",
                                            "--no-progress"])],
})
#: the HDF5 kinds of the sensor chains (base/h5/<kind>.h5)
CHAIN_KINDS = ("prepared", "taxel_scene", "vibrotouch", "calib", "press", "heightmap")


@dataclass
class Corpus:
    root: Path
    base: Path
    damaged: list[Damaged] = field(default_factory=list)
    cases: list[Case] = field(default_factory=list)


def _copy(src: Path, dst: Path) -> None:
    if src.is_dir():
        shutil.copytree(src, dst, symlinks=True)
    else:
        dst.parent.mkdir(parents=True, exist_ok=True)
        shutil.copyfile(src, dst)


def build_corpus(root: Path, *, seed: int = 0, n_random: int = 4) -> Corpus:
    """Every damaged input under ``root/corpus`` and the cases run on them.

    ``n_random`` sets how many seeded random byte flips are made per compressed dataset
    (half that) and in the metadata of each HDF5 file: the corpus grows with it."""
    base = build_bases(root)
    corpus_dir = root / f"corpus-{seed}-{n_random}"
    fresh = not (corpus_dir / ".complete").exists()
    if fresh and corpus_dir.exists():
        shutil.rmtree(corpus_dir)
    rng = np.random.default_rng(seed)
    corpus = Corpus(root=corpus_dir, base=base)

    def add(kind: str, src: Path, entry: str, mutation: str, role: str,
            apply: Callable[[Path], None] | None, harmless: bool = False) -> Damaged:
        name = f"{len(corpus.damaged):04d}-{kind}-{_slug(mutation)}"
        target = corpus_dir / name / entry
        if fresh:
            _copy(src, target if src.is_file() else corpus_dir / name / Path(entry).parts[0])
            if apply is not None:
                apply(target)
        d = Damaged(name, entry, mutation, kind, role, harmless)
        corpus.damaged.append(d)
        return d

    def case(d: Damaged, command: str, argv, expect: str, clash=()) -> None:
        cid = f"{command}:{d.kind}:{d.mutation}"
        n = sum(1 for c in corpus.cases if c.id == cid or c.id.startswith(cid + "#"))
        cid += f"#{n + 1}" if n else ""
        corpus.cases.append(Case(cid, command, tuple(argv), d.name, d.mutation, expect,
                                 tuple(clash)))

    # HDF5 files of each kind, damaged, then every command of that kind on them
    from .chains import add_chain_cases, extra_h5_mutations, harmless_for

    for kind in ("events", "counts", "events_csv", "accel", "taxel", "visuo", *CHAIN_KINDS):
        src = base / "h5" / f"{kind}.h5"
        for mutation, role, apply, harmless in [*_h5_mutations(src, rng, n_random),
                                                *extra_h5_mutations(kind, src)]:
            d = add(kind, src, f"{kind}.h5", mutation, role, apply, harmless)
            if mutation.startswith("flip-chunk") and _decodes_as_before(
                    src, corpus_dir / d.name / d.entry, mutation):
                d.harmless = harmless = True  # see _decodes_as_before
            readers = H5_READERS[role]
            for command, argv in H5_COMMANDS[kind]:
                must = (readers == "*" or command in readers) and not harmless_for(
                    kind, role, mutation, command)
                case(d, command, argv, REFUSE if must and not harmless else EITHER)

    raw = base / "raw"
    # raw event tables
    ingest_events = ["ingest", "{IN}", "--width", "640", "--height", "480",
                     "--out", "{OUT}/o.h5", "--no-progress"]
    # `tactile info` describes every raw format read-only: on a damaged input it may
    # refuse or describe what it can read, but never traceback or write anything
    info_raw = ["info", "{IN}"]
    for mutation, apply in _csv_mutations():
        d = add("events-csv", raw / "events.csv", "events.csv", mutation, "raw", apply)
        case(d, "ingest", ingest_events, REFUSE)
        case(d, "info", info_raw, EITHER)
    for mutation, apply in [
        ("x-65535", _edit_text(_row(7, lambda r: _cell(r, 1, b"65535")))),
        ("y-negative", _edit_text(_row(7, lambda r: _cell(r, 2, b"-4")))),
        ("p-7", _edit_text(_row(7, lambda r: _cell(r, 3, b"7")))),
        ("t-1e30", _edit_text(_row(7, lambda r: _cell(r, 0, b"1e30")))),
        ("t-float", _edit_text(_row(7, lambda r: _cell(r, 0, b"12.5")))),
    ]:
        d = add("events-csv", raw / "events.csv", "events.csv", mutation, "raw", apply)
        case(d, "ingest", ingest_events, REFUSE)
        case(d, "info", info_raw, EITHER)
    d = add("events-csv", raw / "events.csv", "events.csv", "rows-swapped", "raw",
            _edit_text(lambda ls: [ls[0], *ls[1:][::-1]]))
    case(d, "ingest", ingest_events, EITHER)  # sorting them on ingest is a fine answer too
    npy = raw / "events.npy"
    for mutation, apply in [
        ("truncate-0.5", lambda p: _truncate(p, 0.5)),
        ("truncate-header", lambda p: _truncate(p, 0.001)),
        ("flip-magic", lambda p: _flip(p, [0, 1], rng)),
        ("flip-header-dict", lambda p: _flip(p, [20, 30, 40], rng)),
        ("float-nan", lambda p: np.save(p, np.full((100, 4), np.nan))),
        ("1d", lambda p: np.save(p, np.arange(100))),
        ("3d", lambda p: np.save(p, np.zeros((10, 4, 2)))),
        ("strings", lambda p: np.save(p, np.array([["a", "b", "c", "d"]] * 5))),
        ("object-pickle", lambda p: np.save(p, np.array([{"a": 1}], dtype=object),
                                            allow_pickle=True)),
        ("x-65535", lambda p: _npy_field(p, "x", 65535)),
        ("empty", lambda p: np.save(p, np.zeros((0, 4)))),
        ("unsorted", lambda p: _npy_reverse(p)),
    ]:
        d = add("events-npy", npy, "events.npy", mutation, "raw", apply)
        case(d, "ingest", ingest_events, EITHER if mutation == "unsorted" else REFUSE)
        case(d, "info", info_raw, EITHER)
    if (raw / "events.aedat4").exists():
        ae = raw / "events.aedat4"
        ingest_ae = ["ingest", "{IN}", "--out", "{OUT}/o.h5", "--no-progress"]
        for mutation, apply, expect in [
            ("truncate-0.5", lambda p: _truncate(p, 0.5), REFUSE),
            ("truncate-0.999", lambda p: _truncate(p, 0.999), REFUSE),
            ("truncate-header", lambda p: _truncate(p, 0.0005), REFUSE),
            ("trailing-garbage", lambda p: p.write_bytes(p.read_bytes() + b"\x07" * 333), REFUSE),
            ("flip-magic", lambda p: _flip(p, [1, 2], rng), REFUSE),
            ("flip-header", lambda p: _flip(p, [20, 60, 90], rng), REFUSE),
            ("flip-body-0", lambda p: _flip(p, [p.stat().st_size // 2], rng), EITHER),
            ("flip-body-1", lambda p: _flip(p, [p.stat().st_size // 3, 5000], rng), EITHER),
            ("zeros-body", lambda p: _zero(p, p.stat().st_size // 2, 4096), REFUSE),
        ]:
            d = add("aedat4", ae, "events.aedat4", mutation, "raw", apply)
            case(d, "ingest", ingest_ae, expect)
            case(d, "info", info_raw, expect)
    # robot recordings (issue 31): ROS 1 bag, standalone MCAP, MP4; their topic mapping
    robot = raw / "robot"
    if robot.exists():
        ingest_rec = ["ingest", "{IN}", "--mapping", "{BASE}/raw/robot/topics.yaml",
                      "--out", "{OUT}/o.h5", "--no-progress"]
        for name, entry in (("rosbag", "press.bag"), ("mcap", "press.mcap")):
            for mutation, apply, expect in [
                ("truncate-0.5", lambda p: _truncate(p, 0.5), REFUSE),
                ("truncate-0.97", lambda p: _truncate(p, 0.97), REFUSE),
                ("truncate-header", lambda p: _truncate(p, 0.001), REFUSE),
                ("zeros-chunk", lambda p: _zero(p, p.stat().st_size // 3, 4096), EITHER),
                ("flip-body", lambda p: _flip(p, [p.stat().st_size // 2], rng), EITHER),
                ("empty", lambda p: p.write_bytes(b""), REFUSE),
            ]:
                d = add(name, robot / entry, entry, mutation, "raw", apply)
                case(d, "ingest", ingest_rec, expect)
                case(d, "info", info_raw, expect)
        ingest_video = ["ingest", "{IN}", "--out", "{OUT}/o.h5", "--no-progress"]
        for mutation, apply in [("truncate-0.5", lambda p: _truncate(p, 0.5)),
                                ("truncate-header", lambda p: _truncate(p, 0.01)),
                                ("empty", lambda p: p.write_bytes(b""))]:
            d = add("video", robot / "press.mp4", "press.mp4", mutation, "raw", apply)
            case(d, "ingest", ingest_video, REFUSE)
            case(d, "info", info_raw, EITHER)
        # well-formed recordings with one fault in what they hold (robot_cases.py)
        from .robot_cases import CASES as ROBOT_CASES

        for mutation, (file, stream) in ROBOT_CASES.items():
            d = add("robot-content", raw / "robot_cases" / file, file, mutation, "raw", None)
            argv = (["ingest", "{IN}", "--out", "{OUT}/o.h5", "--no-progress"]
                    if stream is None else
                    ["ingest", "{IN}", "--mapping",
                     f"{{BASE}}/raw/robot_cases/{Path(file).stem}.yaml", "--out", "{OUT}/o.h5",
                     "--no-progress"])
            case(d, "ingest", argv, REFUSE)
            case(d, "info", info_raw, EITHER)
        # the sample bag under a topic mapping that does not fit it
        ingest_by_map = ["ingest", "{BASE}/raw/robot/press.bag", "--mapping", "{IN}",
                         "--out", "{OUT}/o.h5", "--no-progress"]
        for mutation, apply in [
            ("topic-missing", _replace_text("/taxels", "/gelsight")),
            ("field-path-missing", _replace_text(
                "kind: force_torque", "kind: force_torque\n    fields: [wrench.force.w]")),
            ("kind-unknown", _replace_text("kind: taxel_array", "kind: skin")),
            ("kind-wrong-for-type", _replace_text("kind: force_torque", "kind: visuotactile")),
            ("reference-beyond-frames", _replace_text("reference: first", "reference: 9999")),
            ("marker-topic-missing", _replace_text("/trial_marker", "/no_marker")),
        ]:
            d = add("topic-mapping", robot / "topics.yaml", "topics.yaml", mutation, "raw",
                    apply)
            case(d, "ingest", ingest_by_map, REFUSE)
    # annotations and trial labels of an ingest
    for name, flag in (("annotations.csv", "--annotations"),
                       ("trial_labels.csv", "--trial-labels")):
        muts = list(_csv_mutations())
        if name == "annotations.csv":
            muts += [("end-before-start", _edit_text(_row(1, lambda r: b"events,0.5,0.1,press\n"))),
                     ("unknown-trial", _edit_text(_row(1, lambda r: b"nobody,0.0,0.1,press\n"))),
                     ("free-label", _edit_text(_row(1, lambda r: b"events,0.0,0.1,dance\n")))]
        for mutation, apply in muts:
            d = add(name.split(".")[0], base / name, name, mutation, "raw", apply)
            # a free-form annotation label, or another trial-label column name, is fine; a
            # file cut inside its last cell still parses (hand-written files may lack the
            # final newline, so that is not refused); one text label cannot be told from
            # a number column that has a single row
            harmless = mutation in ("free-label", "cut-mid-row") or (
                name == "trial_labels.csv" and mutation in ("header-renamed",
                                                            "text-in-number"))
            case(d, "ingest", ["ingest", "{BASE}/raw/events.csv", "--width", "640",
                               "--height", "480", flag, "{IN}", "--out", "{OUT}/o.h5",
                               "--no-progress"], EITHER if harmless else REFUSE)
    # accelerometer tree
    accel_csv = "accel_tree/wood/0/0.16/data.csv"
    ingest_accel = ["ingest", "{IN}", "--format", "accel-tree", "--out", "{OUT}/o.h5",
                    "--no-progress"]
    accel_muts = [*list(_csv_mutations()),
                  ("swapped-slip-slide", _edit_text(_row(0, lambda r: r.replace(
                      b"slip_v,slide_v", b"slide_v,slip_v")))),
                  ("dropped-column", _edit_text(lambda ls: [b",".join(x.split(b",")[:-1])
                                                            + b"\n" for x in ls]))]
    for mutation, apply in accel_muts:
        d = add("accel-tree", raw / "accel_tree", accel_csv, mutation, "raw", apply)
        case(d, "ingest", ingest_accel.copy(), REFUSE)
        case(d, "info", ["info", "{IN}", "--format", "accel-tree"], EITHER)
        corpus.damaged[-1].entry = "accel_tree"
    # taxel CSVs and their mapping
    ingest_taxel = ["ingest", "{IN}", "--mapping", "{BASE}/cfg/taxels.yaml", "--out",
                    "{OUT}/o.h5", "--no-progress"]
    for mutation, apply in [*_csv_mutations(),
                            ("time-reversed", _edit_text(lambda ls: [ls[0], *ls[1:][::-1]])),
                            ("time-repeated", _edit_text(_row(3, lambda r: r)))]:
        if mutation == "time-repeated":
            apply = _edit_text(lambda ls: [*ls[:4], ls[3], *ls[4:]])
        d = add("taxel-csv", raw / "taxel", "taxel/foam_1.csv", mutation, "raw", apply)
        corpus.damaged[-1].entry = "taxel"
        # a renamed channel column may simply fall outside the mapping's channel pattern
        case(d, "ingest", ingest_taxel, EITHER if mutation == "header-renamed" else REFUSE)
        case(d, "info", ["info", "{IN}", "--mapping", "{BASE}/cfg/taxels.yaml"], EITHER)
    for mutation, apply in _yaml_mutations([("streams.0.units", "[1, 2]"),
                                            ("streams.0.channels", "[nothing_matches*]"),
                                            ("trials.pattern", "'(unclosed'"),
                                            ("streams.0.time.unit", "fortnight")]):
        d = add("mapping", base / "cfg" / "taxels.yaml", "taxels.yaml", mutation, "config", apply)
        case(d, "ingest", ["ingest", "{BASE}/raw/taxel", "--mapping", "{IN}", "--out",
                           "{OUT}/o.h5", "--no-progress"], REFUSE)
        case(d, "info", ["info", "{BASE}/raw/taxel", "--mapping", "{IN}"], REFUSE)
    # image folders
    ingest_img = ["ingest", "{IN}", "--out", "{OUT}/o.h5", "--no-progress"]
    ts = "press_01/timestamps.csv"
    for mutation, apply, target in [
        ("ts-non-utf8", _edit_text(_row(2, lambda r: NON_UTF8 + r)), ts),
        ("ts-empty", lambda p: p.write_bytes(b""), ts),
        ("ts-text", _edit_text(_row(3, lambda r: b"soon\n")), ts),
        ("ts-nan", _edit_text(_row(3, lambda r: b"nan\n")), ts),
        ("ts-reversed", _edit_text(lambda ls: [ls[0], *ls[1:][::-1]]), ts),
        ("ts-short", _edit_text(lambda ls: ls[:4]), ts),
        ("png-truncated", lambda p: _truncate(p, 0.5), "press_01/frame_3.png"),
        ("png-random", lambda p: p.write_bytes(bytes(rng.integers(0, 256, 4000, np.uint8))),
         "press_01/frame_3.png"),
        ("png-flip", lambda p: _flip(p, [p.stat().st_size // 2], rng), "press_01/frame_3.png"),
        ("png-empty", lambda p: p.write_bytes(b""), "press_01/frame_5.png"),
        ("png-other-size", lambda p: _png(p, (7, 5)), "press_01/frame_4.png"),
        ("png-missing", lambda p: p.unlink(), "press_01/frame_2.png"),
    ]:
        d = add("images", raw / "visuotactile", f"visuotactile/{target}", mutation, "raw", apply)
        d.entry = "visuotactile/press_01"
        case(d, "ingest", ingest_img, EITHER if mutation == "png-flip" else REFUSE)
        case(d, "info", info_raw, EITHER)

    # configs
    cfg = base / "cfg"
    train_argv = ["train", "{IN}", "--data", "{BASE}/h5/counts.h5", "--out", "{OUT}/run",
                  "--no-progress"]
    spread_argv = ["seed-spread", "{IN}", "--data", "{BASE}/h5/counts.h5", "--out",
                   "{OUT}/spread", "--cv", "2", "--seeds", "0,1", "--no-progress"]
    for mutation, apply in _yaml_mutations([
            ("data.window", "1000000000000"), ("data.window", "0"), ("data.stride", "-1"),
            ("model.hidden", "[1000000000000]"), ("optim.threads", "1000000"),
            ("optim.lr", ".nan"), ("optim.lr", "-1"), ("optim.epochs", "'many'"),
            ("optim.batch_size", "0"), ("data.channels", "[nope]"), ("data.stream", "nope"),
            ("data.bin_s", "1e-300"), ("data.split.val_fraction", "1.5"),
            ("model.family", "transformer"), ("seed", "'abc'"), ("version", "99"),
            ("data.targets", "[]")]):
        d = add("train-config", cfg / "train.yaml", "train.yaml", mutation, "config", apply)
        case(d, "train", train_argv, REFUSE)
        if mutation in SPREAD_MUTATIONS:  # seed-spread reads the same config
            case(d, "seed-spread", spread_argv, REFUSE)
    for mutation, apply in _yaml_mutations([
            ("output.resolution", "1000000000000"), ("output.resolution", "-5"),
            ("input.range", "[5, 1]"), ("input.terms.small.params", "[4, 3, 2, 1]"),
            ("input.terms.small.mf", "sinmf"), ("rules", "[{if: nothing, then: big}]"),
            ("feature.bin_s", "0"), ("levels_per_grade", "-2"),
            ("input.terms.small.params", "[.nan, 1, 2, 3]")]):
        d = add("grade-config", cfg / "grade_marker.yaml", "grade.yaml", mutation, "config",
                apply)
        case(d, "grade", ["grade", "{BASE}/h5/events.h5", "--config", "{IN}", "--json"], REFUSE)
        case(d, "grade", ["grade", "{BASE}/grade_table.csv", "--config", "{IN}", "--json"],
             REFUSE)
    for mutation, apply in _yaml_mutations([
            ("rois.0.x1_px", "-10"), ("rois.0.x0_px", "100000"), ("sensor.width_px", "0"),
            ("optics.pixel_pitch_m", "-1"), ("optics.focal_length_m", "0"),
            ("centroid.polarity", "sideways"), ("rois", "[]")]):
        d = add("rois", cfg / "rois_marker_scene.yaml", "rois.yaml", mutation, "config", apply)
        for command, argv in [
            ("slip-rate", ["slip-rate", "{BASE}/h5/events.h5", "--rois", "{IN}", "--json"]),
            ("centroids", ["centroids", "{BASE}/h5/events.h5", "--rois", "{IN}", "--out",
                           "{OUT}/c.h5", "--no-progress"]),
            ("frames", ["frames", "{BASE}/h5/events.h5", "--rois", "{IN}", "--out",
                        "{OUT}/frames", "--sheet-only", "--window-ms", "400",
                        "--sheet-max", "2"])]:
            if mutation == "yaml-centroid.polarity=sideways" and command != "centroids":
                continue
            case(d, command, argv, REFUSE)
    for mutation, apply in _yaml_mutations([
            ("bin_s", "0"), ("levels.n_levels", "1000000000000"),
            ("background_per_bin", "[1e300, 1e300]"), ("width_px", "-3"),
            ("timing.slip_s", "[5, 1]"), ("fos.tau_press_s", "-0.3")]):
        d = add("synth-config", cfg / "synth_fos.yaml", "synth.yaml", mutation, "config", apply)
        case(d, "synth", ["synth", "--config", "{IN}", "--n", "3", "--out", "{OUT}/s.h5",
                          "--no-progress"], REFUSE)
    # CSV inputs of grade and fit-fos
    for mutation, apply in _csv_mutations():
        d = add("grade-table", base / "grade_table.csv", "table.csv", mutation, "raw", apply)
        case(d, "grade", ["grade", "{IN}", "--json"],
             EITHER if mutation == "extra-cell" else REFUSE)
    for mutation, apply in [*_csv_mutations(),
                            ("t-reversed", _edit_text(lambda ls: [ls[0], *ls[1:][::-1]]))]:
        d = add("fos-csv", base / "fos_curve.csv", "curve.csv", mutation, "raw", apply)
        case(d, "fit-fos", ["fit-fos", "{IN}", "--model", "step", "--json", "--no-order"],
             EITHER if mutation in ("extra-cell", "header-renamed") else REFUSE)

    # damaged run folders
    run = base / "run"
    run_files = sorted(p.name for p in run.iterdir() if p.is_file())
    run_muts: list[tuple[str, str, Callable[[Path], None]]] = []
    for name in run_files:
        if name.endswith(".json"):
            run_muts += [(f"{name}-cut", name, _truncate_text),
                         (f"{name}-empty-object", name, lambda p: p.write_text("{}")),
                         (f"{name}-list", name, lambda p: p.write_text("[1, 2]")),
                         (f"{name}-drop-key", name, _json_drop_key),
                         (f"{name}-non-utf8", name, lambda p: p.write_bytes(NON_UTF8))]
        elif name.endswith((".yaml", ".yml")):
            run_muts += [(f"{name}-syntax", name, lambda p: p.write_text("a: [b\n")),
                         (f"{name}-unknown-key", name, lambda p: _yaml_set(p, "surprise", 1)),
                         (f"{name}-cut", name, _truncate_text)]
        elif name.endswith((".pt", ".pth")):
            run_muts += [(f"{name}-random", name,
                          lambda p: p.write_bytes(bytes(rng.integers(0, 256, 4096, np.uint8)))),
                         (f"{name}-truncated", name, lambda p: _truncate(p, 0.5)),
                         (f"{name}-empty", name, lambda p: p.write_bytes(b""))]
        run_muts.append((f"{name}-missing", name, lambda p: p.unlink()))
    if (run / "normalisation.json").exists():
        run_muts += [("normalisation-std-0", "normalisation.json", lambda p: _json_numbers(p, 0.0)),
                     ("normalisation-nan", "normalisation.json",
                      lambda p: _json_numbers(p, float("nan")))]
    for mutation, target, apply in run_muts:
        d = add("run", run, f"run/{target}", mutation, "run", apply)
        d.entry = "run"
        for command, argv in [
            ("evaluate", ["evaluate", "{IN}", "--data", "{BASE}/h5/counts.h5", "--no-latency",
                          "--name", "x"]),
            ("perturb", ["perturb", "{IN}", "--data", "{BASE}/h5/counts.h5", "--kinds",
                         "noise", "--levels", "noise=10", "--name", "x"]),
            ("compare", ["compare", "{IN}", "{BASE}/run", "--json"]),
            ("report", ["report", "{IN}", "--out", "{OUT}/report"])]:
            # compare and report read run.json and the evaluation's metrics only; the
            # training's own records (curves, history, split) are not needed by any of them
            reads = command in ("evaluate", "perturb") or target.startswith(("run", "eval"))
            reads = reads and target not in ("curves.png", "history.csv", "split.csv")
            case(d, command, argv, REFUSE if reads else EITHER)

    # a damaged seed-spread folder: its record, or a seed's run gone (kind "run": no new
    # kind for the fast subset; `info` reads the record alone)
    spread = base / "spread"
    for mutation, target, apply in [
            ("seed_spread.json-cut", "seed_spread.json", _truncate_text),
            ("seed_spread.json-empty-object", "seed_spread.json", lambda p: p.write_text("{}")),
            ("seed_spread.json-list", "seed_spread.json", lambda p: p.write_text("[1, 2]")),
            ("seed_spread.json-drop-key", "seed_spread.json", _json_drop_key),
            ("seed_spread.json-non-utf8", "seed_spread.json",
             lambda p: p.write_bytes(NON_UTF8)),
            ("spread-seed-run-missing", "seed_1", lambda p: shutil.rmtree(p))]:
        d = add("run", spread, f"spread/{target}", mutation, "run", apply)
        d.entry = "spread"
        record_damaged = target == "seed_spread.json" and not mutation.endswith("drop-key")
        for command, argv in [
                ("info", ["info", "{IN}"]),
                ("compare", ["compare", "{IN}", "--json"]),
                ("report", ["report", "{IN}", "--out", "{OUT}/report"]),
                # a spread scored on other data: this one is cross-validated (refused too)
                ("evaluate", ["evaluate", "{IN}", "--data", "{BASE}/h5/counts.h5", "--name",
                              "x", "--no-latency"])]:
            refuse = record_damaged or command == "evaluate" or (
                target == "seed_1" and command != "info")
            case(d, command, argv, REFUSE if refuse else EITHER)

    # clashing outputs: a file where a folder is expected and the reverse (valid inputs)
    ev = "{BASE}/h5/events.h5"
    clashes = [
        ("plot", ["plot", ev, "--out", "{OUT}/x"], "file:x"),
        ("plot", ["plot", ev, "--out", "{OUT}/f/x"], "file:f"),
        ("frames", ["frames", ev, "--out", "{OUT}/x", "--sheet-only", "--window-ms", "400",
                    "--sheet-max", "2"], "file:x"),
        ("slip-rate", ["slip-rate", ev, "--rois", "{BASE}/cfg/rois_marker_scene.yaml",
                       "--plot", "{OUT}/x"], "file:x"),
        ("accumulate", ["accumulate", ev, "--plot", "{OUT}/x", "--no-progress"], "file:x"),
        ("accumulate", ["accumulate", ev, "--out", "{OUT}/x", "--no-progress"], "dir:x"),
        ("accumulate", ["accumulate", ev, "--csv", "{OUT}/x", "--no-progress"], "dir:x"),
        ("grade", ["grade", ev, "--plot", "{OUT}/x"], "file:x"),
        ("fit-fos", ["fit-fos", ev, "--no-write", "--no-order", "--kind", "press",
                     "--max-steps", "8", "--plot", "{OUT}/x"], "file:x"),
        ("fit-fos", ["fit-fos", ev, "--no-write", "--no-order", "--kind", "press",
                     "--max-steps", "8", "--csv", "{OUT}/x"], "dir:x"),
        ("centroids", ["centroids", ev, "--rois", "{BASE}/cfg/rois_marker_scene.yaml",
                       "--out", "{OUT}/x", "--no-progress"], "dir:x"),
        ("ingest", ["ingest", "{BASE}/raw/events.csv", "--width", "640", "--height", "480",
                    "--out", "{OUT}/x", "--no-progress"], "dir:x"),
        ("ingest", ["ingest", "{BASE}/raw/events.csv", "--width", "640", "--height", "480",
                    "--out", "{OUT}/f/x.h5", "--no-progress"], "file:f"),
        ("synth", ["synth", "--n", "3", "--out", "{OUT}/x", "--no-progress"], "dir:x"),
        ("train", ["train", "{BASE}/cfg/train.yaml", "--data", "{BASE}/h5/counts.h5", "--out",
                   "{OUT}/x", "--no-progress"], "file:x"),
        ("evaluate", ["evaluate", "{RUN}", "--data", "{BASE}/h5/counts.h5", "--no-latency",
                      "--name", "x"], "run-eval-file"),
        ("compare", ["compare", "{BASE}/run", "--out", "{OUT}/x"], "file:x"),
        ("report", ["report", "{BASE}/run", "--out", "{OUT}/x"], "file:x"),
        ("grade", ["grade", "{BASE}/h5/events.h5", "--calibrate", "--out", "{OUT}/x"], "dir:x"),
    ]
    for i, (command, argv, clash) in enumerate(clashes):
        d = add("clash", base / "annotations.csv", "unused", f"{command}-{clash}-{i}", "clash",
                None)
        case(d, command, argv, REFUSE, clash=(clash,))

    # symlink loops where an input is expected
    loop_cmds = [(c, a) for c, a in H5_COMMANDS["events"]] + [
        ("ingest", ingest_events), ("train", train_argv),
        ("grade", ["grade", "{BASE}/h5/events.h5", "--config", "{IN}"]),
        ("slip-rate", ["slip-rate", "{BASE}/h5/events.h5", "--rois", "{IN}"]),
        ("compare", ["compare", "{IN}"]), ("report", ["report", "{IN}", "--out", "{OUT}/r"])]
    d = add("symlink", base / "annotations.csv", "loop", "symlink-loop", "link", None)
    if fresh:
        loop = corpus_dir / d.name / "loop"
        loop.unlink()
        os.symlink("loop", loop)
    for command, argv in loop_cmds:
        case(d, command, [a if a not in ("{RUN}",) else "{IN}" for a in argv], REFUSE)

    add_chain_cases(add, case, base, rng)
    from .outputs import add_output_cases

    add_output_cases(add, case, base)

    from .learn_outputs import add_learn_output_cases

    add_learn_output_cases(add, case, base, REFUSE)

    if fresh:
        (corpus_dir / ".complete").write_text("ok\n")
    return corpus


def _slug(text: str) -> str:
    return "".join(c if c.isalnum() or c in "-_." else "_" for c in text)[:60]


def _zero(p: Path, at: int, n: int) -> None:
    data = bytearray(p.read_bytes())
    data[at:at + n] = bytes(min(n, len(data) - at))
    p.write_bytes(bytes(data))


def _npy_field(p: Path, name: str, value: int) -> None:
    arr = np.load(p)
    if arr.dtype.names:
        arr[name][len(arr) // 2] = value
    else:
        arr[len(arr) // 2, 1] = value
    np.save(p, arr)


def _npy_reverse(p: Path) -> None:
    np.save(p, np.load(p)[::-1].copy())


def _png(p: Path, size: tuple[int, int]) -> None:
    from PIL import Image

    Image.new("RGB", size).save(p)


def _json_drop_key(p: Path) -> None:
    doc = json.loads(p.read_text())
    if isinstance(doc, dict) and doc:
        del doc[sorted(doc)[0]]
    p.write_text(json.dumps(doc))


def _json_numbers(p: Path, value: float) -> None:
    def walk(x):
        if isinstance(x, dict):
            return {k: walk(v) for k, v in x.items()}
        if isinstance(x, list):
            return [walk(v) for v in x]
        if isinstance(x, float):
            return value
        return x
    p.write_text(json.dumps(walk(json.loads(p.read_text()))))
