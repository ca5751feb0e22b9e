"""Benchmark `roneld-eval run`: frames per second with baseline and RONELD, 1 worker and all.

Generates a CULane-shaped set of at least --frames frames (4x288x800 uint8 .npy maps), with
the videos and frame numbering of the official CULane test list when
../shared/data/culane-lists/test.txt is present (whole videos, in list order), then runs the
full evaluation (paper protocol, official CULane scores, all outputs) with one worker and with
every core, and prints frames per second and peak memory. Memory should not grow with frames:
the run is repeated on half the set to show it.

    python scripts/bench_run.py [--frames 2000] [--data DIR]
"""

from __future__ import annotations

import argparse
import posixpath
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

from roneld_eval.evaluation import default_workers  # noqa: E402
from roneld_eval.synth import synth_culane  # noqa: E402

TEST_LIST = REPO.parent / "shared" / "data" / "culane-lists" / "test.txt"


def structure(frames: int):
    """(video, frame relpaths) of whole videos from the real test list until `frames` are reached."""
    if not TEST_LIST.is_file():
        return None
    videos: dict[str, list[str]] = {}
    for line in TEST_LIST.read_text().split():
        relpath = line.lstrip("/")
        videos.setdefault(posixpath.dirname(relpath), []).append(relpath)
    chosen, total = [], 0
    for video, relpaths in videos.items():
        chosen.append((video, relpaths))
        total += len(relpaths)
        if total >= frames:
            break
    return chosen


def timed_run(data: Path, maps: Path, workers: int, limit: int | None, out: Path) -> tuple[float, int]:
    command = [sys.executable, "-m", "roneld_eval", "run", "--dataset", "culane", "--data-root", str(data),
               "--maps-root", str(maps), "--maps-format", "npy", "--methods", "baseline,roneld",
               "--workers", str(workers), "--out", str(out), "--quiet"]
    if limit:
        command += ["--limit", str(limit)]
    start = time.perf_counter()
    subprocess.run(command, check=True)
    elapsed = time.perf_counter() - start
    peak = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss // 1024
    return elapsed, peak


def evaluation_seconds(out: Path) -> float:
    """The run's own wall time (summary.json): evaluation and report, without Python start-up."""
    import json

    return json.loads((out / "summary.json").read_text())["wall_time_s"]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--frames", type=int, default=2000)
    parser.add_argument("--data", type=Path, help="where to generate the set (default: a temporary folder)")
    args = parser.parse_args()
    folder = args.data or Path(tempfile.mkdtemp(prefix="roneld-bench-run-"))
    layout = structure(args.frames)
    start = time.perf_counter()
    if not (folder / "data" / "list" / "test.txt").exists():
        result = synth_culane(folder, clips=max(args.frames // 30, 1), frames=30, structure=layout, seed=1)
        print(f"generated {result.n_frames} frames in {result.n_clips} videos "
              f"({'CULane test list layout' if layout else 'synthetic layout'}) in {time.perf_counter() - start:.0f} s")
    data, maps = folder / "data", folder / "maps"
    frames = len((data / "list" / "test.txt").read_text().split())
    videos = len({posixpath.dirname(line) for line in (data / "list" / "test.txt").read_text().split()})
    # Warm the page cache and numba's on-disk cache so both runs read the same way.
    timed_run(data, maps, 1, 1, folder / "warm")
    print(f"{frames} frames in {videos} videos, 4x288x800 uint8 .npy; methods baseline, roneld")
    for workers in sorted({1, default_workers()}):
        runs = [timed_run(data, maps, workers, None, folder / f"out-{workers}") for _ in range(3)]
        elapsed, peak = sorted(runs)[1]
        inner = evaluation_seconds(folder / f"out-{workers}")
        print(f"  {workers} worker(s): {elapsed:6.1f} s  {frames / elapsed:6.0f} frames/s for the whole command, median of 3 "
              f"({inner:.1f} s inside the run: {frames / inner:.0f} frames/s; peak RSS of a process {peak} MB)")
    half = max(videos // 2, 1)
    elapsed, peak = timed_run(data, maps, default_workers(), half, folder / "out-half")
    print(f"  first {half} videos only, all workers: {elapsed:6.1f} s  (peak RSS of a process {peak} MB)")
    print("Target: at least 400 frames/s on 2 cores (the 34,680-frame CULane test set in under 1.5 minutes).")


if __name__ == "__main__":
    main()
