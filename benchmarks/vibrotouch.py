"""Paper 003 (VibroTouch) targets on simulated scenes (issue 17, items 4-5).

Targets (sec. 3.1): over repeated light contacts the vibration detector finds at least as
many as the paper's 9 of 10, with no false alarm while the gripper moves, earlier than the
force sensor (the baseline, measured in the same run on the same trials), and its SNR beside
the force sensor's (paper: about 18 vs 8).

Seeds: the scene and the detector defaults were tuned on scene seed 100 (the demo shows
seed 0); the tests use seed 7; the numbers here come from the held-out seeds 1000, 1001
and 1002 (10 contact and 2 touch trials each, default configs), none of which was looked
at while tuning.

    .venv/bin/python benchmarks/vibrotouch.py --json             # the targets
    .venv/bin/python benchmarks/vibrotouch.py --stability        # item 5: breaking points

``--stability`` sweeps, on held-out seed 1000 (10 contact trials per point): the contact
stiffness (the light first contact and its stiffening with depth scaled together: lighter
touches, softer skin), the gripper's motion vibration and the detection
band's offset from 570-580 Hz, and writes benchmarks/figures/vibrotouch_stability.png and
.json. A point breaks when the detection rate falls below 90 % or a false alarm occurs.
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from tactile_cli._version import __version__  # noqa: E402
from tactile_cli.store.trials import TactileFile  # noqa: E402
from tactile_cli.vibro import (  # noqa: E402
    DetectorConfig,
    VibroTouchSceneConfig,
    detect_contacts,
    simulate_vibrotouch,
)

TUNING_SEEDS = (100,)
TEST_SEEDS = (7,)
HELD_OUT_SEEDS = (1000, 1001, 1002)
FIGURES = ROOT / "benchmarks" / "figures"


def run_scene(scene: VibroTouchSceneConfig, detector: DetectorConfig, seed: int, work: Path,
              tag: str = "") -> dict:
    path = work / f"scene_{seed}{tag}.h5"
    if not path.exists():
        simulate_vibrotouch(scene, path, seed=seed, command=f"benchmarks/vibrotouch.py {seed}")
    with TactileFile(path) as f:
        return detect_contacts(f, detector).totals()


def combine(rows: list[dict]) -> dict:
    """Sums of counts; SNR and lead weighted by each scene's contacts."""
    n = sum(r["n_contacts"] for r in rows)
    out = {k: sum(r[k] for r in rows) for k in
           ("n_contacts", "vibration_detected", "force_detected", "false_alarms",
            "force_false_alarms", "n_touches", "vibration_touch_hits", "force_touch_hits",
            "vibration_touch_false_alarms", "force_touch_false_alarms")}
    for k in ("vibration_snr", "force_snr", "mean_lead_s", "mean_vibration_delay_s",
              "mean_force_delay_s"):
        vals = [(r[k], r["n_contacts"]) for r in rows if r[k] is not None]
        out[k] = round(sum(v * w for v, w in vals) / max(1, sum(w for _, w in vals)), 4) \
            if vals else None
    out["vibration_rate"] = round(out["vibration_detected"] / n, 4) if n else None
    out["force_rate"] = round(out["force_detected"] / n, 4) if n else None
    return out


def targets(work: Path, seeds: tuple[int, ...]) -> dict:
    started = time.perf_counter()
    rows = [run_scene(VibroTouchSceneConfig(), DetectorConfig(), s, work) for s in seeds]
    out = combine(rows)
    out.update({
        "seeds": list(seeds), "tuning_seeds": list(TUNING_SEEDS), "per_seed": rows,
        "met_detection": out["vibration_rate"] is not None and out["vibration_rate"] >= 0.9,
        "met_no_false_alarms": out["false_alarms"] == 0,
        "met_earlier": out["mean_lead_s"] is not None and out["mean_lead_s"] > 0,
        "paper": {"vibration_detected": "9/10", "force_detected": "8/10",
                  "vibration_snr": 18, "force_snr": 8},
        "tool_version": __version__, "elapsed_s": round(time.perf_counter() - started, 1)})
    return out


