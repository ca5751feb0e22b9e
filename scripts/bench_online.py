"""Benchmark RONELD on a vehicle (issue 50): `RoneldTracker.update` against the run's batch path.

On the real CULane clip (../shared/data/culane-scnn-clip, 90 frames), side by side in one process,
passes alternating:
- 800x288, 4 channels (the clip's maps resized as SCNN writes them): per-frame ms of the run's
  extractor (`RoneldExtractor(maps)`, what `run` times per frame) and of `update` (uint8 and
  float32 probabilities), p50 and p99, and update's p50 over the batch path's;
- 640x320, Autoware EgoLanes' 3 channels (ego left, ego right, other lanes from the same maps):
  `update(channels="egolanes")` against the batch path on the same frames mapped to SCNN's order;
- RSS growth over --frames calls of `update` (default 100,000), after the first 1,000;
- the share of update spent in the kernel that releases the GIL, and the throughput of two
  trackers in two threads against one tracker in one (frames per second).

    python scripts/bench_online.py [--repeats 30] [--frames 100000] [--thread-frames 20000]
        [--authors DIR --authors-python PYTHON]

With --authors, also the authors' RONELD (czming/RONELD-Lane-Detection's lane_detection_functions.py
in DIR, never part of this project) in a Python of its own (its numba must be < 0.59), kept
running beside this process and given the same frames (800x288, and the clip's own 976x351),
passes alternating with update's.
Its function draws each active lane into a mask too: its time includes that.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

import roneld_eval  # noqa: E402
from roneld_eval.config import MapsConfig, RoneldParams  # noqa: E402
from roneld_eval.extract.online import egolanes_as_scnn  # noqa: E402
from roneld_eval.extract.roneld import RoneldExtractor  # noqa: E402
from roneld_eval.geometry import MapGeometry  # noqa: E402
from roneld_eval.maps import frames_in_folder, load_maps  # noqa: E402
from roneld_eval.model import FrameMaps  # noqa: E402

REAL_CLIP = REPO.parent / "shared" / "data" / "culane-scnn-clip"


def clip_maps(width: int, height: int) -> list[np.ndarray]:
    """The real clip's four channels resized (bilinear) to width x height, uint8."""
    import cv2

    config = MapsConfig(format="scnn-png", width=976, height=351)
    out = []
    for relpath in frames_in_folder(REAL_CLIP, config):
        maps = load_maps(REAL_CLIP, relpath, config).probabilities
        out.append(np.stack([cv2.resize(np.asarray(m), (width, height), interpolation=cv2.INTER_LINEAR)
                             for m in maps]))
    return out


def as_egolanes(maps: np.ndarray) -> np.ndarray:
    """SCNN's channels as EgoLanes' masks: ego left, ego right, and every other lane in one."""
    return np.ascontiguousarray(np.stack([maps[1], maps[2], np.maximum(maps[0], maps[3])]))


def per_frame_ms(call, frames) -> list[float]:
    times = []
    for maps in frames:
        start = time.perf_counter()
        call(maps)
        times.append((time.perf_counter() - start) * 1e3)
    return times


def side_by_side(title: str, geometry: MapGeometry, ways: dict, repeats: int) -> None:
    """Each way (name -> (make a fresh callable per pass, its frames)) over the clip, passes
    alternating, `repeats` times; a fresh tracker per pass (a clip from its start)."""
    times: dict[str, list[float]] = {name: [] for name in ways}
    for _ in range(repeats):
        for name, (make, frames) in ways.items():
            times[name] += per_frame_ms(make(), frames)
    batch = np.median(times["batch path (run's extractor)"])
    print(f"\n{title}: {repeats} passes of the clip's {len(next(iter(ways.values()))[1])} frames, alternating")
    print(f"  {'':44s} {'p50 ms':>8s} {'p99 ms':>8s} {'max ms':>8s} {'p50 / batch':>12s}")
    for name, values in times.items():
        p50, p99 = np.percentile(values, [50, 99])
        print(f"  {name:44s} {p50:8.3f} {p99:8.3f} {max(values):8.3f} {p50 / batch:12.2f}")


def rss_bytes() -> int:
    with open("/proc/self/statm") as file:
        return int(file.read().split()[1]) * os.sysconf("SC_PAGE_SIZE")


