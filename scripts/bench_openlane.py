"""Benchmark `score openlane` on a generated OpenLane 2D set (`synth --dataset openlane`: lane2d
annotations and a detector's lanes), end to end in a fresh process, beside OpenLane's lane2d
evaluator on the same files when given: its two runs (default, lanes matched within their category,
and -k, whatever their category) at its defaults (-w 30, -t 0.3), OpenMP on --workers threads.

    python scripts/bench_openlane.py [--frames 400] [--workers 2] [--official LANE2D_DIR/evaluate]

The evaluator is OpenDriveLab/OpenLane (8a0ce6b) eval/LANE_evaluation/lane2d, built unchanged with its
Makefile (this project does not ship it); on Debian or Ubuntu with libopencv-dev (OpenCV 4):

    git -C OpenLane archive --prefix=lane2d/ 8a0ce6b:eval/LANE_evaluation/lane2d | tar x -C DIR
    make -C DIR/lane2d OPENCV_INCLUDE=/usr/include/opencv4 OPENCV_LIB_PATH=/usr/lib/x86_64-linux-gnu

It reads every listed image and writes a picture of each (always: its -s is on by default), so the
images are given to it: one blank 1920x1280 JPEG, linked under each frame's name.
"""

from __future__ import annotations

import argparse
import csv
import os
import re
import subprocess
import sys
import tempfile
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]


def generate(work: Path, n_frames: int) -> list[str]:
    """`synth --dataset openlane`, 100 frames a segment; the list of its images, and the images."""
    import cv2
    import numpy as np

    from roneld_eval.benchmarks.openlane.synth import synth_openlane

    clips = max(1, n_frames // 100)
    synth_openlane(work / "set", clips, max(1, n_frames // clips))
    names = sorted(str(path.relative_to(work / "set" / "labels").with_suffix(".jpg"))
                   for path in (work / "set" / "labels").rglob("*.json"))
    (work / "list.txt").write_text("".join(f"{name}\n" for name in names))
    cv2.imwrite(str(work / "blank.jpg"), np.zeros((1280, 1920, 3), np.uint8))
    for name in names:
        (work / "images" / name).parent.mkdir(parents=True, exist_ok=True)
        (work / "images" / name).symlink_to(work / "blank.jpg")
    return names


def lane2d(evaluate: Path, work: Path, workers: int, any_category: bool) -> tuple[float, tuple[int, int, int]]:
    """One run of the evaluator: its wall time and the TP, FP, FN of its output.txt."""
    out = work / ("lane2d-any" if any_category else "lane2d-same")
    command = [str(evaluate), "-a", f"{work}/set/labels/", "-d", f"{work}/set/predictions/", "-i", f"{work}/images/",
               "-l", str(work / "list.txt"), "-o", f"{out}/"] + (["-k", "1"] if any_category else [])
    start = time.perf_counter()
    subprocess.run(command, check=True, capture_output=True, env=dict(os.environ, OMP_NUM_THREADS=str(workers)))
    seconds = time.perf_counter() - start
    counts = re.search(r"tp: (\d+) fp: (\d+) fn: (\d+)", (out / "output.txt").read_text())
    return seconds, tuple(int(value) for value in counts.groups())


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--frames", type=int, default=400)
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--official", type=Path, help="lane2d's built `evaluate`")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as folder:
        work = Path(folder)
        names = generate(work, args.frames)
        start = time.perf_counter()
        subprocess.run([sys.executable, "-m", "roneld_eval", "score", "openlane", "--labels", str(work / "set/labels"),
                        "--pred-root", str(work / "set/predictions"), "--list", str(work / "list.txt"),
                        "--workers", str(args.workers), "--quiet", "--out", str(work / "ours")], check=True, cwd=REPO)
        ours = time.perf_counter() - start
        print(f"score openlane: {len(names):,} frames, both matchings, IoU 0.3, {args.workers} workers: {ours:.1f} s")
        if args.official is None:
            return
        with open(work / "ours" / "official.csv") as table:
            counts = {row["matching"]: tuple(int(row[k]) for k in ("tp", "fp", "fn")) for row in csv.DictReader(table)}
        same_time, same = lane2d(args.official.resolve(), work, args.workers, any_category=False)
        any_time, any_ = lane2d(args.official.resolve(), work, args.workers, any_category=True)
        theirs = same_time + any_time
        agree = counts == {"same category": same, "any category": any_}
        print(f"lane2d evaluate (2 runs, {args.workers} OpenMP threads): {same_time:.1f} + {any_time:.1f} = "
              f"{theirs:.1f} s; ratio {theirs / ours:.1f}x; TP/FP/FN {'identical' if agree else 'DIFFER'}: "
              f"same category {'/'.join(map(str, same))}, any category {'/'.join(map(str, any_))}")


if __name__ == "__main__":
    main()
