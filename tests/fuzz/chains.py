"""The sensor chains in the damaged-input corpus: their bases and side-file cases.

:func:`build_chain_bases` adds, under the corpus bases, the smallest valid inputs of each
chain (about 40 s on 2 cores): a vibro-slip scene ingested and prepared (``prepared.h5``)
with a tiny motion run, a PVDF taxel-slip scene, a VibroTouch scene, a small DIGIT press
scene ingested twice (ball presses ``calib.h5``, trials ``press.h5``) with a tiny normal
MLP and one trial's height maps (``heightmap.h5``), the scene configs of every simulator,
the feature, detector, lumped-model and sweep configs, and an image-sequence folder with a
``labels.json``. Their HDF5 files are damaged by :func:`corpus._h5_mutations` plus the
chain-specific damage of :func:`extra_h5_mutations`; :func:`add_chain_cases` adds the
damaged side files (scene and command configs, ``labels.json``, truth ``.npz`` files,
run folders, scene folders) and the clashing outputs of the chain commands.
"""

from __future__ import annotations

import json
import shutil
from collections.abc import Callable, Iterator
from pathlib import Path

import h5py
import numpy as np

#: the commands of the sensor chains (``simulate`` and ``features`` with their subcommand)
CHAIN_COMMANDS = ("accel-prepare", "detect-delay", "features", "slip-interface",
                  "vibro-model", "detect-contact", "normal-labels", "heightmap",
                  "slip-signal", "monitor", "simulate", "export", "sweep")

#: the smallest scenes the simulators allow (the first line of each file is its whole
#: mapping in flow style, so that a cut file is broken YAML rather than a smaller scene)
SCENES = {
    "vibro_slip": {"orientations_deg": [0], "motor_rps": [0.16, 0.48], "duration_s": 1.0},
    "vibrotouch": {"contact_trials": 1, "touch_trials": 1, "touches_per_trial": 2,
                   "gap_mm": [0.02, 0.03], "after_contact_s": 2.0},
    "taxel_slip": {"presets": ["pvdf"], "trials_per_class": 3, "slip_s": 1.2},
    "digit_press": {"version": 1,
                    "optics": {"width_px": 96, "height_px": 72, "px_per_mm": 8.0},
                    "calibration": {"presses": 2, "margin_px": 20},
                    "trials": {"objects": ["hex_key_small"], "per_object": 2,
                               "duration_s": 1.5, "static_s": [1.2, 1.22],
                               "slip_s": [0.1, 0.2]}},
    "digit_avoidance": {"version": 1, "optics": {"width_px": 160, "height_px": 120},
                        "objects": ["cable"], "interferences": 1, "tail_s": 3.5,
                        "repeat_after_s": None},
    "marker_events": {"trials": {"groups": 1, "levels": [1]}},
}
SIMULATORS = {"vibro_slip": "vibro-slip", "vibrotouch": "vibrotouch",
              "taxel_slip": "taxel-slip", "digit_press": "digit-press",
              "digit_avoidance": "digit-avoidance", "marker_events": "marker-events"}

PRESS_TRIAL = "hex_key_small_01"  # the press scene's slipping trial


def _flow_yaml(doc: dict) -> str:
    return json.dumps(doc) + "\n"  # JSON is YAML in flow style


def _tiny_train(src: Path, dst: Path, replace: dict[str, str]) -> None:
    text = src.read_text()
    for old, new in replace.items():
        assert old in text, (src, old)
        text = text.replace(old, new)
    dst.write_text(text)


def sim_argv(scene: str, config: str, out: str) -> list[str]:
    """``tactile simulate <scene>`` writing ``out`` from ``config``."""
    name = SIMULATORS[scene]
    where = [out] if scene in ("digit_press", "digit_avoidance") else ["--out", out]
    return ["simulate", name, *where, "--config", config, "--no-progress"]