def memory(frames: list[np.ndarray], total: int) -> None:
    tracker = roneld_eval.RoneldTracker.from_preset("scnn-culane")
    count = len(frames)
    for k in range(1000):
        tracker.update(frames[k % count])
    start, started = rss_bytes(), time.perf_counter()
    peak = start
    for k in range(1000, total):
        tracker.update(frames[k % count])
        if k % 10_000 == 0:
            peak = max(peak, rss_bytes())
    end = rss_bytes()
    print(f"\nmemory: RSS {start / 2**20:.1f} MB after 1,000 frames, {end / 2**20:.1f} MB after {total:,} "
          f"(growth {(end - start) / 2**20:+.2f} MB, peak {peak / 2**20:.1f} MB; target < 5 MB); "
          f"{(time.perf_counter() - started) / (total - 1000) * 1e3:.3f} ms a frame; {tracker.latency()} "
          f"(the tracker's own ring); {tracker.state.n_lanes} lanes tracked at the end")


def threads(frames: list[np.ndarray], per_thread: int, rounds: int = 3) -> None:
    def drive(tracker, out: list, index: int) -> None:
        count = len(frames)
        for k in range(per_thread):
            tracker.update(frames[k % count])
        out[index] = True

    ratios = []
    for _ in range(rounds):
        timings = []
        for n in (1, 2):
            trackers = [roneld_eval.RoneldTracker.from_preset("scnn-culane") for _ in range(n)]
            done = [False] * n
            workers = [threading.Thread(target=drive, args=(trackers[i], done, i)) for i in range(n)]
            start = time.perf_counter()
            for worker in workers:
                worker.start()
            for worker in workers:
                worker.join()
            assert all(done)
            timings.append(n * per_thread / (time.perf_counter() - start))
        ratios.append(timings[1] / timings[0])
        print(f"  one tracker {timings[0]:7.0f} frames/s, two in two threads {timings[1]:7.0f} frames/s together: "
              f"{ratios[-1]:.2f}x")
    print(f"threads: two trackers against one, median {np.median(ratios):.2f}x throughput "
          f"({os.cpu_count()} cores, load average {os.getloadavg()[0]:.1f}; aim 1.5x)")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=30, help="passes over the clip per way of running it")
    parser.add_argument("--frames", type=int, default=100_000, help="update calls of the memory check")
    parser.add_argument("--thread-frames", type=int, default=20_000, help="frames per thread in the thread check")
    parser.add_argument("--authors", metavar="DIR", help="folder holding the authors' lane_detection_functions.py")
    parser.add_argument("--authors-python", metavar="PYTHON", default="python3.7",
                        help="a Python with numba < 0.59, numpy, scipy and OpenCV for the authors' code")
    args = parser.parse_args()
    if not REAL_CLIP.is_dir():
        sys.exit(f"{REAL_CLIP}: the real clip is not here; nothing measured")
    start = time.perf_counter()
    roneld_eval.warm_up()
    print(f"warm_up (numba's kernels from its cache, SciPy's spline, every path once): "
          f"{time.perf_counter() - start:.2f} s, paid before the first frame")
    print(f"load average {os.getloadavg()[0]:.1f} on {os.cpu_count()} cores")

    scnn = clip_maps(800, 288)
    floats = [maps.astype(np.float32) / 255 for maps in scnn]
    geometry = MapGeometry(1640, 590, 800, 288)
    params = RoneldParams()
    framed = [FrameMaps(maps) for maps in scnn]

    def batch(geometry: MapGeometry):
        return RoneldExtractor(geometry, {"center_ratio": 0.5, "lane_ratio": 0.0})

    side_by_side("800x288, 4 channels (SCNN)", geometry, {
        "batch path (run's extractor)": (lambda: batch(geometry), framed),
        "update, uint8": (lambda: roneld_eval.RoneldTracker(params, geometry).update, scnn),
        "update, float32 probabilities": (lambda: roneld_eval.RoneldTracker(params, geometry).update, floats),
    }, args.repeats)

    ego_geometry = MapGeometry(1640, 590, 640, 320)
    egolanes = [as_egolanes(maps) for maps in clip_maps(640, 320)]
    mapped = [FrameMaps(egolanes_as_scnn(masks, params.center_ratio)) for masks in egolanes]
    side_by_side("640x320, Autoware EgoLanes' 3 channels", ego_geometry, {
        "batch path (run's extractor)": (lambda: batch(ego_geometry), mapped),
        "update, channels=egolanes, uint8": (
            lambda: roneld_eval.RoneldTracker(params, ego_geometry, channels="egolanes").update, egolanes),
    }, args.repeats)

    if args.authors is not None:
        authors(scnn, geometry, args.authors, args.authors_python, args.repeats)
        native = clip_maps(976, 351)  # the clip's own size, as the authors' demo runs it
        authors(native, MapGeometry(1640, 590, 976, 351), args.authors, args.authors_python, args.repeats)
    memory(scnn, args.frames)
    kernel_share(scnn, geometry, args.repeats)
    threads(scnn, args.thread_frames)


