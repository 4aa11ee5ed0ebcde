"""Frame -> height map speed (MLP normals + eq. 9 + Poisson) against a sparse-solver
baseline, and the height RMSE, at 320x240 (DIGIT) and 640x480 (GelSight).

Issue 16, item 4. One run measures, on the same frames and the same machine:

- ``tactile``: :class:`tactile_cli.visuotactile.heightmap.HeightMapper` (folded float32
  MLP in cache-sized tiles, eq. 9, DST-I Poisson solve on an FFT-friendly padded grid);
- ``baseline``: the same MLP and eq. 9, then the same 5-point Poisson system (same padded
  grid, same right-hand side) solved by ``scipy.sparse.linalg.spsolve`` (matrix built once,
  outside the timing); ``splu`` (factorised once, one triangular solve per frame) is
  reported beside it as the strongest sparse variant;
- the network and the solver alone, and the opt-in ``skip_below`` (flat pixels skipped)
  with its RMSE cost.

Frames: with ``--scene FILE --truth DIR --model RUN`` (an ingested ``tactile simulate
digit-press`` trials file, its ``truth/`` folder, a run trained on another seed's
calibration presses) the timed frames are the scene's and the RMSE is against its truth.
Without them, ball presses rendered by the tests' factory (``tests/factories/gel_frames``)
with a small network trained on the factory's presses (seed 0; timed frames seed 1).
640x480 frames are always factory presses (timing; RMSE only where the model was trained
on that size, so it is left out there).

    .venv/bin/python benchmarks/heightmap.py [--scene trials.h5 --truth DIR --model RUN]
        [--models RUN ...] [--strides 1 2 3] [--camera RUN STRIDE] [--before TREE]
        [--frames 30] [--json]

JSON keys: tactile_ms_per_frame, baseline_ms_per_frame, ratio, height_rmse_mm (320x240),
replay_fps (issue 35, item 6: a whole replay of the timed 320x240 frames as one 60 fps
trial through ``monitor_file`` with the height source: frame read, height map, slip
signal on the 32x24 mesh, monitor; ``replay`` beside it holds the frame read alone),
plus per-size details and the load average before and after.

Camera rate (issue 35, item 6): ``camera_rate`` holds, for ``--model`` and each of
``--models`` at each of ``--strides`` (``HeightMapper(stride=k)``: the network on k x k
block means, the solve on the blocks, heights interpolated back), the median ms per
frame over ``--rounds`` interleaved rounds and the height RMSE over all pixels and the
contact pixels, with ``rmse_vs_today`` against ``--model`` at stride 1; ``before`` (with
``--before TREE``, an earlier checkout) the same frames through that tree's HeightMapper
in a separate process, and ``speedup_vs_before``; ``camera_replay_fps`` (with ``--camera
RUN STRIDE``) the whole replay at that setting.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))


def _laplacian(rows: int, cols: int):  # type: ignore[no-untyped-def]
    import scipy.sparse as sp

    def d2(n: int):  # type: ignore[no-untyped-def]
        return sp.diags([np.ones(n - 1), -2 * np.ones(n), np.ones(n - 1)], [-1, 0, 1])

    return (sp.kron(sp.identity(rows), d2(cols)) + sp.kron(d2(rows), sp.identity(cols))).tocsc()


def _timed(fn, items, repeat: int = 1) -> tuple[float, list]:  # type: ignore[no-untyped-def]
    fn(items[0])  # warm-up (caches, FFT plans)
    out = []
    t0 = time.perf_counter()
    for _ in range(repeat):
        out = [fn(x) for x in items]
    return 1e3 * (time.perf_counter() - t0) / (repeat * len(items)), out


def factory_frames(shape: tuple[int, int], n: int, seed: int, px_per_mm: float
                   ) -> tuple[list[np.ndarray], np.ndarray, list[np.ndarray]]:
    from tests.factories.gel_frames import shade, sphere_cap

    rng = np.random.default_rng(seed)
    h, w = shape
    ref = shade(np.zeros(shape), px_per_mm=px_per_mm, noise_std=1.0, rng=rng)
    truths, frames = [], []
    for _ in range(n):
        cap = sphere_cap(shape, (rng.uniform(0.3, 0.7) * w, rng.uniform(0.3, 0.7) * h),
                         rng.uniform(2.0, 4.0), rng.uniform(0.3, 0.8), px_per_mm)
        truths.append(cap.astype(np.float32))
        frames.append(shade(cap, px_per_mm=px_per_mm, noise_std=1.0, rng=rng))
    return frames, ref, truths


def factory_model(work: Path, shape: tuple[int, int], px_per_mm: float) -> Path:
    """A normal network trained on factory presses of ``shape`` (seed 0)."""
    import yaml

    from tactile_cli.learn import parse_config
    from tactile_cli.learn.train import train
    from tactile_cli.store import StoreWriter
    from tests.factories.gel_frames import TRAIN_YAML, normals_of, shade, sphere_cap

    rng = np.random.default_rng(0)
    h, w = shape
    yy, xx = np.mgrid[0:h, 0:w].astype(np.float32)
    ref = shade(np.zeros(shape), px_per_mm=px_per_mm, noise_std=1.0, rng=rng)
    table = work / "pixels.h5"
    with StoreWriter(table, command="benchmarks/heightmap.py") as wr:
        s = wr.add_sensor("pixels", kind="visuotactile", sample_rate_hz=1000.0, width_px=w,
                          height_px=h, channel_names=["x", "y", "dR", "dG", "dB"],
                          channel_units=["px", "px", "", "", ""])
        for i in range(8):
            cap = sphere_cap(shape, (rng.uniform(0.3, 0.7) * w, rng.uniform(0.3, 0.7) * h),
                             rng.uniform(2.0, 4.0), rng.uniform(0.3, 0.8), px_per_mm)
            frame = shade(cap, px_per_mm=px_per_mm, noise_std=1.0, rng=rng)
            diff = (frame.astype(np.float32) - ref).reshape(-1, 3)
            n = normals_of(cap, px_per_mm).reshape(-1, 3)
            keep = (np.abs(cap.ravel()) > 0) | (rng.random(h * w) < 0.1)
            data = np.c_[xx.ravel(), yy.ravel(), diff][keep]
            t = wr.trial(f"ball_{i:02d}")
            t.write_signal("pixels", sensor=s, data=data,
                           t_s=np.arange(keep.sum(), dtype=np.float64) * 1e-3,
                           sample_labels={k: (n[keep, j].astype(np.float32), None)
                                          for j, k in enumerate(("nx", "ny", "nz"))})
        wr.commit()
    cfg = yaml.safe_load(TRAIN_YAML)
    cfg["optim"]["epochs"] = 8
    out = work / "run"
    train(parse_config(cfg), [table], out)
    return out


def scene_frames(path: Path, truth: Path, n: int) -> tuple[list[np.ndarray], list[np.ndarray],
                                                           list[np.ndarray], float]:
    """Up to ``n`` frames spread over the scene's trials, their references and truths."""
    from tactile_cli.store.trials import TactileFile
    from tactile_cli.visuotactile.heightmap import frame_trials, frames_px_per_mm, load_truth

    frames, refs, truths = [], [], []
    with TactileFile(path) as tf:
        trials = frame_trials(tf)
        ppm = frames_px_per_mm(tf, trials[0], None)
        per = max(1, -(-n // len(trials)))
        for t in trials:
            fr = t.frames()
            true = load_truth(truth, t.name, (len(fr), *fr.shape[:2]))
            for k in np.linspace(0, len(fr) - 1, per).astype(int):
                frames.append(fr[int(k)])
                refs.append(fr.reference)
                truths.append(true[int(k)])
            if len(frames) >= n:
                break
    return frames[:n], refs[:n], truths[:n], ppm


def measure(model, frames, refs, truths, ppm: float, *, rmse: bool,  # type: ignore[no-untyped-def]
            baseline: bool = True) -> dict:
    import scipy.sparse.linalg as spla

    from tactile_cli.visuotactile.heightmap import HeightMapper
    from tactile_cli.visuotactile.poisson import gradients_from_normals

    h, w = frames[0].shape[:2]
    mapper = HeightMapper(model, ppm)
    solver = mapper.solver(h, w)
    items = list(zip(frames, refs, strict=True))
    res: dict = {"size": f"{w}x{h}", "n_frames": len(frames), "workers": mapper.workers,
                 "padded_grid": f"{solver.cols}x{solver.rows}"}
    res["tactile_ms_per_frame"], heights = _timed(lambda x: mapper(*x), items, repeat=2)
    res["mlp_ms_per_frame"], normals = _timed(lambda x: mapper.normals(*x), items)
    grads = [gradients_from_normals(n, nz_floor=mapper.nz_floor) for n in normals]
    res["poisson_dst_ms_per_frame"], _ = _timed(lambda g: solver.integrate(*g), grads, repeat=3)
    if rmse:
        err = np.concatenate([(a - b).ravel() for a, b in zip(heights, truths, strict=True)])
        res["height_rmse_mm"] = float(np.sqrt(np.mean(err.astype(np.float64) ** 2)))
        res["peak_mm"] = [float(a.max()) for a in heights[:5]]
        res["true_peak_mm"] = [float(b.max()) for b in truths[:5]]
    if baseline:
        lap = _laplacian(solver.rows, solver.cols)

        def sparse_solve(g: tuple[np.ndarray, np.ndarray]) -> np.ndarray:
            f = solver.divergence(*g).astype(np.float64)
            u = spla.spsolve(lap, f.ravel()).reshape(solver.rows, solver.cols)
            return u[solver.top:solver.top + h, solver.left:solver.left + w]

        n_base = min(len(grads), 5)  # spsolve refactorises per frame: slow, a few suffice
        res["spsolve_ms_per_frame"], base = _timed(sparse_solve, grads[:n_base])
        lu = spla.splu(lap)

        def lu_solve(g: tuple[np.ndarray, np.ndarray]) -> np.ndarray:
            return lu.solve(solver.divergence(*g).astype(np.float64).ravel())

        res["splu_solve_ms_per_frame"], _ = _timed(lu_solve, grads[:n_base])
        dst = [solver.integrate(*g) for g in grads[:n_base]]
        res["max_abs_diff_dst_vs_spsolve_mm"] = float(max(
            np.abs(a.astype(np.float64) - b).max() for a, b in zip(dst, base, strict=True)))
        res["baseline_ms_per_frame"] = res["mlp_ms_per_frame"] + res["spsolve_ms_per_frame"]
        res["baseline_splu_ms_per_frame"] = (res["mlp_ms_per_frame"]
                                             + res["splu_solve_ms_per_frame"])
        res["ratio"] = res["baseline_ms_per_frame"] / res["tactile_ms_per_frame"]
        res["ratio_vs_splu"] = res["baseline_splu_ms_per_frame"] / res["tactile_ms_per_frame"]
    return res


def skip_study(model, frames, refs, truths, ppm: float, levels: list[float]) -> list[dict]:  # type: ignore[no-untyped-def]
    from tactile_cli.visuotactile.heightmap import HeightMapper

    rows = []
    items = list(zip(frames, refs, strict=True))
    for level in levels:
        mapper = HeightMapper(model, ppm, skip_below=level)
        ms, heights = _timed(lambda x, m=mapper: m(*x), items, repeat=2)
        err = np.concatenate([(a - b).ravel() for a, b in zip(heights, truths, strict=True)])
        rows.append({"skip_below": level, "ms_per_frame": ms,
                     "height_rmse_mm": float(np.sqrt(np.mean(err.astype(np.float64) ** 2)))})
    return rows


def replay_study(work: Path, run: Path, frames: list[np.ndarray], ref: np.ndarray,
                 ppm: float, stride: int = 1) -> dict:
    """A whole replay of ``frames`` as one 60 fps trial of a tactile file: the frame read
    alone, and ``monitor_file`` with the height source (read, height map at ``stride``,
    slip signal on the 32x24 mesh, monitor), frames per second of each."""
    from tactile_cli.store import StoreWriter
    from tactile_cli.store.trials import TactileFile
    from tactile_cli.visuotactile.monitor_replay import monitor_file

    path = work / "replay.h5"
    h, w = frames[0].shape[:2]
    path.unlink(missing_ok=True)
    with StoreWriter(path, command="benchmarks/heightmap.py") as wr:
        s = wr.add_sensor("digit", kind="visuotactile", sample_rate_hz=60.0, width_px=w,
                          height_px=h, px_per_mm=ppm)
        wr.trial("replay").write_frames(sensor=s, images=np.stack(frames),
                                        t_s=np.arange(len(frames)) / 60.0, reference=ref)
        wr.commit()
    n = len(frames)
    t0 = time.perf_counter()
    with TactileFile(path) as tf:
        fr = tf.trial("replay").frames()
        read = sum(int(img[0, 0, 0]) for _, img in fr)  # every frame decoded
    read_s = time.perf_counter() - t0
    monitor_file(path, source="height", model_run=run, n_static=5, stride=stride)  # warm-up
    t0 = time.perf_counter()
    monitor_file(path, source="height", model_run=run, n_static=5, stride=stride)
    replay_s = time.perf_counter() - t0
    return {"frames": n, "model": str(run), "stride": stride,
            "read_fps": round(n / read_s, 1), "replay_fps": round(n / replay_s, 1),
            "replay_ms_per_frame": round(1e3 * replay_s / n, 2), "checksum": read}


def _rounds(mappers: dict, items: list, rounds: int) -> dict:
    """Median ms per frame of each mapper over ``rounds`` rounds, the mappers interleaved
    within a round (so a slow moment of the machine falls on all of them)."""
    times: dict = {key: [] for key in mappers}
    for _ in range(rounds):
        for key, mapper in mappers.items():
            mapper(*items[0])  # warm-up (buffers, FFT plans)
            t0 = time.perf_counter()
            for x in items:
                mapper(*x)
            times[key].append(1e3 * (time.perf_counter() - t0) / len(items))
    return {key: float(np.median(v)) for key, v in times.items()}


def camera_rate_study(runs: list[Path], frames, refs, truths, ppm: float,  # type: ignore[no-untyped-def]
                      strides: list[int], rounds: int) -> list[dict]:
    """Issue 35, item 6: ms per frame (median of interleaved rounds) and height RMSE (all
    pixels and the truth's contact pixels, height > 0) of every model run at every
    stride, on the same frames; ``rmse_vs_today`` relative to the first run at stride 1
    (the paper's network at every pixel)."""
    from tactile_cli.visuotactile.heightmap import HeightMapper
    from tactile_cli.visuotactile.normals import NormalModel

    items = list(zip(frames, refs, strict=True))
    mappers = {}
    for run in runs:
        model = NormalModel.from_run(run)
        for k in strides:
            mappers[(str(run), k)] = HeightMapper(model, ppm, stride=k)
    ms = _rounds(mappers, items, rounds)
    rows = []
    for (run, k), mapper in mappers.items():
        sq = sq_c = 0.0
        n = n_c = 0
        for (frame, ref), true in zip(items, truths, strict=True):
            err = (mapper(frame, ref).astype(np.float64) - true) ** 2
            contact = true > 0
            sq, n = sq + float(err.sum()), n + err.size
            sq_c, n_c = sq_c + float(err[contact].sum()), n_c + int(contact.sum())
        hidden = [int(w.shape[1]) for w, _ in mapper.model.hidden]
        rows.append({"model": run, "hidden": [int(mapper.model.b1.size), *hidden],
                     "stride": k, "ms_per_frame": round(ms[(run, k)], 2),
                     "height_rmse_mm": float(np.sqrt(sq / n)),
                     "height_rmse_contact_mm": float(np.sqrt(sq_c / n_c)) if n_c else None})
    today = rows[0]
    for r in rows:
        r["rmse_vs_today"] = round(r["height_rmse_mm"] / today["height_rmse_mm"] - 1, 4)
        if today["height_rmse_contact_mm"] and r["height_rmse_contact_mm"]:
            r["contact_rmse_vs_today"] = round(
                r["height_rmse_contact_mm"] / today["height_rmse_contact_mm"] - 1, 4)
    return rows


_BEFORE = """
import json, sys, time
import numpy as np
from tactile_cli.visuotactile.heightmap import HeightMapper
from tactile_cli.visuotactile.normals import NormalModel
z = np.load(sys.argv[1])
items = list(zip(z["frames"], z["refs"]))
mapper = HeightMapper(NormalModel.from_run(sys.argv[2]), float(z["ppm"]))
times = []
for _ in range(int(sys.argv[3])):
    mapper(*items[0])
    t0 = time.perf_counter()
    for x in items:
        mapper(*x)
    times.append(1e3 * (time.perf_counter() - t0) / len(items))
print(json.dumps({"ms_per_frame": float(np.median(times))}))
"""


def before_study(tree: Path, work: Path, run: Path, frames, refs, ppm: float,  # type: ignore[no-untyped-def]
                 rounds: int) -> dict:
    """The same frames through ``HeightMapper`` of an earlier checkout ``tree`` (the
    implementation before this one), in a separate process: median ms per frame."""
    import subprocess

    data = work / "before_frames.npz"
    np.savez(data, frames=np.stack(frames), refs=np.stack(refs), ppm=ppm)
    env = dict(os.environ, PYTHONPATH=str(tree.resolve()))
    out = subprocess.run([sys.executable, "-c", _BEFORE, str(data), str(run.resolve()),
                          str(rounds)], env=env, capture_output=True, text=True, cwd=tree)
    if out.returncode != 0:
        raise SystemExit(f"--before {tree}: {out.stderr.strip().splitlines()[-1]}")
    commit = subprocess.run(["git", "-C", str(tree), "rev-parse", "--short", "HEAD"],
                            capture_output=True, text=True).stdout.strip() or None
    return {"tree": str(tree), "commit": commit, **json.loads(out.stdout.splitlines()[-1])}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scene", type=Path, help="ingested digit-press trials file")
    ap.add_argument("--truth", type=Path, help="the scene's truth/ folder")
    ap.add_argument("--model", type=Path, help="normal-network run folder")
    ap.add_argument("--frames", type=int, default=30)
    ap.add_argument("--skip-levels", type=float, nargs="*", default=[2.0, 4.0, 8.0])
    ap.add_argument("--models", type=Path, nargs="*", default=[],
                    help="further normal-network runs for the camera-rate study (issue 35, "
                         "item 6), e.g. configs/train_mlp_normals_small.yaml's")
    ap.add_argument("--strides", type=int, nargs="*", default=[1, 2, 3],
                    help="block sides of the camera-rate study (HeightMapper stride)")
    ap.add_argument("--camera", nargs=2, metavar=("RUN", "STRIDE"),
                    help="the setting whose whole replay is also timed (camera_replay_fps)")
    ap.add_argument("--rounds", type=int, default=5, help="interleaved timing rounds")
    ap.add_argument("--before", type=Path, metavar="TREE",
                    help="an earlier checkout of this repository: its HeightMapper on the "
                         "same frames and --model, timed in a separate process")
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args()

    from tactile_cli.visuotactile.normals import NormalModel

    load_before = os.getloadavg()
    with tempfile.TemporaryDirectory() as tmp:
        work = Path(tmp)
        if args.scene is not None:
            if args.truth is None or args.model is None:
                ap.error("--scene needs --truth and --model")
            frames, refs, truths, ppm = scene_frames(args.scene, args.truth, args.frames)
            run = args.model
            source = f"scene {args.scene}"
        else:
            ppm = 16.0
            run = args.model or factory_model(work, (240, 320), ppm)
            frames, ref, truths = factory_frames((240, 320), args.frames, 1, ppm)
            refs = [ref] * len(frames)
            source = "factory ball presses (tests/factories/gel_frames), seed 1"
        model = NormalModel.from_run(run)
        small = measure(model, frames, refs, truths, ppm, rmse=True)
        skips = skip_study(model, frames, refs, truths, ppm, args.skip_levels)
        camera = camera_rate_study([run, *args.models], frames, refs, truths, ppm,
                                   args.strides, args.rounds)
        before = (None if args.before is None else
                  before_study(args.before, work, run, frames, refs, ppm, args.rounds))
        replay = replay_study(work, run, frames, refs[0], ppm)
        camera_replay = (None if args.camera is None else
                         replay_study(work, Path(args.camera[0]), frames, refs[0], ppm,
                                      stride=int(args.camera[1])))
        big_frames, big_ref, big_truth = factory_frames((480, 640), min(args.frames, 10), 2, ppm)
        big = measure(model, big_frames, [big_ref] * len(big_frames), big_truth, ppm,
                      rmse=False)
    load_after = os.getloadavg()
    out = {
        "tactile_ms_per_frame": small["tactile_ms_per_frame"],
        "baseline_ms_per_frame": small["baseline_ms_per_frame"],
        "ratio": small["ratio"],
        "height_rmse_mm": small["height_rmse_mm"],
        "frames": source, "model": str(args.model or "factory-trained (seed 0)"),
        "320x240": small, "640x480": big, "skip_below": skips,
        "load_before": load_before, "load_after": load_after, "cpus": os.cpu_count(),
        "target_ms_per_frame": 5.0, "target_ratio": 10.0,
        "replay_fps": replay["replay_fps"], "replay": replay, "target_replay_fps": 60.0,
        "camera_rate": camera, "before": before,
        "camera_replay_fps": None if camera_replay is None else camera_replay["replay_fps"],
        "camera_replay": camera_replay,
    }
    here = next(r for r in camera if r["model"] == str(run) and r["stride"] == 1)
    if before is not None:
        out["speedup_vs_before"] = round(before["ms_per_frame"] / here["ms_per_frame"], 2)
    if args.json:
        print(json.dumps(out, indent=2))
        return
    for key in ("320x240", "640x480"):
        r = out[key]
        print(f"{key}: tactile {r['tactile_ms_per_frame']:.2f} ms/frame (MLP "
              f"{r['mlp_ms_per_frame']:.2f}, DST Poisson {r['poisson_dst_ms_per_frame']:.2f} on "
              f"{r['padded_grid']}); baseline MLP + spsolve {r['baseline_ms_per_frame']:.1f} "
              f"ms (ratio {r['ratio']:.1f}x), MLP + splu solve "
              f"{r['baseline_splu_ms_per_frame']:.1f} ms ({r['ratio_vs_splu']:.2f}x); DST vs "
              f"spsolve max diff {r['max_abs_diff_dst_vs_spsolve_mm']:.1e} mm")
    print(f"height RMSE {out['height_rmse_mm']:.4f} mm on {source}")
    print(f"replay (read, height map, slip signal, monitor) of {replay['frames']} frames: "
          f"{replay['replay_fps']:.1f} fps ({replay['replay_ms_per_frame']:.1f} ms a frame); "
          f"frame read alone {replay['read_fps']:.0f} fps")
    for s in skips:
        print(f"  skip_below {s['skip_below']:g}: {s['ms_per_frame']:.2f} ms/frame, RMSE "
              f"{s['height_rmse_mm']:.4f} mm")
    print(f"camera rate (median of {args.rounds} interleaved rounds; RMSE against the first "
          "model at stride 1):")
    for r in camera:
        contact = r.get("contact_rmse_vs_today")
        print(f"  {'-'.join(map(str, [5, *r['hidden'], 3]))} stride {r['stride']}: "
              f"{r['ms_per_frame']:.2f} ms/frame, RMSE {r['height_rmse_mm']:.4f} mm "
              f"({100 * r['rmse_vs_today']:+.1f} %), contact "
              f"{r['height_rmse_contact_mm']:.4f} mm"
              + ("" if contact is None else f" ({100 * contact:+.1f} %)"))
    if before is not None:
        print(f"before ({before['commit']}): {before['ms_per_frame']:.2f} ms/frame; now "
              f"{here['ms_per_frame']:.2f} ({out['speedup_vs_before']:.2f}x)")
    if camera_replay is not None:
        print(f"replay at {args.camera[0]} stride {args.camera[1]}: "
              f"{camera_replay['replay_fps']:.1f} fps")
    print(f"load average before {load_before}, after {load_after}; {os.cpu_count()} CPUs")


if __name__ == "__main__":
    main()
