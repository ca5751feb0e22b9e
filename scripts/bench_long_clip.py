"""Benchmark one long clip against the same frames split into clips (target: within 1.3x).

RONELD's tracking runs in frame order within a clip, so a long clip is cut into segments
(roneld_eval.evaluation.SEGMENT_FRAMES) extracted one after another, the tracking state passed
along, and scored in parallel by every worker.

Generates --frames synthetic CULane frames twice, as one video folder and as videos of
--clip-frames frames, then runs `roneld-eval run` on each alternately (--repeats
times) and prints the median wall times, frames/s and their ratio.

    python scripts/bench_long_clip.py [--frames 5000] [--clip-frames 100] [--maps-format npy] [--workers N]
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

from roneld_eval.synth import synth_culane  # noqa: E402
from roneld_eval.workers import default_workers  # noqa: E402


def frames_of(video: str, count: int) -> list[str]:
    return [f"{video}/{30 * i:05d}.jpg" for i in range(count)]


def timed_run(root: Path, maps_format: str, workers: int, out: Path) -> float:
    command = [sys.executable, "-m", "roneld_eval", "run", "--dataset", "culane", "--data-root", str(root / "data"),
               "--maps-root", str(root / "maps"), "--maps-format", maps_format, "--methods", "baseline,roneld",
               "--workers", str(workers), "--out", str(out), "--quiet"]
    start = time.perf_counter()
    subprocess.run(command, check=True)
    return time.perf_counter() - start


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--frames", type=int, default=5000)
    parser.add_argument("--clip-frames", type=int, default=100)
    parser.add_argument("--maps-format", default="npy", choices=["npy", "npz", "scnn-png"])
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--workers", type=int, default=default_workers())
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as folder:
        base = Path(folder)
        one = [("driver_1_30frame/long.MP4", frames_of("driver_1_30frame/long.MP4", args.frames))]
        videos = [f"driver_1_30frame/part{k:03d}.MP4" for k in range(args.frames // args.clip_frames)]
        many = [(video, frames_of(video, args.clip_frames)) for video in videos]
        synth_culane(base / "one", structure=one, seed=1, maps_format=args.maps_format)
        synth_culane(base / "many", structure=many, seed=1, maps_format=args.maps_format)
        timed_run(base / "many", args.maps_format, args.workers, base / "warm")  # compile, fill caches
        times: dict[str, list[float]] = {"one clip": [], "split": []}
        for _ in range(args.repeats):
            times["one clip"].append(timed_run(base / "one", args.maps_format, args.workers, base / "out1"))
            times["split"].append(timed_run(base / "many", args.maps_format, args.workers, base / "out2"))
    frames = len(many) * args.clip_frames
    medians = {name: statistics.median(values) for name, values in times.items()}
    print(f"{frames} frames of {args.maps_format} maps, {args.workers} workers, median of {args.repeats} runs")
    for name, value in medians.items():
        print(f"  {name:9s} {value:6.2f} s  {frames / value:6.0f} frames/s")
    ratio = medians["one clip"] / medians["split"]
    print(f"one clip / split: {ratio:.2f}x (target <= 1.3x)")


if __name__ == "__main__":
    main()
