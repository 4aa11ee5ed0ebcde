"""Which BioTac inputs carry texture: vibration, electrodes or both, per model and window.

Issue 14, item 8. The 200 trials of ../shared/data/biotac_slide20 (20 materials x 10
slides) are ingested with configs/biotac_slide20.yaml and every config of
configs/biotac_inputs/ (input x model x window, written once before any fold result was
seen) is cross-validated as the CLI does it::

    tactile train configs/biotac_inputs/<input>_<model>_w<window>.yaml --data bt.h5 --cv 5 --out RUN
    tactile evaluate RUN

Inputs: ``pac`` (vibration alone: the dynamic pressure, about 2.2 kHz), ``ele`` (electrodes
alone: ele1..ele19, 100 Hz) and ``both``. The library trains one network on one stream, so
``both`` is late fusion of a vibration model and an electrode model of the same family and
window rank (long with long, short with short), trained on the same folds:

- per trial: the average of the two models' mean class probabilities over the trial's
  windows (argmax = the trial's class);
- per window: each vibration window paired with the electrode window of the same trial
  whose end lies nearest in time, the two probability vectors averaged.

Every figure comes from each fold's model on its own held-out trials (the probabilities are
recomputed through the library: ``runs.load_run`` + ``train.predict``; the window
accuracy equals ``tactile evaluate``'s, which is checked). Reported per row: window
accuracy with a 95 % bootstrap interval over trials, per-trial accuracy by mean probability
(the rule ``both`` uses; majority vote beside it) with its interval, the standard deviation
of per-trial accuracy over the folds (ddof 1), parameters and batch-1 latency (the sum of
both models for ``both``).

The model to use on other recordings of these materials (``recommend``): the reference is
the row with the highest lower 95 % bound of per-trial accuracy (ties: smaller fold
spread); every row whose per-trial accuracy lies at or above that bound and whose fold
spread is at most the reference's plus 5 pp is as good on these folds; among those the
one with the fewest parameters is chosen (ties: lower latency, then label), as
``tactile compare`` chooses the model a scene needs within its margin
(:func:`tactile_cli.learn.compare.pick_needed`). Not the top point estimate.

    .venv/bin/python benchmarks/biotac_inputs.py [--models fnn lstm cnn2d mlp] [--folds 5]
        [--jobs 2] [--work DIR] [--finished-only] [--json]

Writes benchmarks/figures/biotac_inputs.json and biotac_inputs.png (per-window and per-trial
accuracy with intervals, one row per input x model x window) and
biotac_inputs_compare.png (``tactile compare`` by per-trial accuracy against latency, with
the intervals). ``--work`` keeps the ingested file and the run folders (a second call
reuses finished runs; ``--finished-only`` reports the finished ones without training the
rest); by default they go to a temporary folder.
"""

from __future__ import annotations

import argparse
import multiprocessing
import os
import subprocess
import sys
import tempfile
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path
from typing import Any

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from tactile_cli._version import __version__  # noqa: E402
from tactile_cli.learn import load_config, runs  # noqa: E402
from tactile_cli.learn.compare import pick_needed  # noqa: E402
from tactile_cli.learn.trial_metrics import (  # noqa: E402
    bootstrap_window_intervals,
    fmt_interval,
    per_trial_confusion,
    trial_votes,
)
from tactile_cli.store.provenance import sha256_of, utc_now  # noqa: E402

CFG_DIR = ROOT / "configs" / "biotac_inputs"
FAMILIES = ("fnn", "lstm", "cnn2d", "mlp")
#: input -> family -> windows, longest first (window rank 0 = long, 1 = short). The PAC
#: LSTM has only a short, strided window (see configs/biotac_inputs/pac_lstm_w64.yaml).
WINDOWS = {
    "pac": {"fnn": (1024, 256), "lstm": (None, 64), "cnn2d": (1024, 256), "mlp": (1024, 256)},
    "ele": {"fnn": (50, 20), "lstm": (50, 20), "cnn2d": (50, 20), "mlp": (50, 20)},
}
RATE_HZ = {"pac": 2200.0, "ele": 100.0}
INPUT_NAMES = {"pac": "vibration (PAC)", "ele": "electrodes", "both": "both (late fusion)"}
SPREAD_SLACK_PP = 5.0
#: Core-seconds of 5 folds estimated from 2 epochs of one fold (shared machine): the
#: costliest configs start first, so that the workers finish together.
EST_CORE_S = {"pac_cnn2d_w256": 485, "pac_cnn2d_w1024": 475, "pac_fnn_w256": 265,
              "pac_mlp_w256": 230, "pac_lstm_w64": 216, "ele_fnn_w20": 130,
              "ele_cnn2d_w20": 125, "ele_lstm_w20": 120, "pac_fnn_w1024": 100,
              "pac_mlp_w1024": 60, "ele_lstm_w50": 87, "ele_fnn_w50": 60, "ele_cnn2d_w50": 60,
              "ele_mlp_w20": 50, "ele_mlp_w50": 25}