def build_chain_bases(base: Path, tactile: Callable[[list[str], Path], None],
                      repo: Path) -> None:
    """The chains' valid inputs under ``base`` (see the module's docstring)."""
    ch = base / "chains"
    cfg = base / "cfg"
    h5 = base / "h5"
    ch.mkdir()
    for scene, doc in SCENES.items():
        (cfg / f"scene_{scene}.yaml").write_text(_flow_yaml(doc))
    for name in ("detect_contact.yaml", "taxel_features.yaml", "vibro_model.yaml"):
        shutil.copyfile(repo / "configs" / name, cfg / name)
    _tiny_train(repo / "configs" / "train_fnn_vibro.yaml", cfg / "fnn_vibro.yaml",
                {"hidden: [512, 256]": "hidden: [8]", "epochs: 20": "epochs: 1"})
    _tiny_train(repo / "configs" / "train_mlp_normals.yaml", cfg / "mlp_normals.yaml",
                {"hidden: [32, 32, 32]": "hidden: [4]", "epochs: 40": "epochs: 1"})
    (cfg / "sweep.yaml").write_text(_flow_yaml({
        "version": 1, "name": "fuzz", "train_data": [str(h5 / "prepared.h5")],
        "eval": {"data": [str(h5 / "prepared.h5")], "split": "test"},
        "models": {"fnn": {"config": str(cfg / "fnn_vibro.yaml")}},
        "windows": [{"window": 400, "stride": 400}],
        "channel_sets": {"Lx": ["L_x"]},
        "overrides": {"optim.epochs": 1, "optim.patience": 0}}))

    def sim(scene: str, out: Path) -> None:
        tactile(sim_argv(scene, str(cfg / f"scene_{scene}.yaml"), str(out)), base)

    # accelerometer chain (paper 001)
    sim("vibro_slip", ch / "vibro_slip")
    tactile(["ingest", str(ch / "vibro_slip"), "--format", "accel-tree", "--out",
             str(ch / "accel_scene.h5"), "--no-progress"], base)
    tactile(["accel-prepare", str(ch / "accel_scene.h5"), "--out", str(h5 / "prepared.h5"),
             "--segment-s", "0.5", "--no-progress"], base)
    tactile(["train", str(cfg / "fnn_vibro.yaml"), "--data", str(h5 / "prepared.h5"),
             "--out", str(ch / "run_vibro"), "--no-progress"], base)
    # taxel arrays (paper 004) and VibroTouch (paper 003)
    sim("taxel_slip", h5 / "taxel_scene.h5")
    sim("vibrotouch", h5 / "vibrotouch.h5")
    # DIGIT (paper 002): ball presses, the normal MLP, trials and one trial's height maps
    dp = ch / "digit_press"
    sim("digit_press", dp)
    tactile(["ingest", str(dp / "calibration"), "--trial-labels",
             str(dp / "calibration_labels.csv"), "--px-per-mm", "8", "--out",
             str(h5 / "calib.h5"), "--no-progress"], base)
    tactile(["ingest", str(dp / "trials"), "--trial-labels", str(dp / "trial_labels.csv"),
             "--px-per-mm", "8", "--out", str(h5 / "press.h5"), "--no-progress"], base)
    tactile(["normal-labels", str(h5 / "calib.h5"), "--out", str(ch / "pixels.h5"),
             "--flat-per-press", "200", "--no-progress"], base)
    tactile(["train", str(cfg / "mlp_normals.yaml"), "--data", str(ch / "pixels.h5"),
             "--out", str(ch / "run_normals"), "--no-progress"], base)
    tactile(["heightmap", str(h5 / "press.h5"), "--model", str(ch / "run_normals"),
             "--trial", PRESS_TRIAL, "--workers", "1", "--out", str(h5 / "heightmap.h5"),
             "--no-progress"], base)
    # an image-sequence folder with its labels.json
    labeled = ch / "labeled"
    shutil.copytree(base / "raw" / "visuotactile" / "press_01", labeled / "press_01")
    (labeled / "press_01" / "labels.json").write_text(
        json.dumps({"object": "cable", "force_n": 1.5, "split": "train"}) + "\n")


# ----------------------------------------------------------------- HDF5 of the chains

def _edit(fn: Callable[[h5py.File], None]) -> Callable[[Path], None]:
    def apply(p: Path) -> None:
        with h5py.File(p, "r+") as f:
            fn(f)
    return apply


def _set_attr(path: str, name: str, value) -> Callable[[Path], None]:
    return _edit(lambda f: f[path].attrs.__setitem__(name, value))


def _del_attr(path: str, name: str) -> Callable[[Path], None]:
    return _edit(lambda f: f[path].attrs.__delitem__(name))


def extra_h5_mutations(kind: str, path: Path
                       ) -> Iterator[tuple[str, str, Callable[[Path], None], bool]]:
    """(mutation, role, apply, harmless): damage only a chain's command reads."""
    with h5py.File(path, "r") as f:
        trials = sorted(f["trials"])
        sensors = sorted(f["sensors"])
    t = f"/trials/{trials[0]}"
    if kind in ("calib", "press"):
        s = f"/sensors/{sensors[0]}"
        for value, tag in ((0.0, "0"), (float("nan"), "nan"), ("wide", "str")):
            yield f"px_per_mm-{tag}", "px_per_mm", _set_attr(s, "px_per_mm", value), False
        yield "del-reference", "frames", _edit(
            lambda f: f.__delitem__(f"{t}/frames/reference")), False
        yield "reference-small", "frames", _edit(lambda f: _resize_reference(f, t)), False
    if kind == "calib":
        for value, tag in ((float("nan"), "nan"), (-2.0, "neg"), ("big", "str")):
            yield (f"ball_radius-{tag}", "ball", _set_attr(f"{t}/labels", "ball_radius_mm",
                                                           value), False)
        yield "del-ball_radius", "ball", _del_attr(f"{t}/labels", "ball_radius_mm"), False
    if kind == "taxel_scene":
        yield "slip-label-bogus", "slip_label", _set_attr(f"{t}/labels", "slip", "sideways"), \
            False
        yield "del-slip-label", "slip_label", _del_attr(f"{t}/labels", "slip"), False
        # a trial recorded with one finger is a valid one (scene config `fingers: 1`)
        yield "del-f1-stream", "finger", _edit(
            lambda f: f.__delitem__(f"{t}/signals/{sensors[1]}")), True
    if kind == "vibrotouch":
        # the force stream is optional: without it only the vibration trigger runs
        yield "del-force-stream", "force", _edit(
            lambda f: f.__delitem__(f"{t}/signals/force")), True
        yield "scenario-bogus", "scenario", _set_attr(f"{t}/labels", "scenario", "party"), False
    if kind == "heightmap":
        g = f"{t}/signals/height_mm"
        yield "height-shape-odd", "signal", _edit(
            lambda f: _replace_data(f, g, f[g + "/data"][:, :-7])), False


def _replace_data(f: h5py.File, group: str, data: np.ndarray) -> None:
    del f[group + "/data"]
    f.create_dataset(group + "/data", data=data)


