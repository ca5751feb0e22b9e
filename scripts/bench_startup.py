"""Benchmark start-up: how long the quick commands take, end to end, in a fresh process each time.

Times (median of --runs, after one untimed round) `roneld-eval --help`, `roneld-eval --version`,
`roneld-eval score culane` on a one-frame set (with and without --out) and `import roneld_eval`,
each beside its target (under 1 s, issue 15), as wall time and as the CPU time (user + system)
of the process, all its threads (numpy's BLAS threads too, so it can exceed the wall time).
Then what the third-party imports in the score path cost, measured inside one process: numpy,
numba, numba's first load from its cache (it imports all its registries, and scipy.linalg
through them), the scoring kernels' first call, and pandas, which `score culane` no longer
imports (said so below). Modules run from .pyc files kept in a scratch folder, as an
installation has them (--no-bytecode: compiled from source every run).

The commands run as `python -m roneld_eval` with this checkout first on PYTHONPATH; --code
DIR adds another checkout (e.g. an old commit: `git archive HEAD | tar -x -C /tmp/old`) to
compare. Runs are interleaved, code after code, and the first round is untimed: it fills
numba's cache where a kernel changed (a compile is not start-up). The machine's load average
is printed before and after: on a shared machine, run it when idle.

    python scripts/bench_startup.py [--runs 7] [--code /tmp/old] [--no-bytecode]
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
TARGET_S = 1.0  # issue 15: `score culane` on one frame and `--help` each start in under 1 s

# Inside one process: what each import of the score path costs, in the order score culane meets them.
IMPORT_COSTS = r"""
import json, time
laps = {}
start = time.perf_counter()
def lap(name):
    global start
    now = time.perf_counter()
    laps[name] = now - start
    start = now
import numpy as np; lap("numpy")
import numba; lap("numba")
from numba.core.registry import cpu_target
cpu_target.target_context.refresh(); lap("numba's registries (its first cache load; imports scipy.linalg)")
from roneld_eval.metrics import lane_iou_f1; lap("roneld_eval.metrics (creating the numba dispatchers)")
from roneld_eval.model import Lane
lanes = [Lane(np.array([[x, 590.0], [x + 200, 400.0], [x + 300, 300.0]])) for x in (300.0, 900.0)]
lane_iou_f1.match_frame(lanes, lanes); lap("the scoring kernels' first call (loaded from the cache)")
import pandas; lap("pandas (not imported by score culane)")
print(json.dumps(laps))
"""

# `score culane` run in-process: which heavy modules did it import?
SCORE_IMPORTS = r"""
import json, sys
from roneld_eval.cli import main
try:
    main(sys.argv[1:])
except SystemExit:
    pass
print(json.dumps(sorted(m for m in ("pandas", "matplotlib", "scipy", "cv2", "PIL") if m in sys.modules)))
"""


def environment(code: Path, bytecode: Path | None) -> dict[str, str]:
    """`code` first on the path; with `bytecode`, compiled modules kept there (as an installed
    package has its .pyc files) instead of compiling every module from source in every run."""
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join([str(code)] + [p for p in [env.get("PYTHONPATH")] if p])
    if bytecode is not None:
        env.pop("PYTHONDONTWRITEBYTECODE", None)
        env["PYTHONPYCACHEPREFIX"] = str(bytecode)  # outside the checkout: the tree stays as it is
    return env


def timed(command: list[str], env: dict[str, str], cwd: Path) -> tuple[float, float]:
    """Wall seconds and CPU seconds (user + system) of one run of `command`."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    start = time.perf_counter()
    done = subprocess.run(command, env=env, cwd=cwd, capture_output=True, text=True)
    wall = time.perf_counter() - start
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    if done.returncode != 0:
        sys.exit(f"{' '.join(command)} failed ({done.returncode}):\n{done.stdout}\n{done.stderr}")
    return wall, (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)


def median_pair(samples: list[tuple[float, float]]) -> tuple[float, float]:
    return statistics.median(s[0] for s in samples), statistics.median(s[1] for s in samples)