COMMAND = "benchmarks/biotac_inputs.py"


def ingest(source: Path, out: Path) -> Path:
    exe = Path(sys.executable).with_name("tactile")
    subprocess.run([str(exe) if exe.exists() else "tactile", "ingest", str(source),
                    "--mapping", str(ROOT / "configs" / "biotac_slide20.yaml"), "--out",
                    str(out)], check=True, stdout=subprocess.DEVNULL)
    return out


def config_names(families: list[str]) -> list[str]:
    return [f"{inp}_{fam}_w{w}" for fam in families for inp in ("pac", "ele")
            for w in WINDOWS[inp][fam] if w is not None]


def _softmax(z: np.ndarray) -> np.ndarray:
    z = z.astype(np.float64) - z.max(axis=1, keepdims=True)
    e = np.exp(z)
    return e / e.sum(axis=1, keepdims=True)


def fold_probabilities(run_dir: Path, data: Path) -> list[dict[str, Any]]:
    """Every fold's model on its held-out trials: per window the trial key, end time (s),
    true class and class probabilities (as :func:`tactile_cli.learn.cv.evaluate_cv`
    builds its windows)."""
    from tactile_cli.learn.data import make_windows, read_trials
    from tactile_cli.learn.heads import primary_head
    from tactile_cli.learn.train import predict

    info = runs.read_run_info(run_dir)
    cv = info["cv"]
    out = []
    trials = None
    for fold in cv["folds"]:
        run = runs.load_run(run_dir / cv.get("folds_dir", "folds") / f"fold_{fold['fold']:02d}")
        if trials is None:
            trials = {t.key: t for t in read_trials([data], run.config.data, trained=True)}
        held = [trials[k] for k in fold["test"]]
        ws = make_windows(held, run.config.data, run.heads, run.normalisation)
        head = primary_head(run.heads)
        assert head is not None
        logits = predict(run.load_model(), ws)[head.name]
        out.append({"fold": int(fold["fold"]), "test": list(fold["test"]),
                    "trial": np.array([ws.trials[i] for i in ws.trial_index]),
                    "t_s": ws.target_t_s.astype(np.float64),
                    "y": ws.targets[head.name].astype(np.int64),
                    "p": _softmax(logits), "classes": list(head.classes)})
    return out


def run_config(name: str, data: str, work: str, folds: int) -> dict[str, Any]:
    """Train (or reuse) and evaluate one config; returns its evaluate figures and the
    per-window probabilities of every fold."""
    import torch

    torch.set_num_threads(1)
    from tactile_cli.learn.cv import train_cv
    from tactile_cli.learn.evaluate import evaluate

    cfg_path = CFG_DIR / f"{name}.yaml"
    run_dir = Path(work) / "runs" / name
    started = time.perf_counter()
    reused = (run_dir / runs.RUN_JSON).is_file()
    if not reused:
        train_cv(load_config(cfg_path), [data], run_dir, k=folds, jobs=1,
                 config_path=cfg_path, command=COMMAND)
    train_wall = time.perf_counter() - started
    ev = evaluate(run_dir, None, threads=1, command=COMMAND, overwrite=True)
    m = next(h for h in ev.heads if h.head == "material")
    assert ev.cv is not None and ev.latency is not None and m.per_trial is not None
    info = runs.read_run_info(run_dir)
    if reused:  # the wall time of the call that trained it
        train_wall = float(info.get("wall_time_s") or float("nan"))
    return {
        "name": name, "config": str(cfg_path.relative_to(ROOT)), "run_dir": str(run_dir),
        "family": ev.family, "n_params": ev.n_params,
        "batch1_ms_median": ev.latency.batch1_ms_median, "reused": reused,
        "train_wall_s": train_wall, "train_time_s": info["training"]["train_time_s"],
        "epochs_run": [f.get("epochs_run") for f in info["training"]["folds"]],
        "evaluate": {"window_accuracy": m.accuracy, "window_accuracy_ci95": m.accuracy_ci95,
                     "trial_accuracy_majority": m.per_trial["majority_accuracy"],
                     "trial_accuracy_majority_ci95": m.per_trial["majority_accuracy_ci95"],
                     "per_trial_accuracy_fold_std": ev.cv["per_trial_accuracy_std"]},
        "probabilities": fold_probabilities(run_dir, Path(data)),
    }


