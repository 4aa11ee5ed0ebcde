"""What the exported model costs on the robot: batch-1 latency of `tactile export`'s ONNX file
in onnxruntime beside the same model in PyTorch, and how far their outputs are apart.

For every family (LSTM, CNN 1-D, spectrogram CNN 2-D, FNN, MLP with summary features) a
run with the family's default sizes is trained briefly (3 epochs; the weights matter only
for the outputs compared, not for the cost) on synthetic action trials (three event-count
channels, positive, negative and net; 20 ms bins, window 50 samples = 1 s, signed_log1p,
per-channel normalisation), exported with :func:`tactile_cli.learn.export.export_run` and
timed on held-out windows in the same process, one after the other:

- baseline ``torch_ms``: PyTorch running :class:`~tactile_cli.learn.export.DeployedModel`,
  the very graph that is exported (raw window in, transform, normalisation, network,
  softmax), timed by :func:`tactile_cli.learn.latency.measure_latency` (batch 1, median of
  300 calls after 30 warm-up calls, 1 thread, ``torch.inference_mode``);
- ``onnx_ms``: onnxruntime (CPU execution provider, 1 intra-op thread) on the exported
  file, the same windows, the same timing (:func:`tactile_cli.learn.export.time_batch1`);
- ``max_abs_diff``: largest absolute difference between the ONNX outputs (class
  probabilities) and `tactile evaluate`'s own (:func:`~tactile_cli.learn.export.package_outputs`)
  over every held-out window.

The ratio printed is ``torch_ms / onnx_ms`` (above 1: the exported model is faster).

    .venv/bin/python benchmarks/export.py                # table
    .venv/bin/python benchmarks/export.py --json         # one row per family
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from tactile_cli.learn import export as ex  # noqa: E402
from tactile_cli.learn.config import parse_config  # noqa: E402
from tactile_cli.learn.data import make_windows, read_trials  # noqa: E402
from tactile_cli.learn.latency import cpu_name, measure_latency  # noqa: E402
from tactile_cli.learn.runs import load_run  # noqa: E402
from tactile_cli.learn.train import train  # noqa: E402
from tests.factories.action_files import make_action_file  # noqa: E402

FAMILIES = ("lstm", "cnn1d", "cnn2d_spectrogram", "fnn", "mlp")
CHANNELS = ("positive", "negative", "net")


def config(family: str, *, window: int, epochs: int):
    return parse_config({
        "seed": 0,
        "data": {"stream": "event_counts", "channels": list(CHANNELS), "window": window,
                 "stride": 5, "pad": "zero", "transform": "signed_log1p",
                 "targets": [{"name": "action"}],
                 "split": {"val_fraction": 0.25, "test_fraction": 0.0}},
        "model": {"family": family},
        "optim": {"epochs": epochs, "batch_size": 128, "threads": 1, "patience": 0},
    })


def measure(family: str, root: Path, train_file: Path, test_file: Path, *, window: int,
            epochs: int, repeats: int) -> dict:
    run_dir = root / family
    train(config(family, window=window, epochs=epochs), [train_file], run_dir,
          command="benchmarks/export.py")
    path = ex.export_run(run_dir, root / f"{family}.onnx", command="benchmarks/export.py").path
    run = load_run(run_dir)
    trials = read_trials([test_file], run.config.data, trained=True)
    ws = make_windows(trials, run.config.data, run.heads, run.normalisation)
    raw = ex.raw_windows(trials, run)
    onnx = ex.ExportedModel(path, threads=1)
    diff = ex.max_abs_diff(onnx(raw), ex.package_outputs(run.load_model(), ws, run.heads,
                                                         run.normalisation.targets))
    pick = np.sort(np.random.default_rng(0).choice(len(raw), min(len(raw), 2048),
                                                   replace=False))
    torch_ms = measure_latency(ex.deployed_model(run), raw[pick], threads=1,
                               repeats=repeats, large_batch=64, large_repeats=1
                               ).batch1_ms_median
    onnx_ms = ex.time_batch1(onnx.run_batch, raw[pick], repeats=repeats)["batch1_ms_median"]
    return {"family": family, "torch_ms": torch_ms, "onnx_ms": onnx_ms,
            "max_abs_diff": diff, "n_windows": int(len(raw)),
            "file_kb": path.stat().st_size / 1e3}


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--json", action="store_true", help="print one JSON row per family")
    ap.add_argument("--window", type=int, default=50)
    ap.add_argument("--epochs", type=int, default=3)
    ap.add_argument("--repeats", type=int, default=300)
    ap.add_argument("--families", default=",".join(FAMILIES))
    args = ap.parse_args(argv)
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        root = Path(tmp)
        train_file = make_action_file(root / "train.h5", n_trials=24, seed=0,
                                      channel_names=CHANNELS)
        test_file = make_action_file(root / "test.h5", n_trials=12, seed=7,
                                     channel_names=CHANNELS)
        for family in args.families.split(","):
            rows.append(measure(family, root, train_file, test_file, window=args.window,
                                epochs=args.epochs, repeats=args.repeats))
    if args.json:
        print(json.dumps(rows, indent=2))
        return 0
    print(f"batch-1 latency per window, 1 thread, {cpu_name()}; window {args.window} x "
          f"{len(CHANNELS)} channels; baseline PyTorch")
    print(f"{'family':<18} {'torch ms':>9} {'onnx ms':>9} {'ratio':>7} {'max |diff|':>11} "
          f"{'file kB':>8}")
    for r in rows:
        print(f"{r['family']:<18} {r['torch_ms']:9.4f} {r['onnx_ms']:9.4f} "
              f"{r['torch_ms'] / r['onnx_ms']:6.2f}x {r['max_abs_diff']:11.2e} "
              f"{r['file_kb']:8.1f}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