def stability(work: Path, seed: int) -> dict:
    base = VibroTouchSceneConfig(touch_trials=0)
    det = DetectorConfig()
    sweeps = {
        "contact_scale": [1.0, 0.5, 0.25, 0.1, 0.05, 0.02, 0.01],
        "motion_noise_g": [0.05, 0.1, 0.2, 0.4, 0.8, 1.6],
        "band_offset_hz": [0.0, 10.0, 20.0, 40.0, 80.0, -40.0, -80.0],
    }
    result: dict = {"seed": seed, "sweeps": {}}
    for key, values in sweeps.items():
        rows = []
        for v in values:
            if key == "band_offset_hz":
                scene, detector, tag = base, DetectorConfig(
                    band_hz=(det.band_hz[0] + v, det.band_hz[1] + v)), "_base"
            elif key == "contact_scale":  # softer skin and object: every touch lighter
                scene = VibroTouchSceneConfig.model_validate({
                    **base.model_dump(),
                    "light_stiffness_n_m": base.light_stiffness_n_m * v,
                    "stiffening_n_m2": base.stiffening_n_m2 * v})
                detector, tag = det, f"_{key}_{v:g}"
            else:
                scene = VibroTouchSceneConfig.model_validate({**base.model_dump(), key: v})
                detector, tag = det, f"_{key}_{v:g}"
            t = run_scene(scene, detector, seed, work, tag)
            rows.append({"value": v, "rate": t["vibration_detected"] / t["n_contacts"],
                         "false_alarms": t["false_alarms"],
                         "force_rate": t["force_detected"] / t["n_contacts"],
                         "vibration_snr": t["vibration_snr"],
                         "vibration_delay_s": t["mean_vibration_delay_s"],
                         "force_delay_s": t["mean_force_delay_s"]})
            print(f"  {key}={v:g}: rate {rows[-1]['rate']:.2f}, false alarms "
                  f"{t['false_alarms']}", file=sys.stderr)
        broken = next((r["value"] for r in rows if r["rate"] < 0.9 or r["false_alarms"] > 0),
                      None)
        result["sweeps"][key] = {"rows": rows, "breaking_point": broken}
    return result


def plot_stability(result: dict, path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    titles = {"contact_scale": "contact stiffness x (light and stiffening; log)",
              "motion_noise_g": "gripper motion vibration RMS (g, log)",
              "band_offset_hz": "band offset from 570-580 Hz (Hz)"}
    fig, axes = plt.subplots(1, 3, figsize=(14, 4))
    for ax, (key, sweep) in zip(axes, result["sweeps"].items(), strict=True):
        rows = sorted(sweep["rows"], key=lambda r: r["value"])
        x = [r["value"] for r in rows]
        ax.plot(x, [r["rate"] for r in rows], "o-", color="red", label="vibration detected")
        ax.plot(x, [r["force_rate"] for r in rows], "x--", color="blue", label="force detected")
        ax2 = ax.twinx()
        ax2.plot(x, [r["false_alarms"] for r in rows], "s:", color="black",
                 label="false alarms")
        ax2.set_ylabel("false alarms (10 trials)")
        ax2.set_ylim(-0.5, max(2, max(r["false_alarms"] for r in rows)) + 0.5)
        if key != "band_offset_hz":
            ax.set_xscale("log")
        ax.axhline(0.9, color="grey", lw=0.8)
        if sweep["breaking_point"] is not None:
            ax.axvline(sweep["breaking_point"], color="orange", ls="--",
                       label=f"breaks at {sweep['breaking_point']:g}")
        ax.set_ylim(-0.05, 1.05)
        ax.set_xlabel(titles[key])
        ax.set_ylabel("detection rate")
        handles = ax.get_legend_handles_labels()
        extra = ax2.get_legend_handles_labels()
        ax.legend(handles[0] + extra[0], handles[1] + extra[1], fontsize=7, loc="lower left")
    fig.suptitle(f"VibroTouch detector stability (held-out seed {result['seed']}, "
                 "10 contact trials per point)")
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--seeds", type=int, nargs="+", default=list(HELD_OUT_SEEDS))
    ap.add_argument("--work", type=Path, help="keep the scenes here (default: a temp folder)")
    ap.add_argument("--json", action="store_true")
    ap.add_argument("--stability", action="store_true")
    args = ap.parse_args()
    if set(args.seeds) & set(TUNING_SEEDS + TEST_SEEDS):
        print("warning: tuning or test seeds among --seeds; the numbers are not held out",
              file=sys.stderr)
    with tempfile.TemporaryDirectory() as tmp:
        work = args.work or Path(tmp)
        work.mkdir(parents=True, exist_ok=True)
        if args.stability:
            result = stability(work, args.seeds[0])
            FIGURES.mkdir(parents=True, exist_ok=True)
            (FIGURES / "vibrotouch_stability.json").write_text(json.dumps(result, indent=2)
                                                               + "\n")
            plot_stability(result, FIGURES / "vibrotouch_stability.png")
            print(json.dumps({k: v["breaking_point"] for k, v in result["sweeps"].items()}))
            return
        out = targets(work, tuple(args.seeds))
    if args.json:
        print(json.dumps(out, indent=2))
        return
    print(f"held-out seeds {out['seeds']}: vibration {out['vibration_detected']}/"
          f"{out['n_contacts']}, force {out['force_detected']}/{out['n_contacts']}, false "
          f"alarms {out['false_alarms']}, SNR {out['vibration_snr']} vs {out['force_snr']}, "
          f"vibration earlier by {out['mean_lead_s']} s; touches: vibration "
          f"{out['vibration_touch_hits']}/{out['n_touches']}, force "
          f"{out['force_touch_hits']}/{out['n_touches']}")


if __name__ == "__main__":
    main()