# Runs in the authors' Python: one pass over the clip per line read, its per-frame ms written back.
AUTHORS_PASS = """
import json, sys, time
import numpy as np
sys.path.insert(0, sys.argv[1])
from lane_detection_functions import roneld_lane_detection
frames = list(np.load(sys.argv[2])["frames"])
def one_pass():
    lanes, curves, curve_mode, times = [], np.zeros(10), False, []
    for maps in frames:
        start = time.perf_counter()
        _, lanes, curves, curve_mode = roneld_lane_detection(list(maps), lanes, curves, curve_mode=curve_mode)
        times.append((time.perf_counter() - start) * 1e3)
    return times
one_pass()  # its numba compiles here
print("ready", flush=True)
for line in sys.stdin:
    print(json.dumps(one_pass()), flush=True)
"""


def authors(frames: list[np.ndarray], geometry: MapGeometry, code: str, python: str, repeats: int) -> None:
    with tempfile.TemporaryDirectory(prefix="roneld-authors-") as folder:
        clip = Path(folder) / "clip.npz"
        np.savez(clip, frames=np.stack(frames))
        theirs = subprocess.Popen([python, "-c", AUTHORS_PASS, code, str(clip)], stdin=subprocess.PIPE,
                                  stdout=subprocess.PIPE, text=True)
        assert theirs.stdin is not None and theirs.stdout is not None
        try:
            if theirs.stdout.readline().strip() != "ready":
                sys.exit("the authors' RONELD did not start (see its error above)")
            ours_ms: list[float] = []
            theirs_ms: list[float] = []
            for _ in range(repeats):
                ours_ms += per_frame_ms(roneld_eval.RoneldTracker(RoneldParams(), geometry).update, frames)
                theirs.stdin.write("pass\n")
                theirs.stdin.flush()
                theirs_ms += json.loads(theirs.stdout.readline())
        finally:
            theirs.stdin.close()
            theirs.wait(timeout=60)
    ours50, ours99 = np.percentile(ours_ms, [50, 99])
    their50, their99 = np.percentile(theirs_ms, [50, 99])
    height, width = frames[0].shape[1:]
    print(f"\nthe authors' RONELD, {width}x{height}, {repeats} passes alternating with update: p50 {their50:.3f} ms, "
          f"p99 {their99:.3f} ms; update p50 {ours50:.3f} ms, p99 {ours99:.3f} ms: {their50 / ours50:.1f}x faster "
          f"at p50")


def kernel_share(frames: list[np.ndarray], geometry: MapGeometry, repeats: int) -> None:
    """How much of update runs inside the point-extraction kernel, which releases the GIL: what
    two threads can overlap (the Python around it runs one thread at a time)."""
    from roneld_eval.extract.roneld import current_lanes

    tracker = roneld_eval.RoneldTracker(RoneldParams(), geometry)
    kernel = np.median([ms for _ in range(repeats) for ms in per_frame_ms(current_lanes, frames)])
    whole = np.median([ms for _ in range(repeats) for ms in per_frame_ms(tracker.update, frames)])
    print(f"\nGIL: frame_lanes (nogil) {kernel:.3f} ms of update's {whole:.3f} ms per frame ({kernel / whole:.0%}); "
          f"two threads can gain at most {1 / max(1 - kernel / whole, 0.5):.2f}x")


if __name__ == "__main__":
    main()