def one_frame_set(folder: Path) -> tuple[Path, Path]:
    """A CULane root with one listed frame (4 ground-truth lanes) and a prediction tree for it."""
    from roneld_eval.benchmarks.culane.synth import synth_lane_files

    return synth_lane_files(folder, frames=1, seed=0)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=7, help="timed runs per command (default 7)")
    parser.add_argument("--code", type=Path, action="append", default=[],
                        help="another checkout to time the same way (repeatable)")
    parser.add_argument("--no-bytecode", action="store_true",
                        help="compile every module from source in every run, as with PYTHONDONTWRITEBYTECODE=1 "
                             "(default: .pyc files kept in a scratch folder, as an installation has them)")
    args = parser.parse_args()
    sys.path.insert(0, str(REPO))
    load = os.getloadavg()
    print(f"{os.cpu_count()} cores; load average {load[0]:.2f} {load[1]:.2f} {load[2]:.2f} (1, 5, 15 min); "
          f"Python {sys.version.split()[0]}; median of {args.runs} runs after one untimed round")
    scratch = Path(tempfile.mkdtemp(prefix="roneld-bench-startup-"))
    try:
        bench(scratch, [REPO] + [path.resolve() for path in args.code], args.runs,
              None if args.no_bytecode else scratch / "pycache")
    finally:
        shutil.rmtree(scratch, ignore_errors=True)
    load = os.getloadavg()
    print(f"load average after: {load[0]:.2f} {load[1]:.2f} {load[2]:.2f}")


def bench(scratch: Path, codes: list[Path], runs: int, bytecode: Path | None) -> None:
    print("modules compiled from source in every run (--no-bytecode)" if bytecode is None else
          "compiled modules (.pyc) kept in a scratch folder, written by the untimed round")
    gt, pred = one_frame_set(scratch / "set")
    python = [sys.executable, "-m", "roneld_eval"]
    score = python + ["score", "culane", "--data-root", str(gt), "--pred-root", str(pred)]
    commands = [
        ("roneld-eval --help", python + ["--help"]),
        ("roneld-eval --version", python + ["--version"]),
        ("roneld-eval score culane (1 frame)", score),
        ("  the same with --out", score + ["--out", str(scratch / "out")]),
        ("import roneld_eval", [sys.executable, "-c", "import roneld_eval"]),
    ]
    samples: dict[tuple[Path, str], list[tuple[float, float]]] = {}
    # Interleaved (each run of each command, code after code), so that a change of load on a shared
    # machine falls on every figure alike; the first round is untimed (file cache, numba's cache).
    for round_ in range(runs + 1):
        for code in codes:
            for name, command in commands:
                sample = timed(command, environment(code, bytecode), scratch)
                if round_:
                    samples.setdefault((code, name), []).append(sample)
    for code in codes:
        env = environment(code, bytecode)
        print(f"\ncode: {code}")
        print(f"  {'command':<38} {'wall s':>7} {'CPU s':>7}  target")
        for name, _ in commands:
            wall, cpu = median_pair(samples[code, name])
            verdict = "ok" if wall < TARGET_S else "OVER"
            print(f"  {name:<38} {wall:>7.3f} {cpu:>7.3f}  < {TARGET_S:g} s  {verdict}")
        loaded = subprocess.run([sys.executable, "-c", SCORE_IMPORTS] + score[3:] + ["--quiet"], env=env, cwd=scratch,
                                capture_output=True, text=True, check=True).stdout.splitlines()[-1]
        print(f"  score culane imports: {', '.join(json.loads(loaded)) or 'none'} of pandas, matplotlib, scipy, cv2, "
              "PIL (scipy comes with numba's registries)")
    env = environment(codes[0], bytecode)
    laps: dict[str, list[float]] = {}
    for _ in range(runs):
        done = subprocess.run([sys.executable, "-c", IMPORT_COSTS], env=env, cwd=scratch, capture_output=True,
                              text=True, check=True)
        for name, seconds in json.loads(done.stdout.splitlines()[-1]).items():
            laps.setdefault(name, []).append(seconds)
    bare = median_pair([timed([sys.executable, "-c", "pass"], env, scratch) for _ in range(runs)])[0]
    print(f"\nwhat the score path's imports cost (inside one process, median; code: {codes[0]}):")
    print(f"  {'the interpreter starting and stopping (python -c pass)':<64} {bare:>6.3f} s")
    for name, seconds in laps.items():
        print(f"  {name:<64} {statistics.median(seconds):>6.3f} s")


if __name__ == "__main__":
    main()
