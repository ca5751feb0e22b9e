"""Benchmark the in-memory CULane metric (`roneld_eval.metric("culane", ...)`) as a training loop
uses it, beside `score culane` on the same lanes in files and CLRNet's culane_metric.py.

On generated lane files (`synth_lane_files`, the official test list's size by default), for one
threshold (0.5) and the 0.50:0.95 grid:
- `score culane --workers 1` in a fresh process, with a warm ground-truth cache (its second run);
- the metric in a fresh process (the lanes read into memory first, untimed: a model gives them),
  fed frame by frame for `--epochs` epochs (`reset()` between them), `compute()` each time:
  every epoch's seconds, the second against the first, and the process's RSS after each;
- CLRNet's `culane_metric(pred, anno, ...)` (Turoad/CLRNet 7269e9d, clrnet/utils/culane_metric.py,
  given with --clrnet; not part of this project) on the first --clrnet-frames frames, the label
  lanes handed to it in memory too, as its per-frame cost (ms a frame) against the metric's.
The metric's F1 at 0.5 must equal score culane's; the script says so.

    python scripts/bench_in_memory.py [--frames 34680] [--epochs 5] [--clrnet PATH] [--clrnet-frames 500]
"""

from __future__ import annotations

import argparse
import csv
import importlib.util
import json
import os
import resource
import subprocess
import sys
import tempfile
import time
import types
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
GRIDS = ("0.5", "0.50:0.95:0.05")


def rss_mb() -> float:
    with open("/proc/self/statm") as statm:
        return int(statm.read().split()[1]) * os.sysconf("SC_PAGE_SIZE") / 2**20


def read_lanes(root: Path, frames) -> dict:
    from roneld_eval.benchmarks.culane.reader import labels_path
    from roneld_eval.lanes_io import read_lines_txt

    return {frame: [lane.points for lane in read_lines_txt(labels_path(root, frame))] for frame in frames}


def child(gt: Path, pred: Path, iou: str, epochs: int) -> dict:
    """The metric's epochs in this (fresh) process."""
    import roneld_eval

    roneld_eval.warm_up()
    metric = roneld_eval.metric("culane", data_root=gt, iou=iou)
    lanes = read_lanes(pred, metric.core.frames)
    out: dict = {"epochs": [], "rss": [], "rss_before": rss_mb()}
    for _ in range(epochs):
        start = time.perf_counter()
        for frame, frame_lanes in lanes.items():
            metric.update(frame, frame_lanes)
        scores = metric.compute()
        out["epochs"].append(time.perf_counter() - start)
        out["rss"].append(rss_mb())
        metric.reset()
    out["f1_50"] = scores["F1@50"]
    out["peak_mb"] = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    return out


def clrnet_child(gt: Path, pred: Path, path: Path, n_frames: int, iou: str) -> dict:
    """CLRNet's per-frame metric on the first frames, lanes in memory."""
    for name in ("p_tqdm", "shapely", "shapely.geometry"):  # imported at its top, not called with official=True
        try:
            importlib.import_module(name)
        except ImportError:
            stand_in = types.ModuleType(name)
            stand_in.t_map = stand_in.p_map = stand_in.LineString = stand_in.Polygon = None  # type: ignore[attr-defined]
            sys.modules[name] = stand_in
    spec = importlib.util.spec_from_file_location("clrnet_culane_metric", path)
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    import roneld_eval
    from roneld_eval.thresholds import parse_thresholds

    frames = roneld_eval.metric("culane", data_root=gt).core.frames[:n_frames]
    predicted, truth = read_lanes(pred, frames), read_lanes(gt, frames)
    thresholds = list(parse_thresholds(iou).values)
    # its reader keeps lanes of 2 points or more, as (x, y) tuples
    pairs = [([p.tolist() for p in predicted[f] if len(p) >= 2], [p.tolist() for p in truth[f] if len(p) >= 2])
             for f in frames]
    refused = 0
    start = time.perf_counter()
    for pred_lanes, anno in pairs:
        try:
            module.culane_metric(pred_lanes, anno, width=30, iou_thresholds=thresholds, official=True)
        except ValueError:  # its splprep refuses a lane with repeated points: its eval stops there
            refused += 1
    return {"frames": len(pairs), "seconds": time.perf_counter() - start, "refused": refused}