# -- scores -----------------------------------------------------------------------------------
def _sd(values: list[float]) -> float | None:
    return float(np.std(values, ddof=1)) if len(values) > 1 else None


def score(folds: list[dict[str, Any]], trial_p: list[dict[str, np.ndarray]] | None = None
          ) -> dict[str, Any]:
    """Window and trial figures of per-window probabilities pooled over folds.
    ``trial_p`` (fusion): per fold, trial key -> the trial's class probabilities, which
    replace the mean over its windows for the per-trial decision."""
    keys = sorted({k for f in folds for k in f["trial"]})
    index = {k: i for i, k in enumerate(keys)}
    y = np.concatenate([f["y"] for f in folds])
    p = np.concatenate([f["p"] for f in folds])
    tid = np.concatenate([[index[k] for k in f["trial"]] for f in folds]).astype(np.int64)
    k = p.shape[1]
    pred = p.argmax(axis=1)
    win = bootstrap_window_intervals(per_trial_confusion(y, pred, tid, len(keys), k))
    votes = trial_votes(y, np.log(np.clip(p, 1e-300, None)), tid)
    assert votes is not None
    trial_acc, trial_ci = votes.mean_probability_accuracy, votes.mean_probability_accuracy_ci95
    fold_trial, fold_win = [], []
    for j, f in enumerate(folds):
        fold_win.append(float((f["p"].argmax(axis=1) == f["y"]).mean()))
        if trial_p is None:
            v = trial_votes(f["y"], np.log(np.clip(f["p"], 1e-300, None)), f["trial"])
            assert v is not None
            fold_trial.append(v.mean_probability_accuracy)
        else:
            truth = {t: int(c) for t, c in zip(f["trial"], f["y"], strict=True)}
            fold_trial.append(float(np.mean([trial_p[j][t].argmax() == truth[t]
                                             for t in trial_p[j]])))
    if trial_p is not None:  # fused per-trial decisions: one "window" per trial
        truth = {t: int(c) for f in folds for t, c in zip(f["trial"], f["y"], strict=True)}
        tk = [t for tp in trial_p for t in tp]
        tv = trial_votes(np.array([truth[t] for t in tk]),
                         np.log(np.clip(np.stack([tp[t] for tp in trial_p for t in tp]),
                                        1e-300, None)), np.arange(len(tk)))
        assert tv is not None
        trial_acc, trial_ci = tv.mean_probability_accuracy, tv.mean_probability_accuracy_ci95
    return {"n_trials": len(keys), "n_windows": int(y.shape[0]),
            "window_accuracy": float((pred == y).mean()),
            "window_accuracy_ci95": win["accuracy_ci95"],
            "trial_accuracy": float(trial_acc), "trial_accuracy_ci95": trial_ci,
            "trial_accuracy_majority": votes.majority_accuracy if trial_p is None else None,
            "trial_accuracy_majority_ci95": votes.majority_accuracy_ci95
            if trial_p is None else None,
            "trial_accuracy_folds": fold_trial, "trial_accuracy_fold_std": _sd(fold_trial),
            "window_accuracy_folds": fold_win, "window_accuracy_fold_std": _sd(fold_win)}


