"""Benchmark `roneld-eval run`: frames per second with baseline and RONELD, 1 worker and all.

Generates a CULane-shaped set of at least --frames frames (4x288x800 uint8 .npy maps), with
the videos and frame numbering of the official CULane test list when
../shared/data/culane-lists/test.txt is present (whole videos, in list order), then runs the
full evaluation (paper protocol, official CULane scores, all outputs) with one worker and with
every core, and prints frames per second and peak memory. Memory should not grow with frames:
the run is repeated on half the set to show it.

With --compare-scoring it instead times, in one go on the same set, the whole command with
scoring as it was before masks became runs per row (roneld_eval.metrics.reference: every lane
drawn pixel by pixel on a canvas) against the current scoring, alternating, and one official
CULane lane mask both ways (ms per ground-truth lane of the set, one core).

    python scripts/bench_run.py [--frames 2000] [--data DIR] [--compare-scoring]
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


# `python -m roneld_eval` with scoring's masks drawn on canvases, as before runs per row.
_REFERENCE_SCORING = ("import sys; from roneld_eval.cli import main\n"
                      "from roneld_eval.metrics.reference import drawn_masks\n"
                      "with drawn_masks(): main(sys.argv[1:], prog_name='roneld-eval')")


def timed_run(data: Path, maps: Path, workers: int, limit: int | None, out: Path,
              reference_scoring: bool = False) -> tuple[float, int]:
    python = [sys.executable, "-c", _REFERENCE_SCORING] if reference_scoring else [sys.executable, "-m", "roneld_eval"]
    command = python + ["run", "--dataset", "culane", "--data-root", str(data),
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
    parser.add_argument("--compare-scoring", action="store_true",
                        help="time the run with canvas-drawn masks (the old scoring) against the current one")
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
    if args.compare_scoring:
        compare_scoring(data, maps, folder, frames)
        return
    for workers in sorted({1, default_workers()}):
        runs = [timed_run(data, maps, workers, None, folder / f"out-{workers}") for _ in range(3)]
        elapsed, peak = sorted(runs)[1]
        inner = evaluation_seconds(folder / f"out-{workers}")
        print(f"  {workers} worker(s): {elapsed:6.1f} s  {frames / elapsed:6.0f} frames/s for the whole command, "
              "median of 3 "
              f"({inner:.1f} s inside the run: {frames / inner:.0f} frames/s; peak RSS of a process {peak} MB)")
    half = max(videos // 2, 1)
    elapsed, peak = timed_run(data, maps, default_workers(), half, folder / "out-half")
    print(f"  first {half} videos only, all workers: {elapsed:6.1f} s  (peak RSS of a process {peak} MB)")
    print("Target: at least 400 frames/s on 2 cores (the 34,680-frame CULane test set in under 1.5 minutes).")


def compare_scoring(data: Path, maps: Path, folder: Path, frames: int, repeats: int = 3) -> None:
    """Old (canvas) against new (runs) scoring: whole runs alternating, then one lane mask."""
    import filecmp

    workers = default_workers()
    timed_run(data, maps, workers, 1, folder / "warm-old", reference_scoring=True)
    seconds: dict[bool, list[float]] = {True: [], False: []}
    for _ in range(repeats):
        for reference in (True, False):
            out = folder / f"out-{'old' if reference else 'new'}"
            elapsed, _ = timed_run(data, maps, workers, None, out, reference)
            seconds[reference].append(elapsed)
    old, new = sorted(seconds[True])[repeats // 2], sorted(seconds[False])[repeats // 2]
    same = all(filecmp.cmp(folder / "out-old" / name, folder / "out-new" / name, shallow=False)
               for name in ("per_frame.csv", "official.csv", "accuracy.csv"))
    print(f"  {workers} worker(s), whole command, median of {repeats} (alternating):")
    print(f"    old scoring (canvas masks): {old:6.1f} s  {frames / old:6.0f} frames/s")
    print(f"    new scoring (runs per row): {new:6.1f} s  {frames / new:6.0f} frames/s  = {old / new:.2f}x "
          f"({'identical' if same else 'DIFFERENT'} per_frame.csv, official.csv, accuracy.csv)")
    lane_mask_ms(data)


def lane_mask_ms(data: Path, lanes_wanted: int = 4000) -> None:
    """ms per official lane mask (1640x590, 30 px) on the set's ground-truth lanes, both ways."""
    from roneld_eval import kernels
    from roneld_eval.lanes_io import read_culane_lines
    from roneld_eval.metrics.raster import official_mask, official_mask_by_canvas

    kernels.warm_up(["official"])
    lanes = []
    for path in sorted(data.rglob("*.lines.txt")):
        lanes += [lane for lane in read_culane_lines(path) if len(lane) >= 2]
        if len(lanes) >= lanes_wanted:
            break
    for name, draw in (("canvas (old)", official_mask_by_canvas), ("runs per row (new)", official_mask)):
        runs = []
        for _ in range(5):
            start = time.process_time()
            for lane in lanes:
                draw(lane, 1640, 590, 30)
            runs.append(time.process_time() - start)
        print(f"  official lane mask, {name:18s}: {1e3 * min(runs) / len(lanes):.3f} ms per lane "
              f"(CPU, best of 5, {len(lanes)} ground-truth lanes)")


if __name__ == "__main__":
    main()
