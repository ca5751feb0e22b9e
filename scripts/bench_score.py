"""Benchmark `score culane` at the official test list's size with the CLRNet grid (mF1).

Generates, in a temporary folder, a CULane-shaped set: 34,680 frames in 419 videos with the
nine category lists at their real sizes, about 4 ground-truth lanes a frame (points every
10 rows from the bottom, as CULane's labels) and noisy predictions with missed and extra
lanes. Then times `roneld-eval score culane --iou 0.50:0.95:0.05` end to end (a fresh
process: start-up, reading every file, drawing, matching, tables, writing) and prints the
frames per second and the ratio to the SCNN C++ evaluator run once per threshold.

    python scripts/bench_score.py [--frames 34680] [--workers 2] [--repeats 3] [--methods 1]

The C++ evaluator is not part of this project and is not run here: its time is estimated
from the project's own measurement (scripts/bench_metrics.py, README "Speed": 44 s on one
core for 2,000 frames of synth_lane_files) scaled by the number of lane pairs it draws
(it draws both lanes of every ground-truth/prediction pair), printed with the figures used.
"""

from __future__ import annotations

import argparse
import csv
import os
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

from roneld_eval.benchmarks.culane.synth import synth_lane_files  # noqa: E402

WIDTH, HEIGHT = 1640, 590
VIDEOS = 419
# list/test_split sizes of the official test list (shared/data/README.md); they sum to 34,680.
CATEGORIES = {"normal": 9621, "crowd": 8113, "hlight": 486, "shadow": 930, "noline": 4067, "arrow": 890,
              "curve": 422, "cross": 3122, "night": 7029}
# The project's measurement of the C++ evaluator (README "Speed", scripts/bench_metrics.py):
# 2,000 frames of synth_lane_files(seed 0) in 44 s on one core, per threshold.
CPP_SECONDS, CPP_FRAMES, CPP_SEED = 44.0, 2000, 0


def lane_text(points: np.ndarray) -> str:
    return " ".join(f"{v:.3f}" if k % 2 == 0 else f"{int(v)}" for k, v in enumerate(points.ravel())) + " \n"