def fuse(vib: list[dict[str, Any]], ele: list[dict[str, Any]]
         ) -> tuple[list[dict[str, Any]], list[dict[str, np.ndarray]]]:
    """Late fusion of two runs on the same folds (module docstring): per-window folds
    (vibration windows, probabilities averaged with the nearest-ending electrode window of
    the same trial) and per fold the trials' averaged mean probabilities."""
    folds, trial_p = [], []
    for fv, fe in zip(vib, ele, strict=True):
        if fv["test"] != fe["test"] or fv["classes"] != fe["classes"]:
            raise ValueError(f"fold {fv['fold']}: the two runs hold out other trials or classes")
        p = np.empty_like(fv["p"])
        tp: dict[str, np.ndarray] = {}
        for t in fv["test"]:
            mv, me = fv["trial"] == t, fe["trial"] == t
            te, pe = fe["t_s"][me], fe["p"][me]
            order = np.argsort(te)
            te, pe = te[order], pe[order]
            tv = fv["t_s"][mv]
            j = np.clip(np.searchsorted(te, tv), 1, len(te) - 1) if len(te) > 1 \
                else np.zeros(len(tv), np.int64)
            if len(te) > 1:
                j = np.where(np.abs(te[j - 1] - tv) <= np.abs(te[j] - tv), j - 1, j)
            p[mv] = 0.5 * (fv["p"][mv] + pe[j])
            tp[t] = 0.5 * (fv["p"][mv].mean(axis=0) + fe["p"][me].mean(axis=0))
        folds.append({**fv, "p": p})
        trial_p.append(tp)
    return folds, trial_p


def recommend(rows: list[dict[str, Any]]) -> dict[str, Any]:
    """The model for unseen recordings (module docstring)."""
    def spread(r: dict[str, Any]) -> float:
        s = r["trial_accuracy_fold_std"]
        return float("inf") if s is None else s

    ref = max(rows, key=lambda r: (r["trial_accuracy_ci95"][0], -spread(r)))
    floor = ref["trial_accuracy_ci95"][0]
    eligible = np.array([r["trial_accuracy"] >= floor - 1e-9
                         and spread(r) <= spread(ref) + SPREAD_SLACK_PP / 100 + 1e-9
                         for r in rows])
    labels = [r["label"] for r in rows]
    i = pick_needed(np.array([r["n_params"] for r in rows]),
                    np.array([r["batch1_ms_median"] for r in rows]), eligible, labels)
    top = max(rows, key=lambda r: r["trial_accuracy"])
    return {"rule": ("reference = highest lower 95 % bound of per-trial accuracy (ties: "
                     "smaller fold sd); eligible = per-trial accuracy >= that bound and fold "
                     f"sd <= the reference's + {SPREAD_SLACK_PP:g} pp; choice = fewest "
                     "parameters among the eligible (ties: lower batch-1 latency, label)"),
            "reference": ref["label"], "reference_lower_bound": floor,
            "eligible": [lab for lab, e in zip(labels, eligible, strict=True) if e],
            "recommended": labels[i], "top_point_estimate": top["label"]}