def score_seconds(gt: Path, pred: Path, iou: str, out: Path, cache: Path) -> float:
    command = [sys.executable, "-m", "roneld_eval", "score", "culane", "--data-root", str(gt), "--pred-root",
               str(pred), "--iou", iou, "--workers", "1", "--quiet", "--out", str(out)]
    env = {**os.environ, "RONELD_EVAL_TRUTH_CACHE": str(cache)}
    subprocess.run([*command[:-1], str(out) + "-warm"], check=True, env=env, stdout=subprocess.DEVNULL)
    start = time.perf_counter()
    subprocess.run(command, check=True, env=env, stdout=subprocess.DEVNULL)
    return time.perf_counter() - start


def in_child(*args: str) -> dict:
    found = subprocess.run([sys.executable, __file__, "--child", *args], check=True, capture_output=True, text=True)
    return json.loads(found.stdout.strip().splitlines()[-1])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--frames", type=int, default=34680)
    parser.add_argument("--epochs", type=int, default=5)
    parser.add_argument("--clrnet", type=Path, help="CLRNet's clrnet/utils/culane_metric.py")
    parser.add_argument("--clrnet-frames", type=int, default=500)
    parser.add_argument("--child", nargs="+", help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.child:
        kind, gt, pred, *rest = args.child
        if kind == "metric":
            print(json.dumps(child(Path(gt), Path(pred), rest[0], int(rest[1]))))
        else:
            print(json.dumps(clrnet_child(Path(gt), Path(pred), Path(rest[0]), int(rest[1]), rest[2])))
        return
    from roneld_eval.benchmarks.culane.synth import synth_lane_files

    with tempfile.TemporaryDirectory() as folder:
        work = Path(folder)
        gt, pred = synth_lane_files(work / "set", args.frames)
        print(f"{args.frames:,} generated frames; load average {os.getloadavg()[0]:.1f} on {os.cpu_count()} cores")
        for iou in GRIDS:
            files = score_seconds(gt, pred, iou, work / f"score-{len(iou)}", work / "truth")
            with open(work / f"score-{len(iou)}" / "official.csv", newline="") as table:
                official = next(r for r in csv.DictReader(table) if r["category"] == "all"
                                and r["threshold"] == "0.50")
            run = in_child("metric", str(gt), str(pred), iou, str(args.epochs))
            epochs = run["epochs"]
            same = float(official["f1"]) == run["f1_50"]
            print(f"\n--iou {iou}:")
            print(f"  score culane --workers 1, warm truth cache (fresh process, files): {files:.1f} s")
            print("  in memory, frame by frame (fresh process): " + ", ".join(f"{s:.1f}" for s in epochs)
                  + " s per epoch")
            print(f"  first epoch / score culane: {epochs[0] / files:.2f} (target <= 1); second / first: "
                  f"{epochs[1] / epochs[0]:.2f} (target <= 0.60)" if len(epochs) > 1 else "")
            print("  RSS after each epoch: " + ", ".join(f"{mb:.0f}" for mb in run["rss"]) + f" MB (before: "
                  f"{run['rss_before']:.0f} MB; growth from the first to the last: "
                  f"{run['rss'][-1] - run['rss'][0]:+.1f} MB, target < 20; peak {run['peak_mb']:.0f} MB)")
            print(f"  F1@50 {run['f1_50']:.6f}: {'the same as' if same else 'DIFFERENT FROM'} score culane's")
            if args.clrnet:
                theirs = in_child("clrnet", str(gt), str(pred), str(args.clrnet), str(args.clrnet_frames), iou)
                ours = epochs[-1] / args.frames
                per_frame = theirs["seconds"] / theirs["frames"]
                print(f"  CLRNet's culane_metric, lanes in memory: {per_frame * 1e3:.2f} ms a frame over "
                      f"{theirs['frames']} frames ({theirs['refused']} it refused: repeated points); the "
                      f"metric's last epoch {ours * 1e3:.3f} ms a frame: {per_frame / ours:.0f}x")


if __name__ == "__main__":
    main()