def generate(root: Path, frames: int, methods: int, seed: int = 0) -> tuple[Path, list[Path], int, int]:
    """Write gt/ (a CULane root) and pred/method<k>/ trees; returns (gt, prediction roots,
    ground-truth lanes, lane pairs)."""
    rng = np.random.default_rng([seed, 34680])
    gt_root = root / "gt"
    pred_roots = [root / "pred" / f"method{k}" for k in range(methods)]
    per_video = -(-frames // VIDEOS)
    listing = [f"driver_{100 + v // 40}_30frame/{v:08d}.MP4/{f * 30:05d}.jpg"
               for v in range(VIDEOS) for f in range(per_video)][:frames]
    sizes = {name: round(size * frames / 34680) for name, size in CATEGORIES.items()}
    sizes["normal"] += frames - sum(sizes.values())
    category_of = []
    for name, size in sizes.items():
        category_of += [name] * size
    pairs = n_lanes = 0
    for index, relpath in enumerate(listing):
        stem = relpath[:-4]
        n_gt = 0 if category_of[index] == "cross" else int(rng.choice([3, 4, 4, 4, 4, 4, 5]))
        lanes = []
        for x_bottom in np.sort(rng.uniform(-400, WIDTH + 400, n_gt)):
            top = int(rng.integers(26, 34)) * 10
            ys = np.arange(HEIGHT, top - 1, -10, dtype=float)
            t = (HEIGHT - ys) / (HEIGHT - 250)
            xs = x_bottom + (WIDTH / 2 - x_bottom) * t + rng.normal(0, 40) * t**2
            lanes.append(np.stack([xs, ys], 1))
        n_lanes += len(lanes)
        (gt_root / stem).parent.mkdir(parents=True, exist_ok=True)
        (gt_root / f"{stem}.lines.txt").write_text("".join(lane_text(p) for p in lanes))
        for pred_root in pred_roots:
            predicted = []
            for points in lanes:
                if rng.random() < 0.1:
                    continue
                shifted = points[::2].copy()
                shifted[:, 0] += rng.normal(0, rng.choice([3, 10, 25])) + rng.normal(0, 2, len(shifted)).cumsum()
                predicted.append(shifted)
            if rng.random() < 0.15:
                predicted.append(lanes[0][::3] + [rng.uniform(-200, 200), 0] if lanes else
                                 np.array([[800.0, 590], [820, 400], [830, 300]]))
            pairs += len(lanes) * len(predicted)
            (pred_root / stem).parent.mkdir(parents=True, exist_ok=True)
            (pred_root / f"{stem}.lines.txt").write_text("".join(lane_text(p) for p in predicted))
    (gt_root / "list" / "test_split").mkdir(parents=True, exist_ok=True)
    (gt_root / "list" / "test.txt").write_text("".join(f"/{r}\n" for r in listing))
    for number, name in enumerate(CATEGORIES):
        members = [r for r, c in zip(listing, category_of) if c == name]
        (gt_root / "list" / "test_split" / f"test{number}_{name}.txt").write_text("".join(f"{m}\n" for m in members))
    return gt_root, pred_roots, n_lanes, pairs


def reference_pairs() -> int:
    """Lane pairs (ground truth x prediction) in the set the C++ evaluator was timed on."""
    from roneld_eval.lanes_io import read_lines_txt

    with tempfile.TemporaryDirectory(prefix="roneld-bench-ref-") as folder:
        gt, pred = synth_lane_files(folder, CPP_FRAMES, CPP_SEED)
        pairs = 0
        for path in gt.rglob("*.lines.txt"):
            other = pred / path.relative_to(gt)
            pairs += len(read_lines_txt(path)) * len(read_lines_txt(other))
        return pairs


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--frames", type=int, default=34680)
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--methods", type=int, default=1, help="prediction trees scored in the one pass")
    parser.add_argument("--iou", default="0.50:0.95:0.05")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory(prefix="roneld-bench-score-") as folder:
        start = time.perf_counter()
        gt, preds, n_lanes, pairs = generate(Path(folder), args.frames, args.methods)
        print(f"generated {args.frames:,} frames ({n_lanes / args.frames:.2f} ground-truth lanes a frame; 4 in "
              f"most, none in 'cross'; the real test set has 3.02), {args.methods} prediction tree(s), "
              f"{pairs:,} lane pairs, in {time.perf_counter() - start:.0f} s")
        pred_root = preds[0] if args.methods == 1 else preds[0].parent
        command = [sys.executable, "-m", "roneld_eval", "score", "culane", "--data-root", str(gt), "--pred-root",
                   str(pred_root), "--iou", args.iou, "--workers", str(args.workers), "--quiet"]
        walls, cpus = [], []
        for repeat in range(args.repeats + 1):
            out = Path(folder) / f"out{repeat}"
            before = resource.getrusage(resource.RUSAGE_CHILDREN)
            start = time.perf_counter()
            subprocess.run(command + ["--out", str(out)], check=True)
            walls.append(time.perf_counter() - start)
            after = resource.getrusage(resource.RUSAGE_CHILDREN)
            cpus.append(after.ru_utime + after.ru_stime - before.ru_utime - before.ru_stime)
            print(f"  run {repeat}{' (warm-up: numba cache, file cache)' if repeat == 0 else ''}: {walls[-1]:.1f} s "
                  f"wall, {cpus[-1]:.1f} s CPU (all processes), load average {os.getloadavg()[0]:.1f}")
        wall = statistics.median(walls[1:]) if args.repeats else walls[0]
        cpu = statistics.median(cpus[1:]) if args.repeats else cpus[0]
        with open(out / "official.csv", newline="") as table:
            n_thresholds = len({row["threshold"] for row in csv.DictReader(table)})
        print(f"\nscore culane --iou {args.iou} ({n_thresholds} thresholds), {args.workers} workers, "
              f"{args.methods} method(s): {wall:.1f} s median of {args.repeats} = "
              f"{args.frames * args.methods / wall:,.0f} frames/s")
        print(f"  CPU time (all its processes) {cpu:.1f} s median, i.e. {cpu / args.workers:.1f} s spread over "
              f"{args.workers} cores: on a shared machine, wall time well above that is other processes' load")

    ref_pairs = reference_pairs()
    per_pair = CPP_SECONDS / ref_pairs
    cpp_one = per_pair * pairs
    cpp_per_frame = CPP_SECONDS / CPP_FRAMES * args.frames * args.methods
    print(f"\nC++ evaluator, estimated (not run): {CPP_SECONDS:.0f} s for {CPP_FRAMES:,} frames of synth_lane_files "
          f"= {ref_pairs:,} lane pairs on one core (README 'Speed'), i.e. {per_pair * 1e3:.2f} ms per pair;")
    print(f"  this set: {pairs:,} pairs -> {cpp_one:,.0f} s per threshold on one core "
          f"({cpp_per_frame:,.0f} s if scaled by frames instead); {n_thresholds} thresholds = "
          f"{n_thresholds} runs = {n_thresholds * cpp_one:,.0f} s")
    print(f"ratio (C++ one run per threshold, one core) / (roneld-eval, {args.workers} workers): "
          f"{n_thresholds * cpp_one / wall:,.0f}x; per core: {n_thresholds * cpp_one / (wall * args.workers):,.0f}x "
          f"(scaled by frames instead of pairs: {n_thresholds * cpp_per_frame / wall:,.0f}x and "
          f"{n_thresholds * cpp_per_frame / (wall * args.workers):,.0f}x)")
    print("  pairs are the better model: the C++ tool zeroes, draws and compares two full 1640x590 images for "
          "every ground-truth/prediction pair (lane_compare.cpp get_lane_similarity)")


if __name__ == "__main__":
    main()