# -- outputs ----------------------------------------------------------------------------------
def plot(rows: list[dict[str, Any]], rec: dict[str, Any], path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    colour = {"pac": "C0", "ele": "C1", "both": "C2"}
    ys = np.arange(len(rows))[::-1]
    fig, axes = plt.subplots(1, 2, figsize=(11, 0.32 * len(rows) + 1.6), sharey=True)
    for ax, key, title in ((axes[0], "window_accuracy", "per window"),
                           (axes[1], "trial_accuracy", "per trial (mean probability)")):
        for y, r in zip(ys, rows, strict=True):
            v, ci = 100 * r[key], r[f"{key}_ci95"]
            err = None if ci is None else [[v - 100 * ci[0]], [100 * ci[1] - v]]
            ax.errorbar([v], [y], xerr=err, fmt="o", color=colour[r["input"]], capsize=3,
                        ms=5)
            if r["label"] == rec["recommended"]:
                ax.scatter([v], [y], marker="*", s=220, color="gold", edgecolors="black",
                           zorder=5)
        ax.axvline(5, color="0.6", ls=":", lw=1)  # chance: 1 of 20 materials
        ax.set_title(f"accuracy {title}, 95 % interval over trials", fontsize=9)
        ax.set_xlabel("accuracy (%)")
        ax.set_xlim(0, 102)
        ax.grid(alpha=0.3, axis="x")
    axes[1].axvline(100 * rec["reference_lower_bound"], color="C3", ls="--", lw=1)
    axes[0].set_yticks(ys, [r["label"] for r in rows], fontsize=8)
    from matplotlib.lines import Line2D

    handles = [Line2D([], [], marker="o", ls="", color=colour[k], label=INPUT_NAMES[k])
               for k in ("pac", "ele", "both")]
    handles += [Line2D([], [], marker="*", ls="", color="gold", markeredgecolor="black",
                       ms=12, label=f"recommended: {rec['recommended']}"),
                Line2D([], [], color="C3", ls="--", label="reference lower bound"),
                Line2D([], [], color="0.6", ls=":", label="chance (5 %)")]
    axes[1].legend(handles=handles, fontsize=7, loc="lower left")
    fig.suptitle("BioTac texture (20 materials, 5-fold CV by trial): which inputs carry it",
                 fontsize=10)
    fig.tight_layout()
    tmp = path.with_name(path.name + ".tmp")
    fig.savefig(tmp, format="png", dpi=110)
    plt.close(fig)
    os.replace(tmp, path)


def table(rows: list[dict[str, Any]]) -> str:
    lines = [f"{'input':6} {'model':6} {'window':>11} {'params':>9} {'window acc':>10} "
             f"{'95% CI':>11} {'trial acc':>9} {'95% CI':>11} {'fold sd':>7} {'b1 ms':>6}"]
    for r in rows:
        sd = r["trial_accuracy_fold_std"]
        lines.append(
            f"{r['input']:6} {r['family']:6} {r['window']:>11} {r['n_params']:9,} "
            f"{100 * r['window_accuracy']:9.1f}% {fmt_interval(r['window_accuracy_ci95']):>11} "
            f"{100 * r['trial_accuracy']:8.1f}% {fmt_interval(r['trial_accuracy_ci95']):>11} "
            f"{'n/a' if sd is None else f'{100 * sd:.1f}':>7} {r['batch1_ms_median']:6.3f}")
    return "\n".join(lines)


def _window_text(inp: str, w: int) -> str:
    return f"{w} ({1000 * w / RATE_HZ[inp]:.0f} ms)"


def build_rows(results: dict[str, dict[str, Any]], families: list[str]) -> list[dict[str, Any]]:
    rows = []
    for fam in families:
        for inp in ("pac", "ele"):
            for w in WINDOWS[inp][fam]:
                if w is None or f"{inp}_{fam}_w{w}" not in results:
                    continue
                r = results[f"{inp}_{fam}_w{w}"]
                s = score(r["probabilities"])
                ev = r["evaluate"]
                if abs(s["window_accuracy"] - ev["window_accuracy"]) > 1e-9:
                    raise AssertionError(f"{r['name']}: window accuracy {s['window_accuracy']}"
                                         f" differs from evaluate's {ev['window_accuracy']}")
                rows.append({"label": f"{inp}/{fam}/w{w}", "input": inp, "family": fam,
                             "window": _window_text(inp, w), "runs": [r["name"]],
                             "n_params": r["n_params"],
                             "batch1_ms_median": r["batch1_ms_median"], **s,
                             "evaluate": ev})
        for rank in (0, 1):
            wv, we = WINDOWS["pac"][fam][rank], WINDOWS["ele"][fam][rank]
            if wv is None or we is None or f"pac_{fam}_w{wv}" not in results \
                    or f"ele_{fam}_w{we}" not in results:
                continue
            rv, re_ = results[f"pac_{fam}_w{wv}"], results[f"ele_{fam}_w{we}"]
            folds, trial_p = fuse(rv["probabilities"], re_["probabilities"])
            rows.append({"label": f"both/{fam}/w{wv}+w{we}", "input": "both", "family": fam,
                         "window": f"{wv}+{we}", "runs": [rv["name"], re_["name"]],
                         "n_params": rv["n_params"] + re_["n_params"],
                         "batch1_ms_median": rv["batch1_ms_median"]
                         + re_["batch1_ms_median"], **score(folds, trial_p)})
    order = {"pac": 0, "ele": 1, "both": 2}
    # stable: the long window before the short one within a family
    return sorted(rows, key=lambda r: (order[r["input"]], FAMILIES.index(r["family"])))


def compare_chart(results: dict[str, dict[str, Any]], path: Path) -> dict[str, Any] | None:
    """``tactile compare`` of the single-input runs by per-trial accuracy (majority vote, as
    evaluate reports it) against latency, intervals drawn; None if compare refuses."""
    from tactile_cli.errors import InputError
    from tactile_cli.learn.compare import compare, plot_comparison
    from tactile_cli.store.atomic import write_bytes

    try:
        cmp = compare([r["run_dir"] for r in results.values()], metric="trial_accuracy",
                      margin_pp=5.0)
    except InputError as exc:
        print(f"compare: {exc}", file=sys.stderr)
        return None
    write_bytes(path, plot_comparison(cmp, title="tactile compare: per-trial accuracy "
                                       "(majority) against latency, 95 % intervals"),
                overwrite=True)
    return {"needed_within_5pp": cmp.needed.label, "best": cmp.best.label,
            "summary": cmp.summary()}


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", type=Path, default=None, help="ingested biotac_slide20.h5")
    ap.add_argument("--source", type=Path,
                    default=ROOT.parent / "shared" / "data" / "biotac_slide20")
    ap.add_argument("--models", nargs="+", default=list(FAMILIES), choices=FAMILIES)
    ap.add_argument("--folds", type=int, default=5)
    ap.add_argument("--jobs", type=int, default=2, help="configs trained in parallel")
    ap.add_argument("--work", type=Path, default=None,
                    help="keep the ingested file and run folders here (reused)")
    ap.add_argument("--finished-only", action="store_true",
                    help="report only the configs whose runs are finished in --work (no "
                    "training); the others are listed as not run")
    ap.add_argument("--json", action="store_true", help="print the record as JSON")
    ap.add_argument("--out", type=Path, default=ROOT / "benchmarks" / "figures")
    args = ap.parse_args(argv)
    started = time.perf_counter()
    with tempfile.TemporaryDirectory(prefix="biotac_inputs_") as tmp_s:
        work = args.work or Path(tmp_s)
        work.mkdir(parents=True, exist_ok=True)
        data = args.data or work / "biotac_slide20.h5"
        if args.data is None and not data.is_file():
            ingest(args.source, data)
        names = config_names(args.models)
        not_run = []
        if args.finished_only:
            not_run = [n for n in names if not (work / "runs" / n / runs.RUN_JSON).is_file()]
            names = [n for n in names if n not in not_run]
        ctx = multiprocessing.get_context("spawn")  # no fork of a process with torch
        with ProcessPoolExecutor(max_workers=max(1, args.jobs), mp_context=ctx) as pool:
            futs = {n: pool.submit(run_config, n, str(data), str(work), args.folds)
                    for n in sorted(names, key=lambda n: -EST_CORE_S.get(n, 0))}
            results = {}
            for n in names:
                results[n] = futs[n].result()
                print(f"{n}: done ({results[n]['train_wall_s']:.0f} s training"
                      f"{', reused' if results[n]['reused'] else ''})", file=sys.stderr,
                      flush=True)
        rows = build_rows(results, args.models)
        rec = recommend(rows)
        args.out.mkdir(parents=True, exist_ok=True)
        cmp = compare_chart(results, args.out / "biotac_inputs_compare.png")
        plot(rows, rec, args.out / "biotac_inputs.png")
        wall = time.perf_counter() - started
        record = {
            "format": "tactile-biotac-inputs", "format_version": 1,
            "tool_version": __version__, "created_utc": utc_now(),
            "command": " ".join([COMMAND, *(argv if argv is not None else sys.argv[1:])]),
            "data": {"sha256": sha256_of(data), "source": str(args.source)},
            "folds": args.folds, "wall_time_s": wall, "cpu_count": os.cpu_count(),
            "load_average_end": list(os.getloadavg()),
            "fusion": ("late fusion, same family and window rank: per trial the average of "
                       "the two models' mean class probabilities; per window each vibration "
                       "window with the electrode window of the same trial ending nearest "
                       "in time, probabilities averaged"),
            "trial_accuracy": "mean-probability decision per trial (majority vote beside "
                              "it for single-input rows)",
            "runs": {n: {k: v for k, v in r.items() if k != "probabilities"}
                     for n, r in results.items()},
            "rows": rows, "recommendation": rec, "compare": cmp, "not_run": not_run,
        }
    out = args.out / "biotac_inputs.json"
    tmp_json = out.with_name(out.name + ".tmp")
    tmp_json.write_text(runs.dumps(record) + "\n", encoding="utf-8")
    os.replace(tmp_json, out)
    if args.json:
        print(runs.dumps(record))
        return 0
    print(table(rows))
    print(f"recommended: {rec['recommended']} (reference {rec['reference']}, lower bound "
          f"{100 * rec['reference_lower_bound']:.1f} %; eligible: {', '.join(rec['eligible'])};"
          f" top point estimate: {rec['top_point_estimate']})")
    if not_run:
        print(f"not run (unfinished in {args.work}): {', '.join(not_run)}")
    print(f"wall time {wall:.0f} s; wrote {out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
