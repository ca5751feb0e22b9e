"""Benchmark a checkpoint sweep with `score culane`: CPU per extra prediction root against the
first, peak memory against the number of roots, and the same work over 2 shards plus merge
against one process. Generated lane files (`culane_synth.synth_lane_files`: the official
scorer's awkward cases), every root the same predictions under another name (a symlink), so
each costs what a real checkpoint costs; each command in a fresh process, one worker, without
the ground-truth cache (what one pass shares between methods; bench_truth_cache.py measures the
cache).

    python scripts/bench_sweep.py [--frames 2000] [--roots 1,2,10,50]
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
UNCACHED = {**os.environ, "RONELD_EVAL_TRUTH_CACHE": "0"}


def measured(command: list[str]) -> tuple[float, float, float]:
    """(wall s, CPU s of the process, its peak resident MB) of one command in a fresh process."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    start = time.perf_counter()
    subprocess.run(command, check=True, cwd=REPO, stdout=subprocess.DEVNULL, env=UNCACHED)
    wall = time.perf_counter() - start
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    return wall, cpu, after.ru_maxrss / 1024  # ru_maxrss: the largest child so far, in KiB on Linux


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--frames", type=int, default=2000)
    parser.add_argument("--roots", default="1,2,10,50")
    args = parser.parse_args()
    counts = [int(v) for v in args.roots.split(",")]
    from roneld_eval.benchmarks.culane.synth import synth_lane_files

    with tempfile.TemporaryDirectory() as folder:
        work = Path(folder)
        gt, pred = synth_lane_files(work / "set", args.frames)
        roots = work / "ckpt"
        roots.mkdir()
        for k in range(max(counts)):
            (roots / f"epoch_{k + 1:03d}").symlink_to(pred)
        base = [sys.executable, "-m", "roneld_eval", "score", "culane", "--data-root", str(gt), "--iou",
                "0.50:0.95:0.05", "--workers", "1", "--quiet"]
        measured([*base, "--pred-root", str(roots / "epoch_001"), "--out", str(work / "warm")])  # compile once
        results = {}
        for n in counts:
            listing = work / f"roots{n}.txt"
            listing.write_text("".join(f"{roots / f'epoch_{k + 1:03d}'}\n" for k in range(n)))
            results[n] = measured([*base, "--pred-roots-from", str(listing), "--out", str(work / f"o{n}")])
            print(f"{n:3d} roots: {results[n][0]:6.1f} s wall, {results[n][1]:6.1f} s CPU, "
                  f"peak {results[n][2]:6.0f} MB")
        first = results[counts[0]][1]
        for n in counts[1:]:
            extra = (results[n][1] - first) / (n - counts[0])
            print(f"CPU per extra root (1 -> {n}): {extra:.2f} s, {extra / first:.2f} of the first root's "
                  f"{first:.2f} s")
        n = counts[-1]
        listing = work / f"roots{n}.txt"
        start = time.perf_counter()
        for k in (1, 2):
            subprocess.run([*base, "--pred-roots-from", str(listing), "--out", str(work / f"s{k}"), "--shard",
                            f"{k}/2"], check=True, cwd=REPO, stdout=subprocess.DEVNULL, env=UNCACHED)
        subprocess.run([sys.executable, "-m", "roneld_eval", "merge", str(work / "s1"), str(work / "s2"), "--out",
                        str(work / "merged")], check=True, cwd=REPO, stdout=subprocess.DEVNULL)
        sharded = time.perf_counter() - start
        same = all((work / "merged" / name).read_bytes() == (work / f"o{n}" / name).read_bytes()
                   for name in ("official.csv", "summary.csv", "summary.md", "sweep.csv", "sweep.png"))
        print(f"{n} roots over 2 shards run one after the other, plus merge: {sharded:.1f} s against "
              f"{results[n][0]:.1f} s in one process; merged files {'identical' if same else 'DIFFER'}")


if __name__ == "__main__":
    main()
