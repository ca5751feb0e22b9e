"""Benchmark the first run on a fresh install (numba compiling its kernels) against a warm run.

Runs `roneld-eval run` on the bundled fixture (40 frames, 4 clips) through the command line,
in a fresh Python process each time: cold, with NUMBA_CACHE_DIR pointing at a new empty
folder (as after `pip install`), then warm, with the cache that cold run filled. Prints the
wall times per worker count (the median of the warm runs), their ratio, and the line the run
printed to say it was compiling, if any. The code measured is this checkout's (PYTHONPATH).
"default" runs without --workers: all cores, fewer for a small run (evaluation.pool.pool_size).

    python scripts/bench_cold.py [--workers default,2,1] [--cold-runs 1] [--warm-runs 3]
    python scripts/bench_cold.py --steps    # each compile step's seconds, from nothing, on one core

--steps gives the seconds roneld_eval.kernels.STEPS carries, by which a first run orders its
compile over processes: each step compiled from nothing in one fresh process, in that order (a
step's callees then come from the cache, as in a first run).
"""

from __future__ import annotations

import argparse
import os
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]


def environment(cache_dir: Path) -> dict[str, str]:
    env = dict(os.environ)
    env["NUMBA_CACHE_DIR"] = str(cache_dir)
    env["PYTHONPATH"] = os.pathsep.join([str(REPO)] + [p for p in [env.get("PYTHONPATH")] if p])
    return env


def timed_run(cache_dir: Path, workers: str, scratch: Path) -> tuple[float, str]:
    """Wall seconds of one fixture run, and the output line that mentions compiling (or "")."""
    out = Path(tempfile.mkdtemp(dir=scratch))
    command = [sys.executable, "-m", "roneld_eval", "run", "--out", str(out)]
    if workers != "default":
        command += ["--workers", workers]
    start = time.perf_counter()
    done = subprocess.run(command, env=environment(cache_dir), cwd=scratch, capture_output=True, text=True)
    elapsed = time.perf_counter() - start
    if done.returncode != 0:
        sys.exit(f"run failed ({done.returncode}):\n{done.stdout}\n{done.stderr}")
    said = [line.strip() for line in (done.stdout + "\n" + done.stderr).replace("\r", "\n").splitlines()
            if "compiling" in line.lower()]
    return elapsed, said[0] if said else ""


_STEP_SECONDS = """
import sys, time
from roneld_eval import kernels
for step in kernels.in_order(kernels._steps(kernels.GROUPS)):
    start = time.perf_counter()
    kernels._compile_step(step)
    print(f"{step.name}\t{time.perf_counter() - start:.1f}\t{step.seconds:g}", flush=True)
"""


def step_seconds(scratch: Path) -> None:
    """Each compile step's seconds from nothing, one process, beside the seconds STEPS carries."""
    cache_dir = scratch / "numba-steps"
    cache_dir.mkdir()
    done = subprocess.run([sys.executable, "-c", _STEP_SECONDS], env=environment(cache_dir), cwd=scratch,
                          capture_output=True, text=True)
    if done.returncode != 0:
        sys.exit(f"compiling failed ({done.returncode}):\n{done.stderr}")
    print(f"{'step':<14}  {'measured s':>10}  {'STEPS says':>10}")
    for line in done.stdout.splitlines():
        name, measured, said = line.split("\t")
        print(f"{name:<14}  {measured:>10}  {said:>10}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--workers", default="default,2,1",
                        help="comma-separated worker counts, 'default' for none given (default: default,2,1)")
    parser.add_argument("--cold-runs", type=int, default=1, help="cold runs per worker count (slow)")
    parser.add_argument("--warm-runs", type=int, default=3, help="warm runs per worker count")
    parser.add_argument("--steps", action="store_true", help="only each compile step's seconds, on one core")
    args = parser.parse_args()
    counts = args.workers.split(",")
    if len(set(counts)) < len(counts) or not all(count == "default" or count.isdigit() for count in counts):
        parser.error(f"--workers {args.workers}: give distinct worker counts or 'default', comma-separated")
    print(f"code: {REPO}; {os.cpu_count()} cores; fixture run through `python -m roneld_eval run`")
    scratch = Path(tempfile.mkdtemp(prefix="roneld-bench-cold-"))
    if args.steps:
        try:
            step_seconds(scratch)
        finally:
            shutil.rmtree(scratch, ignore_errors=True)
        return
    rows = []
    try:
        for workers in counts:
            cold, said = [], ""
            cache_dir = scratch / f"numba-{workers}-0"
            for attempt in range(args.cold_runs):
                cache_dir = scratch / f"numba-{workers}-{attempt}"
                cache_dir.mkdir()
                seconds, line = timed_run(cache_dir, workers, scratch)
                cold.append(seconds)
                said = said or line
                print(f"  workers {workers}: cold run {seconds:.1f} s" + (f"  (said: {line})" if line else ""),
                      flush=True)
            warm = []
            for _ in range(args.warm_runs):
                seconds, line = timed_run(cache_dir, workers, scratch)
                warm.append(seconds)
                print(f"  workers {workers}: warm run {seconds:.2f} s" + (f"  (said: {line})" if line else ""),
                      flush=True)
            rows.append((workers, cold, statistics.median(warm) if warm else float("nan"), said))
    finally:
        shutil.rmtree(scratch, ignore_errors=True)
    print()
    print(f"{'workers':>7}  {'cold s':>14}  {'warm s (median)':>15}  {'cold/warm':>9}  announced")
    for workers, cold, warm, said in rows:
        cold_text = ", ".join(f"{c:.1f}" for c in cold)
        print(f"{workers:>7}  {cold_text:>14}  {warm:>15.2f}  {max(cold) / warm:>9.1f}  {said or '-'}")


if __name__ == "__main__":
    main()