def _resize_reference(f: h5py.File, trial: str) -> None:
    ref = f[f"{trial}/frames/reference"][()]
    del f[f"{trial}/frames/reference"]
    f.create_dataset(f"{trial}/frames/reference", data=ref[: ref.shape[0] // 2])


#: role of chain-specific damage -> commands that read it
EXTRA_READERS = {
    "px_per_mm": {"normal-labels", "heightmap"},
    "ball": {"normal-labels"},
    "slip_label": {"slip-interface", "features"},
    "finger": set(),
    "force": {"detect-contact"},
    "scenario": {"detect-contact"},
}


# ------------------------------------------------------------------- side-file cases

def _json_mutations(NON_UTF8: bytes) -> list[tuple[str, Callable[[Path], None]]]:
    """(mutation, apply) for a small JSON object file."""
    return [
        ("json-syntax", lambda p: p.write_text('{"object": "cable",')),
        ("json-empty", lambda p: p.write_bytes(b"")),
        ("json-list", lambda p: p.write_text("[1, 2]")),
        ("json-non-utf8", lambda p: p.write_bytes(NON_UTF8 + p.read_bytes())),
        ("json-nan", lambda p: p.write_text('{"object": "cable", "force_n": NaN}')),
        ("json-nested", lambda p: p.write_text('{"object": {"a": [1, {"b": 2}]}}')),
        ("json-split-bogus", lambda p: p.write_text('{"object": "cable", "split": "later"}')),
        ("json-split-int", lambda p: p.write_text('{"object": "cable", "split": 3}')),
    ]


def _npz_mutations(rng: np.random.Generator, truncate) -> list[tuple[str, Callable]]:
    """(mutation, apply) for a truth ``.npz`` holding ``height_mm`` and other arrays."""
    def resave(fn):
        def apply(p: Path) -> None:
            with np.load(p, allow_pickle=False) as z:
                arrays = {k: z[k] for k in z.files}
            np.savez(p.with_suffix(""), **fn(arrays))  # np.savez appends .npz
        return apply

    def pickled(p: Path) -> None:
        np.savez(p.with_suffix(""), height_mm=np.array([{"a": 1}], dtype=object))

    return [
        ("npz-truncated", lambda p: truncate(p, 0.5)),
        ("npz-empty", lambda p: p.write_bytes(b"")),
        ("npz-random", lambda p: p.write_bytes(bytes(rng.integers(0, 256, 4096, np.uint8)))),
        ("npz-pickled", pickled),
        ("npz-missing", lambda p: p.unlink()),
        ("npz-no-height", resave(lambda a: {k + "_x": v for k, v in a.items()})),
        ("npz-height-short", resave(lambda a: {**a, "height_mm": a["height_mm"][:3]})),
        ("npz-height-str", resave(lambda a: {**a, "height_mm": np.full(
            a["height_mm"].shape[:1], "x")})),
        ("npz-height-nan", resave(lambda a: {**a, "height_mm": a["height_mm"] * np.nan})),
    ]


def add_chain_cases(add, case, base: Path, rng: np.random.Generator) -> None:
    """The chains' side files, damaged, and their clashing outputs (see the docstring)."""
    from .corpus import (
        EITHER,
        NON_UTF8,
        REFUSE,
        _csv_mutations,
        _truncate,
        _truncate_text,
        _yaml_mutations,
    )

    cfg = base / "cfg"
    ch = base / "chains"
    h5 = "{BASE}/h5"
    _scene_configs(add, case, cfg, _yaml_mutations, REFUSE)
    _command_configs(add, case, cfg, _yaml_mutations, REFUSE, EITHER)
    # labels.json of an image-sequence folder: ingest and monitor read it
    for mutation, apply in _json_mutations(NON_UTF8):
        d = add("labels-json", ch / "labeled", "labeled/press_01/labels.json", mutation, "raw",
                apply)
        d.entry = "labeled/press_01"
        case(d, "ingest", ["ingest", "{IN}", "--out", "{OUT}/o.h5", "--no-progress"], REFUSE)
        case(d, "monitor", ["monitor", "{IN}", "--n-static", "3", "--no-progress"], REFUSE)
    # the truth of heightmap --truth
    hm = ["heightmap", f"{h5}/press.h5", "--model", "{BASE}/chains/run_normals", "--trial",
          PRESS_TRIAL, "--workers", "1", "--truth", "{IN}", "--out", "{OUT}/hm.h5",
          "--no-progress"]
    for mutation, apply in _npz_mutations(rng, _truncate):
        d = add("truth", ch / "digit_press" / "truth", f"truth/{PRESS_TRIAL}.npz", mutation,
                "truth", apply)
        d.entry = "truth"
        case(d, "heightmap", hm, REFUSE)
    # a digit-press scene folder given to monitor (its labels and scene.json are read)
    scene_muts = [(f"scene.json-{m}", "scene.json", a) for m, a in [
        ("cut", _truncate_text), ("list", lambda p: p.write_text("[1]")),
        ("non-utf8", lambda p: p.write_bytes(NON_UTF8)),
        ("no-optics", lambda p: _json_edit(p, lambda d: {k: v for k, v in d.items()
                                                          if k not in ("optics", "config")})),
        ("px-nan", lambda p: _json_edit(p, _px_nan))]]
    scene_muts += [(f"trial_labels-{m}", "trial_labels.csv", a) for m, a in _csv_mutations()
                   if m in ("empty", "non-utf8-row", "text-in-number", "binary-garbage",
                            "header-renamed", "missing-cell")]
    scene_muts += [("trial-dir-missing", f"trials/{PRESS_TRIAL}", shutil.rmtree),
                   ("frame-truncated", f"trials/{PRESS_TRIAL}/frame_0040.png",
                    lambda p: _truncate(p, 0.5))]
    for mutation, target, apply in scene_muts:
        d = add("press-scene", ch / "digit_press", f"digit_press/{target}", mutation,
                "scene", apply)
        d.entry = "digit_press"
        # trial labels are free-form text: a renamed column or a word for a number is
        # another label, not damage
        harmless = mutation in ("trial_labels-header-renamed", "trial_labels-text-in-number")
        case(d, "monitor", ["monitor", "{IN}", "--no-progress"],
             EITHER if harmless else REFUSE)
    _run_folders(add, case, base, rng, REFUSE, EITHER, NON_UTF8, _truncate, _truncate_text)
    _clashes(add, case, base, REFUSE)
    _options(add, case, base, REFUSE, EITHER)
    _nothing_lost(add, case, base, REFUSE, EITHER)


def _json_edit(p: Path, fn) -> None:
    p.write_text(json.dumps(fn(json.loads(p.read_text()))))


def _px_nan(doc: dict) -> dict:
    doc["optics"]["px_per_mm"] = float("nan")  # json writes it as NaN
    return doc


def _scene_configs(add, case, cfg: Path, yaml_mutations, REFUSE) -> None:
    absurd = {
        "vibro_slip": [("duration_s", "0"), ("duration_s", "1000000000"),
                       ("motor_rps", "[]"), ("orientations_deg", "[.nan]"),
                       ("textures.wood.mode_hz", "-1"), ("textures", "{}")],
        "vibrotouch": [("contact_trials", "-1"), ("accel_rate_hz", "0"),
                       ("accel_rate_hz", "1000000000000"), ("gap_mm", "[0.06, 0.02]"),
                       ("erm_hz", ".nan"), ("after_contact_s", "1000000000"),
                       ("touch_n", "heavy"), ("model", "{blocks: {}}")],
        "taxel_slip": [("presets", "[toaster]"), ("trials_per_class", "0"), ("rest_s", "-1"),
                       ("slip_s", "1000000000"), ("fingers", "0"), ("noise_scale", ".nan"),
                       ("crosstalk", "5")],
        "digit_press": [("optics.width_px", "1000000000000"), ("optics.width_px", "0"),
                        ("optics.px_per_mm", "-1"), ("optics.noise_std", ".nan"),
                        ("calibration.presses", "-1"),
                        ("calibration.ball_radius_mm", "[-1.0]"),
                        ("trials.objects", "[toaster]"), ("trials.frame_rate_hz", "0"),
                        ("trials.duration_s", "1000000000"),
                        ("trials.slip_s", "[.nan, 1]"), ("version", "99")],
        "digit_avoidance": [("interferences", "0"), ("static_s", "0.5"),
                            ("push_mm", "[2, 1]"), ("frame_rate_hz", ".inf"),
                            ("mesh", "[0, 0]"), ("objects", "[toaster]"),
                            ("optics.width_px", "1000000000000")],
        "marker_events": [("bin_s", "0"), ("trials.groups", "1000000000000"),
                          ("trials.levels", "[99]"), ("timing.slip_s", "[5, 1]"),
                          ("fos.tau_press_s", "-0.3"),
                          ("saturation.alpha_over_limit", "{12: .nan}")],
    }
    for scene, keys in absurd.items():
        src = cfg / f"scene_{scene}.yaml"
        for mutation, apply in yaml_mutations(keys):
            if mutation == "yaml-empty":  # the built-in default scene: valid, minutes long
                continue
            d = add(f"scene-{scene}", src, "scene.yaml", mutation, "config", apply)
            case(d, "simulate", sim_argv(scene, "{IN}", "{OUT}/s" + (
                "" if scene in ("digit_press", "digit_avoidance", "vibro_slip",
                                "marker_events") else ".h5")), REFUSE)


def _command_configs(add, case, cfg: Path, yaml_mutations, REFUSE, EITHER) -> None:
    h5 = "{BASE}/h5"
    tables = [
        ("detect-contact-config", "detect_contact.yaml",
         [("window_s", "0"), ("n_fft", "-1"), ("band_hz", "[580, 570]"),
          ("band_hz", "[1000000000, 1000000010]"), ("refresh_hz", ".nan"),
          ("force_channel", "nope"), ("average_frames", "0"), ("calibration_s", "1000000000")],
         [("detect-contact", ["detect-contact", f"{h5}/vibrotouch.h5", "--config", "{IN}",
                              "--json"])]),
        ("taxel-features", "taxel_features.yaml",
         [("window_s", "0"), ("hop_s", "-1"), ("bands_hz.pvdf.low", "[300, 10]"),
          ("folds", "1"), ("folds", "1000000000000"), ("welch.pvdf.nperseg", "0"),
          ("welch.pvdf.overlap", "1.5"), ("seed", "-1"), ("contact_threshold", ".nan")],
         [("slip-interface", ["slip-interface", f"{h5}/taxel_scene.h5", "--config", "{IN}",
                              "--folds", "2", "--json", "--no-progress"]),
          ("features", ["features", "spectral", f"{h5}/taxel_scene.h5", "--config", "{IN}",
                        "--out", "{OUT}/f.h5", "--no-progress"])]),
        ("vibro-model-config", "vibro_model.yaml",
         [("blocks.gripper.mass_kg", "0"), ("blocks.gripper.mass_kg", "-1"),
          ("blocks.skin_s.stiffness_n_m", ".nan"), ("source", "nobody"),
          ("blocks.gripper.parent", "gripper"), ("blocks.motor.parent", "skin_a"),
          ("f_step_hz", "0"), ("f_max_hz", "1000000000000"), ("contact", "[{between: [a]}]")],
         [("vibro-model", ["vibro-model", "{IN}", "--json"])]),
        ("sweep-config", "sweep.yaml",
         [("models", "{}"), ("windows", "[]"), ("windows", "[{window: 0, stride: 1}]"),
          ("channel_sets.Lx", "[nope]"), ("models.fnn.config", "/nonexistent/x.yaml"),
          ("overrides", "{optim.epochs: -1}"), ("version", "99"),
          ("train_data", "[/nonexistent.h5]")],
         [("sweep", ["sweep", "{IN}", "--out", "{OUT}/sw", "--workers", "0",
                     "--no-progress"])]),
    ]
    for kind, name, keys, commands in tables:
        for mutation, apply in yaml_mutations(keys):
            d = add(kind, cfg / name, name, mutation, "config", apply)
            # an empty config file is the built-in defaults (config_file.load_yaml_model);
            # a channel missing from the data fails that run alone, reported in the
            # sweep's table (a failed run does not stop the grid)
            harmless = (mutation == "yaml-empty" and kind != "sweep-config") or \
                mutation == "yaml-channel_sets.Lx=[nope]"
            for command, argv in commands:
                case(d, command, argv, EITHER if harmless else REFUSE)


def _run_folders(add, case, base: Path, rng, REFUSE, EITHER, NON_UTF8, truncate,
                 truncate_text) -> None:
    h5 = "{BASE}/h5"
    runs = {
        "run_normals": [
            ("heightmap", ["heightmap", f"{h5}/press.h5", "--model", "{IN}", "--trial",
                           PRESS_TRIAL, "--workers", "1", "--out", "{OUT}/hm.h5",
                           "--no-progress"]),
            ("export", ["export", "{IN}", "--out", "{OUT}/m.onnx"])],
        "run_vibro": [
            ("detect-delay", ["detect-delay", "{IN}", "--data", f"{h5}/prepared.h5",
                              "--split", "all", "--json"])],
    }
    for run_name, commands in runs.items():
        run = base / "chains" / run_name
        for mutation, target, apply in _run_mutations(run, rng, NON_UTF8, truncate,
                                                      truncate_text):
            d = add(run_name.replace("_", "-"), run, f"{run_name}/{target}", mutation, "run",
                    apply)
            d.entry = run_name
            for command, argv in commands:
                # the training's own records are read by no command that uses the model
                reads = target not in ("curves.png", "history.csv", "split.csv")
                case(d, command, argv, REFUSE if reads else EITHER)


def _run_mutations(run: Path, rng, NON_UTF8, truncate, truncate_text):
    """(mutation, file, apply) for a run folder of ``tactile train``."""
    from .corpus import _json_drop_key, _json_numbers

    out = []
    for name in sorted(p.name for p in run.iterdir() if p.is_file()):
        if name.endswith(".json"):
            out += [(f"{name}-cut", name, truncate_text),
                    (f"{name}-list", name, lambda p: p.write_text("[1, 2]")),
                    (f"{name}-drop-key", name, _json_drop_key),
                    (f"{name}-non-utf8", name, lambda p: p.write_bytes(NON_UTF8))]
        elif name.endswith(".yaml"):
            out += [(f"{name}-syntax", name, lambda p: p.write_text("a: [b\n")),
                    (f"{name}-cut", name, truncate_text)]
        elif name.endswith(".pt"):
            out += [(f"{name}-random", name,
                     lambda p: p.write_bytes(bytes(rng.integers(0, 256, 4096, np.uint8)))),
                    (f"{name}-truncated", name, lambda p: truncate(p, 0.5)),
                    (f"{name}-empty", name, lambda p: p.write_bytes(b""))]
        out.append((f"{name}-missing", name, lambda p: p.unlink()))
    if (run / "normalisation.json").exists():
        out += [("normalisation-std-0", "normalisation.json", lambda p: _json_numbers(p, 0.0)),
                ("normalisation-nan", "normalisation.json",
                 lambda p: _json_numbers(p, float("nan")))]
    return out


def _clashes(add, case, base: Path, REFUSE) -> None:
    """A file where a folder is expected and the reverse, for the chains' outputs."""
    h5 = "{BASE}/h5"
    press = f"{h5}/press.h5"
    model = "{BASE}/chains/run_normals"
    cfg = "{BASE}/cfg"
    clashes = [
        ("accel-prepare", ["accel-prepare", f"{h5}/accel.h5", "--segment-s", "0.02", "--out",
                           "{OUT}/x", "--no-progress"], "dir:x"),
        ("accel-prepare", ["accel-prepare", f"{h5}/accel.h5", "--segment-s", "0.02",
                           "--out-dir", "{OUT}/x", "--workers", "0", "--no-progress"],
         "file:x"),
        ("features", ["features", "spectral", f"{h5}/taxel_scene.h5", "--out", "{OUT}/x",
                      "--no-progress"], "dir:x"),
        ("features", ["features", "spectral", f"{h5}/taxel_scene.h5", "--out", "{OUT}/f/x.h5",
                      "--no-progress"], "file:f"),
        ("slip-interface", ["slip-interface", f"{h5}/taxel_scene.h5", "--folds", "2",
                            "--out", "{OUT}/x", "--no-progress"], "dir:x"),
        ("slip-interface", ["slip-interface", f"{h5}/taxel_scene.h5", "--folds", "2",
                            "--plot", "{OUT}/x", "--no-progress"], "dir:x"),
        # the figure's path gets .png when it has no suffix, so the clash is at x.png
        ("vibro-model", ["vibro-model", f"{cfg}/vibro_model.yaml", "--plot", "{OUT}/x.png"],
         "dir:x.png"),
        ("vibro-model", ["vibro-model", f"{cfg}/vibro_model.yaml", "--plot", "{OUT}/f/x.png"],
         "file:f"),
        ("detect-contact", ["detect-contact", f"{h5}/vibrotouch.h5", "--plot", "{OUT}/x.png"],
         "dir:x.png"),
        ("detect-contact", ["detect-contact", f"{h5}/vibrotouch.h5", "--trial", "contact_00",
                            "--samples-out", "{OUT}/x"], "dir:x"),
        ("normal-labels", ["normal-labels", f"{h5}/calib.h5", "--out", "{OUT}/x",
                           "--no-progress"], "dir:x"),
        ("normal-labels", ["normal-labels", f"{h5}/calib.h5", "--out", "{OUT}/p.h5",
                           "--plot", "{OUT}/x", "--no-progress"], "file:x"),
        ("heightmap", ["heightmap", press, "--model", model, "--trial", PRESS_TRIAL,
                       "--workers", "1", "--out", "{OUT}/x", "--no-progress"], "dir:x"),
        ("heightmap", ["heightmap", press, "--model", model, "--trial", PRESS_TRIAL,
                       "--workers", "1", "--out", "{OUT}/h.h5", "--plot", "{OUT}/x",
                       "--no-progress"], "file:x"),
        ("slip-signal", ["slip-signal", f"{h5}/heightmap.h5", "--plot", "{OUT}/x",
                         "--no-progress"], "file:x"),
        ("monitor", ["monitor", press, "--plot", "{OUT}/x", "--no-progress"], "file:x"),
        ("export", ["export", model, "--out", "{OUT}/x"], "dir:x"),
        ("export", ["export", model, "--out", "{OUT}/x.onnx"], "dir:x.onnx.json"),
        ("sweep", ["sweep", f"{cfg}/sweep.yaml", "--out", "{OUT}/x", "--workers", "0",
                   "--no-progress"], "file:x"),
    ]
    for scene in SCENES:
        folder = scene in ("digit_press", "digit_avoidance", "vibro_slip", "marker_events")
        clashes.append(("simulate", sim_argv(scene, f"{cfg}/scene_{scene}.yaml", "{OUT}/x"),
                        "file:x" if folder else "dir:x"))
    for i, (command, argv, clash) in enumerate(clashes):
        d = add("chain-clash", base / "annotations.csv", "unused", f"{command}-{clash}-{i}",
                "clash", None)
        case(d, command, argv, REFUSE, clash=(clash,))


def _options(add, case, base: Path, REFUSE, EITHER) -> None:
    """Absurd options of the simulators and the chain commands (valid inputs)."""
    h5 = "{BASE}/h5"
    cfg = "{BASE}/cfg"
    dp = ["simulate", "digit-press", "{OUT}/s", "--config", f"{cfg}/scene_digit_press.yaml",
          "--no-progress"]
    runs = [
        ("simulate", [*dp, "--objects", "toaster"]),
        ("simulate", [*dp, "--objects", ","]),
        ("simulate", [*dp, "--trials", "1000000000000"]),
        ("simulate", ["simulate", "taxel-slip", "--out", "{OUT}/s.h5", "--preset", "toaster",
                      "--no-progress"]),
        ("simulate", ["simulate", "marker-events", "--out", "{OUT}/s", "--levels", "5-1",
                      "--no-progress"]),
        ("simulate", ["simulate", "marker-events", "--out", "{OUT}/s", "--levels", "0,99",
                      "--no-progress"]),
        ("simulate", ["simulate", "digit-avoidance", "{OUT}/s", "--object", "toaster",
                      "--no-progress"]),
        ("simulate", ["simulate", "vibro-slip", "--out", "{OUT}/s", "--config",
                      f"{cfg}/scene_vibro_slip.yaml", "--duration", "1000000000",
                      "--no-progress"]),
        ("accel-prepare", ["accel-prepare", f"{h5}/accel.h5", "--segment-s", "-1", "--out",
                           "{OUT}/p.h5", "--no-progress"]),
        # documented: a cut-off at or above the Nyquist frequency leaves the data as it is
        ("accel-prepare", ["accel-prepare", f"{h5}/accel.h5", "--cutoff-hz", "1000000",
                           "--out", "{OUT}/p.h5", "--no-progress"], EITHER),
        ("accel-prepare", ["accel-prepare", f"{h5}/accel.h5", "--segment-s", "nan",
                           "--out", "{OUT}/p.h5", "--no-progress"]),
        ("detect-contact", ["detect-contact", f"{h5}/vibrotouch.h5", "--band", "580,570"]),
        ("detect-contact", ["detect-contact", f"{h5}/vibrotouch.h5", "--band", "a,b"]),
        ("detect-contact", ["detect-contact", f"{h5}/vibrotouch.h5", "--trial", "nobody"]),
        ("features", ["features", "spectral", f"{h5}/taxel_scene.h5", "--stream", "pvdf_f0",
                      "--band", "mid=400-100", "--out", "{OUT}/f.h5", "--no-progress"]),
        ("features", ["features", "spectral", f"{h5}/taxel_scene.h5", "--stream", "nope",
                      "--out", "{OUT}/f.h5", "--no-progress"]),
        ("heightmap", ["heightmap", f"{h5}/press.h5", "--model", "{BASE}/chains/run_normals",
                       "--px-per-mm", "nan", "--trial", PRESS_TRIAL, "--out", "{OUT}/h.h5",
                       "--no-progress"]),
        ("slip-signal", ["slip-signal", f"{h5}/heightmap.h5", "--mesh", "0x0",
                         "--no-progress"]),
        ("slip-signal", ["slip-signal", f"{h5}/heightmap.h5", "--scale", "nan",
                         "--no-progress"]),
        ("slip-signal", ["slip-signal", f"{h5}/heightmap.h5", "--n-static", "100000",
                         "--no-progress"]),
        ("monitor", ["monitor", f"{h5}/press.h5", "--hold-s", "-1", "--no-progress"]),
        ("monitor", ["monitor", f"{h5}/press.h5", "--threshold", "nan", "--no-progress"]),
        ("monitor", ["monitor", f"{h5}/press.h5", "--mesh", "100000x100000",
                     "--no-progress"]),
        # at most this many flat pixels: more than a press has keeps them all
        ("normal-labels", ["normal-labels", f"{h5}/calib.h5", "--flat-per-press",
                           "1000000000000", "--out", "{OUT}/p.h5", "--no-progress"], EITHER),
        ("export", ["export", "{BASE}/chains/run_normals", "--format", "tflite", "--out",
                    "{OUT}/m.x"]),
        ("detect-delay", ["detect-delay", "{BASE}/chains/run_vibro", "--data",
                          f"{h5}/prepared.h5", "--split", "holiday"]),
        ("detect-delay", ["detect-delay", "{BASE}/run", "--data", f"{h5}/prepared.h5"]),
    ]
    for i, (command, argv, *expect) in enumerate(runs):
        d = add("chain-option", base / "annotations.csv", "unused", f"{command}-option-{i}",
                "option", None)
        case(d, command, argv, expect[0] if expect else REFUSE)


def harmless_for(kind: str, role: str, mutation: str, command: str) -> bool:
    """Whether ``command`` never reads what a generic HDF5 mutation damaged, although its
    role says a reader of that role must refuse it."""
    # features --stream accel reads the accel stream alone, never the velocity stream
    if kind == "accel" and command == "features" and ".velocity." in mutation:
        return True
    # slip-signal, slip-imprint and monitor take frame times from the frames' t_s and the
    # geometry from the images: the frames sensor's kind and sample rate are never read
    return kind in ("visuo", "press") and command in ("slip-signal", "slip-imprint",
                                                      "monitor") and \
        role == "sensor" and mutation.startswith(("del-sensor-kind", "sensor-"))


# ------------------------------------------- nothing lost (issue 33) in the chain commands

def _nothing_lost(add, case, base: Path, REFUSE, EITHER) -> None:
    """The chain commands with an output that is their input or lies inside their input
    folder (kind ``sacred``: the runner hashes ``{IN}`` before and after every run), an
    output folder that cannot be written (``ro:x``), deeply nested configs, live-stream
    garbage and tiny or huge numbers."""
    h5, cfg, ch = base / "h5", base / "cfg", base / "chains"
    model = "{BASE}/chains/run_normals"
    sacred = {
        h5 / "taxel_scene.h5": [
            ["slip-interface", "{IN}", "--folds", "2", "--out", "{IN}", "--overwrite"],
            ["slip-interface", "{IN}", "--folds", "2", "--plot", "{IN}", "--overwrite"],
            ["features", "spectral", "{IN}", "--out", "{IN}", "--overwrite"],
            ["features", "spectral", "{IN}", "--stream", "pvdf_f0", "--out", "{IN}"]],
        h5 / "vibrotouch.h5": [
            ["detect-contact", "{IN}", "--plot", "{IN}", "--overwrite"],
            ["detect-contact", "{IN}", "--trial", "contact_00", "--samples-out", "{IN}",
             "--overwrite"]],
        cfg / "vibro_model.yaml": [["vibro-model", "{IN}", "--plot", "{IN}", "--overwrite"]],
        cfg / "detect_contact.yaml": [
            ["detect-contact", "{BASE}/h5/vibrotouch.h5", "--config", "{IN}", "--plot", "{IN}",
             "--overwrite"]],
        h5 / "press.h5": [
            ["heightmap", "{IN}", "--model", model, "--out", "{IN}", "--overwrite"],
            ["monitor", "{IN}", "--plot", "{IN}", "--overwrite"],
            ["slip-imprint", "{IN}", "--threshold", "0.05", "--plot", "{IN}", "--overwrite"]],
        h5 / "calib.h5": [["normal-labels", "{IN}", "--out", "{IN}", "--overwrite"]],
        h5 / "heightmap.h5": [["slip-signal", "{IN}", "--plot", "{IN}"]],
        h5 / "prepared.h5": [["accel-prepare", "{IN}", "--out", "{IN}", "--overwrite"]],
        cfg / "scene_taxel_slip.yaml": [
            ["simulate", "taxel-slip", "--config", "{IN}", "--out", "{IN}", "--overwrite"]],
    }
    for src, runs in sacred.items():
        d = add("sacred", src, src.name, f"out-is-input-{src.stem}", "sacred", None)
        for argv in runs:
            case(d, argv[0], [*argv, "--no-progress"] if argv[0] in _PROGRESS else argv,
                 REFUSE)
    scene = add("sacred", ch / "digit_press", "digit_press", "scene-folder", "sacred", None)
    for argv in (["monitor", "{IN}", "--plot", "{IN}", "--overwrite"],
                 ["monitor", "{IN}", "--plot", f"{{IN}}/trials/{PRESS_TRIAL}", "--overwrite"],
                 ["monitor", "{IN}", "--plot", "{IN}/plots"]):
        case(scene, "monitor", [*argv, "--no-progress"], REFUSE)
    _unwritable(add, case, base, REFUSE)
    _nested_and_live(add, case, base, REFUSE)
    _numbers(add, case, base, REFUSE, EITHER)


#: the chain commands that take --no-progress
_PROGRESS = {"slip-interface", "features", "heightmap", "monitor", "normal-labels", "slip-imprint",
             "slip-signal", "accel-prepare", "simulate"}


def _unwritable(add, case, base: Path, REFUSE) -> None:
    """Every output option of the chain commands in a folder that cannot be written (the
    runner makes ``{OUT}/ro`` immutable)."""
    h5, cfg = "{BASE}/h5", "{BASE}/cfg"
    model = "{BASE}/chains/run_normals"
    runs = [
        ["vibro-model", f"{cfg}/vibro_model.yaml", "--plot", "{OUT}/ro/m.png"],
        ["detect-contact", f"{h5}/vibrotouch.h5", "--plot", "{OUT}/ro/d.png"],
        ["detect-contact", f"{h5}/vibrotouch.h5", "--trial", "contact_00", "--samples-out",
         "{OUT}/ro/s.txt"],
        ["slip-interface", f"{h5}/taxel_scene.h5", "--folds", "2", "--out", "{OUT}/ro/r.json"],
        ["slip-interface", f"{h5}/taxel_scene.h5", "--folds", "2", "--plot", "{OUT}/ro/r.png"],
        ["features", "spectral", f"{h5}/taxel_scene.h5", "--out", "{OUT}/ro/f.h5"],
        ["heightmap", f"{h5}/press.h5", "--model", model, "--out", "{OUT}/ro/h.h5"],
        ["heightmap", f"{h5}/press.h5", "--model", model, "--out", "{OUT}/h.h5", "--plot",
         "{OUT}/ro/figs"],
        ["normal-labels", f"{h5}/calib.h5", "--out", "{OUT}/ro/p.h5"],
        ["normal-labels", f"{h5}/calib.h5", "--out", "{OUT}/p.h5", "--plot", "{OUT}/ro/figs"],
        ["slip-signal", f"{h5}/heightmap.h5", "--plot", "{OUT}/ro/figs"],
        ["monitor", f"{h5}/press.h5", "--plot", "{OUT}/ro/figs"],
        ["accel-prepare", f"{h5}/prepared.h5", "--segment-s", "0.5", "--out", "{OUT}/ro/p.h5"],
        ["accel-prepare", f"{h5}/prepared.h5", "--segment-s", "0.5", "--out-dir",
         "{OUT}/ro/d", "--workers", "0"],
        ["simulate", "taxel-slip", "--config", f"{cfg}/scene_taxel_slip.yaml", "--out",
         "{OUT}/ro/s.h5"],
        ["simulate", "digit-press", "{OUT}/ro/s", "--config", f"{cfg}/scene_digit_press.yaml"],
    ]
    for i, argv in enumerate(runs):
        d = add("chain-unwritable", base / "annotations.csv", "unused",
                f"{argv[0]}-unwritable-{i}", "clash", None)
        case(d, argv[0], [*argv, "--no-progress"] if argv[0] in _PROGRESS else argv, REFUSE,
             clash=("ro:ro",))


def _deep(p: Path) -> None:
    p.write_text("a: " + "[" * 200 + "]" * 200 + "\n")


def _nested_and_live(add, case, base: Path, REFUSE) -> None:
    """Configs nested 200 deep and a scene.json 2,000 deep; live streams with a NaN, an infinity, a
    number that overflows, an absurd acceleration and a 2 MB line."""
    h5 = "{BASE}/h5"
    deep = [("vibro_model.yaml", ["vibro-model", "{IN}"]),
            ("detect_contact.yaml", ["detect-contact", f"{h5}/vibrotouch.h5", "--config",
                                     "{IN}"]),
            ("taxel_features.yaml", ["slip-interface", f"{h5}/taxel_scene.h5", "--config",
                                     "{IN}", "--no-progress"]),
            ("scene_vibrotouch.yaml", ["simulate", "vibrotouch", "--config", "{IN}", "--out",
                                       "{OUT}/v.h5", "--no-progress"])]
    for name, argv in deep:
        d = add("deep-config", base / "cfg" / name, name, f"deep-{name}", "config", _deep)
        case(d, argv[0], argv, REFUSE)
    d = add("deep-scene", base / "chains" / "digit_press", "digit_press/scene.json",
            "scene.json-deep", "scene",
            lambda p: p.write_text('{"optics": ' + "[" * 2000 + "]" * 2000 + "}"))
    d.entry = "digit_press"
    case(d, "monitor", ["monitor", "{IN}", "--no-progress"], REFUSE)
    for tag, text in (("nan", "0.1\n0.2\nnan\n0.1\n"), ("inf", "0.1\ninf\n"),
                      ("1e400", "0.1\n1e400\n"), ("1e9", "1e9\n"),
                      ("long-line", "0.1\n" + "9" * 2_000_000 + "\n"),
                      ("long-tail", "0.1\n" + "9" * 2_000_000)):
        d = add("live-stream", base / "annotations.csv", "s.txt", f"stream-{tag}", "raw",
                lambda p, t=text: p.write_text(t))
        case(d, "detect-contact", ["detect-contact", "{IN}", "--follow"], REFUSE)


def _numbers(add, case, base: Path, REFUSE, EITHER) -> None:
    """Tiny and huge values of the chain commands' numeric options (valid inputs)."""
    h5 = "{BASE}/h5"
    model = "{BASE}/chains/run_normals"
    stream = ["features", "spectral", f"{h5}/taxel_scene.h5", "--stream", "pvdf_f0", "--out",
              "{OUT}/f.h5"]
    prep = ["accel-prepare", f"{h5}/accel.h5", "--out", "{OUT}/p.h5"]
    hm = ["heightmap", f"{h5}/press.h5", "--model", model, "--trial", PRESS_TRIAL, "--workers",
          "1", "--out", "{OUT}/h.h5"]
    runs = [
        ([*stream, "--hop-s", "1e-6"], REFUSE), ([*stream, "--window-s", "1e-6"], REFUSE),
        ([*stream, "--window-s", "1e300"], REFUSE),
        ([*prep, "--segment-s", "1e-6"], REFUSE), ([*prep, "--segment-s", "1e-300"], REFUSE),
        ([*prep, "--segment-s", "1e300"], EITHER), ([*prep, "--cutoff-hz", "1e-9"], REFUSE),
        ([*hm, "--px-per-mm", "1e308"], REFUSE), ([*hm, "--px-per-mm", "1e-308"], REFUSE),
        ([*hm, "--workers", "100000"], REFUSE),
        (["slip-signal", f"{h5}/heightmap.h5", "--workers", "100000"], REFUSE),
        (["slip-signal", f"{h5}/heightmap.h5", "--scale", "1e300", "--n-static", "5"], EITHER),
        (["monitor", f"{h5}/press.h5", "--hold-s", "1e300", "--n-static", "5"], EITHER),
        (["detect-contact", f"{h5}/vibrotouch.h5", "--find-band", "--band-width", "1e300"],
         REFUSE),
    ]
    for i, (argv, expect) in enumerate(runs):
        d = add("chain-number", base / "annotations.csv", "unused", f"{argv[0]}-number-{i}",
                "option", None)
        case(d, argv[0], [*argv, "--no-progress"] if argv[0] in _PROGRESS else argv, expect)

