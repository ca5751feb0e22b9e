"""Benchmark the official CULane protocol: frames per second on one core, and the sweep.

Generates a CULane-like set of ground-truth and predicted lane files with the awkward cases
(synth.synth_lane_files), scores it with one worker at IoU 0.5 and with the 21-step sweep
0.30..0.50 (one pass either way). With --official PATH (a build of SCNN's
tools/lane_evaluation `evaluate`, not part of this project), it also times that tool on one
thread on the same files, checks the TP/FP/FN are equal, and prints the speed ratio.

    python scripts/bench_metrics.py [--frames 2000] [--official /path/to/evaluate]
"""

from __future__ import annotations

import argparse
import os
import re
import subprocess
import sys
import tempfile
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

from roneld_eval.api import score_culane  # noqa: E402
from roneld_eval.benchmarks.culane.synth import synth_lane_files  # noqa: E402


def run_official(tool: Path, gt: Path, pred: Path, threshold: str) -> tuple[float, tuple[int, int, int]]:
    out = Path(tempfile.mkdtemp()) / "out.txt"
    start = time.perf_counter()
    subprocess.run([str(tool), "-a", f"{gt}/", "-d", f"{pred}/", "-i", f"{gt}/", "-l", str(gt / "list" / "test.txt"),
                    "-w", "30", "-t", threshold, "-c", "1640", "-r", "590", "-o", str(out)],
                   check=True, capture_output=True, env={**os.environ, "OMP_NUM_THREADS": "1"})
    elapsed = time.perf_counter() - start
    tp, fp, fn = map(int, re.search(r"tp: (\d+) fp: (\d+) fn: (\d+)", out.read_text()).groups())
    return elapsed, (tp, fp, fn)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--frames", type=int, default=2000)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--official", type=Path, help="a built SCNN lane_evaluation 'evaluate' to compare with")
    args = parser.parse_args()
    folder = Path(tempfile.mkdtemp(prefix="roneld-bench-metrics-"))
    gt, pred = synth_lane_files(folder, args.frames, args.seed)
    lanes = sum(len(p.read_text().splitlines()) for p in gt.rglob("*.lines.txt"))
    lanes += sum(len(p.read_text().splitlines()) for p in pred.rglob("*.lines.txt"))
    print(f"{args.frames} frames, {lanes} lanes (ground truth + predictions) in {folder}")
    score_culane(gt, pred, iou="0.5", workers=1)  # warm-up: numba kernels, file cache

    timings = {}
    for label, iou in (("IoU 0.5", "0.5"), ("sweep 0.30:0.50:0.01", "0.30:0.50:0.01")):
        runs = []
        for _ in range(3):
            start = time.perf_counter()
            score = score_culane(gt, pred, iou=iou, workers=1)
            runs.append(time.perf_counter() - start)
        timings[label] = sorted(runs)[1]
        row = score.table[score.table["category"] == "all"].iloc[0]
        print(f"roneld-eval, 1 core, {label:22s}: {timings[label]:6.2f} s median of 3 = "
              f"{args.frames / timings[label]:7.1f} frames/s  "
              f"(tp {row.tp} fp {row.fp} fn {row.fn} at the first threshold)")

    if args.official is None:
        print("\nThe official C++ tool was not given (--official). Measured on this kind of machine for "
              "2,000 such frames: 44 s on one core per threshold, so a 21-step sweep takes 21 runs (~9.5 min).")
        return
    elapsed, counts = run_official(args.official, gt, pred, "0.5")
    ours = score_culane(gt, pred, iou="0.5", workers=1).table
    ours = ours[ours["category"] == "all"].iloc[0]
    same = counts == (ours.tp, ours.fp, ours.fn)
    print(f"\nofficial C++ evaluator, 1 thread, IoU 0.5: {elapsed:6.2f} s = {args.frames / elapsed:7.1f} frames/s "
          f"(tp {counts[0]} fp {counts[1]} fn {counts[2]}; {'identical' if same else 'DIFFERENT'} counts)")
    print(f"speed ratio at one threshold: {elapsed / timings['IoU 0.5']:.1f}x; for the 21-step sweep "
          f"(21 runs of the C++ tool): {21 * elapsed / timings['sweep 0.30:0.50:0.01']:.0f}x")


if __name__ == "__main__":
    main()
