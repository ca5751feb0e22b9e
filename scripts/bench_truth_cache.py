"""Benchmark the ground-truth cache of `score culane`: one prediction root scored in a fresh
process without the cache, with an empty cache (drawn, then written) and with the entry there
(nothing drawn), on generated lane files (`culane_synth.synth_lane_files`), one worker; the
tables must be the same bytes each way.

    python scripts/bench_truth_cache.py [--frames 34680]
"""

from __future__ import annotations

import argparse
import os
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]


def measured(command: list[str], cache: str) -> tuple[float, float]:
    """(wall s, CPU s) of one command in a fresh process with RONELD_EVAL_TRUTH_CACHE=cache."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    start = time.perf_counter()
    subprocess.run(command, check=True, cwd=REPO, stdout=subprocess.DEVNULL,
                   env={**os.environ, "RONELD_EVAL_TRUTH_CACHE": cache})
    wall = time.perf_counter() - start
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    return wall, (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--frames", type=int, default=34680)
    args = parser.parse_args()
    from roneld_eval.benchmarks.culane.synth import synth_lane_files

    with tempfile.TemporaryDirectory() as folder:
        work = Path(folder)
        gt, pred = synth_lane_files(work / "set", args.frames)
        cache = work / "truth"

        def command(out: str) -> list[str]:
            return [sys.executable, "-m", "roneld_eval", "score", "culane", "--data-root", str(gt), "--pred-root",
                    str(pred), "--iou", "0.50:0.95:0.05", "--workers", "1", "--quiet", "--out", str(work / out)]

        measured(command("warm"), "0")  # kernels compiled or loaded once, files in the page cache
        off = measured(command("off"), "0")
        cold = measured(command("cold"), str(cache))
        hit = measured(command("hit"), str(cache))
        size = sum(p.stat().st_size for p in cache.rglob("*") if p.is_file()) / 2**20
        same = all((work / "off" / name).read_bytes() == (work / run / name).read_bytes()
                   for run in ("cold", "hit") for name in ("official.csv", "summary.csv", "summary.md"))
        print(f"{args.frames:,} frames, one root: without the cache {off[0]:.1f} s wall ({off[1]:.1f} s CPU); "
              f"first with it (drawn and written) {cold[0]:.1f} s ({cold[1]:.1f} s CPU); "
              f"later (taken from it) {hit[0]:.1f} s ({hit[1]:.1f} s CPU), {hit[1] / off[1]:.2f} of the CPU "
              f"without; entry {size:.0f} MB; tables {'identical' if same else 'DIFFER'}")


if __name__ == "__main__":
    main()
