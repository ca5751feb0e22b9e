"""What `score culane --diagnose` adds to `score culane`'s time, side by side in one run.

Generates the official test list's layout (scripts/bench_score.generate: 34,680 frames in 419
videos, the nine category lists at their real sizes, noisy predictions with missed and extra
lanes), warms the ground-truth cache once, then times fresh `roneld-eval score culane`
processes without and with `--diagnose` (and, with --sweep, `--diagnose --score-sweep`),
interleaved so that a change in the machine's load falls on both alike, and prints the medians
and their ratio. The target (issue: "why a method loses F1") is at most 1.25x.

    python scripts/bench_diagnose.py [--frames 34680] [--workers 1] [--repeats 5] [--iou 0.5] [--sweep]
"""

from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO / "scripts"))

from bench_score import generate  # noqa: E402


def timed(command: list[str], out: Path, env: dict[str, str]) -> float:
    start = time.perf_counter()
    subprocess.run(command + ["--out", str(out)], check=True, env=env)
    return time.perf_counter() - start


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--frames", type=int, default=34680)
    parser.add_argument("--workers", type=int, default=1)
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument("--iou", default="0.5")
    parser.add_argument("--sweep", action="store_true", help="also time --diagnose --score-sweep (lanes scored 1.0 "
                                                             "without .scores.txt files: every threshold rematched)")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory(prefix="roneld-bench-diagnose-") as folder:
        root = Path(folder)
        gt, preds, n_lanes, pairs = generate(root, args.frames, 1)
        env = {**os.environ, "RONELD_EVAL_TRUTH_CACHE": str(root / "cache")}  # its own, warmed below
        command = [sys.executable, "-m", "roneld_eval", "score", "culane", "--data-root", str(gt), "--pred-root",
                   str(preds[0]), "--iou", args.iou, "--workers", str(args.workers), "--quiet"]
        cases = {"score culane": [], "--diagnose": ["--diagnose"]}
        if args.sweep:
            cases["--diagnose --score-sweep"] = ["--diagnose", "--score-sweep"]
        print(f"{args.frames:,} frames, {n_lanes / args.frames:.2f} ground-truth lanes a frame, {pairs:,} lane pairs; "
              f"IoU {args.iou}, {args.workers} worker(s)")
        for name, extra in cases.items():  # warm-up: numba's cache, the truth cache, the file cache
            print(f"  warm-up {name}: {timed(command + extra, root / 'warm', env):.1f} s")
        times: dict[str, list[float]] = {name: [] for name in cases}
        for repeat in range(args.repeats):
            for name, extra in cases.items():
                times[name].append(timed(command + extra, root / f"out-{repeat}-{len(extra)}", env))
            print(f"  round {repeat + 1}: " + ", ".join(f"{name} {values[-1]:.2f} s" for name, values in times.items())
                  + f" (load {os.getloadavg()[0]:.1f})")
        base = statistics.median(times["score culane"])
        print(f"\nmedians of {args.repeats}, interleaved:")
        for name, values in times.items():
            print(f"  {name:28s} {statistics.median(values):6.2f} s  {statistics.median(values) / base:.3f}x")
        same = all((root / "out-0-0" / name).read_bytes() == (root / "out-0-1" / name).read_bytes()
                   for name in ("official.csv", "summary.csv", "summary.md"))
        print(f"official.csv, summary.csv, summary.md byte-identical with and without --diagnose: {same}")


if __name__ == "__main__":
    main()
