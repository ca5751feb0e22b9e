"""Benchmark what a plug-in extractor costs beyond its own work: a no-op plug-in beside the
baseline and RONELD, against the same run without it (target: under 5% more wall time).

Generates a CULane-shaped synthetic set (npy maps) of --frames frames, then runs
`roneld-eval run` alternately without and with `--method noop=tests/plugin_extractors.py:no_op`
(--repeats times each), and prints the median wall times and their ratio. The no-op plug-in
returns an empty Prediction, so the difference is the runner's per-method cost: calling it,
checking its output, scoring it (empty) and writing its rows.

    python scripts/bench_plugins.py [--frames 2000] [--repeats 3] [--workers N]
"""

from __future__ import annotations

import argparse
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

from roneld_eval.benchmarks.culane.synth import synth_culane  # noqa: E402
from roneld_eval.workers import default_workers  # noqa: E402

NO_OP = f"{REPO / 'tests' / 'plugin_extractors.py'}:no_op"


def timed_run(data: Path, maps: Path, workers: int, out: Path, plugin: bool) -> float:
    command = [sys.executable, "-m", "roneld_eval", "run", "--dataset", "culane", "--data-root", str(data),
               "--maps-root", str(maps), "--maps-format", "npy", "--methods", "baseline,roneld",
               "--workers", str(workers), "--out", str(out), "--quiet"]
    if plugin:
        command += ["--method", f"noop={NO_OP}"]
    start = time.perf_counter()
    subprocess.run(command, check=True)
    return time.perf_counter() - start


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--frames", type=int, default=2000)
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--workers", type=int, default=default_workers())
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as folder:
        root = Path(folder)
        clips = max(1, args.frames // 100)
        made = synth_culane(root / "set", clips=clips, frames=args.frames // clips, seed=1)
        timed_run(made.data_root, made.maps_root, args.workers, root / "warm", True)  # compile, warm caches
        without, with_plugin = [], []
        for _ in range(args.repeats):
            without.append(timed_run(made.data_root, made.maps_root, args.workers, root / "a", False))
            with_plugin.append(timed_run(made.data_root, made.maps_root, args.workers, root / "b", True))
    base, plugged = statistics.median(without), statistics.median(with_plugin)
    print(f"{made.n_frames} frames, {args.workers} workers, {args.repeats} runs each (median wall time)")
    print(f"baseline + RONELD:             {base:6.2f} s  ({made.n_frames / base:6.0f} frames/s)")
    print(f"baseline + RONELD + no-op:     {plugged:6.2f} s  ({made.n_frames / plugged:6.0f} frames/s)")
    print(f"overhead of a no-op plug-in:   {100 * (plugged / base - 1):+.1f}% "
          f"(ratio {plugged / base:.3f}; target < 5%)")


if __name__ == "__main__":
    main()
