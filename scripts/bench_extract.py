"""Benchmark the extractors: ms per frame of the baseline and RONELD (with PFT), after warm-up.

Maps: the real clip's 976x351 SCNN maps (../shared/data/culane-scnn-clip, when present) and
synthetic 288x800 (SCNN) and 208x976 (ENet-SAD) maps from the fixture generator. Prints
median and p95 per method, numba's compile time apart, and the time of one pass over the
same map data (every value read once, numpy's max) as the floor RONELD is compared with.

    python scripts/bench_extract.py [--repeats 20]
"""

from __future__ import annotations

import argparse
import os
import sys
import tempfile
import time
from pathlib import Path

# A private numba cache: the first call below measures compilation, not a cache load.
os.environ["NUMBA_CACHE_DIR"] = tempfile.mkdtemp(prefix="roneld-bench-numba-")

import numpy as np  # noqa: E402

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

from roneld_eval.config import BaselineParams, MapsConfig, RoneldParams  # noqa: E402
from roneld_eval.extract import RoneldTracker, baseline_lanes, sample_rows, warm_up  # noqa: E402
from roneld_eval.geometry import MapGeometry  # noqa: E402
from roneld_eval.maps import load_maps  # noqa: E402
from roneld_eval.benchmarks.culane.synth import CAMERA  # noqa: E402
from roneld_eval.synth import ClipStyle, render_maps, scene_sequence  # noqa: E402

REAL_CLIP = REPO.parent / "shared" / "data" / "culane-scnn-clip"


def real_clip_maps() -> list[np.ndarray] | None:
    if not REAL_CLIP.is_dir():
        return None
    names = sorted({p.name[:5] for p in REAL_CLIP.glob("*_1_avg.png")})
    config = MapsConfig(format="scnn-png", width=976, height=351)
    return [np.ascontiguousarray(load_maps(REAL_CLIP, f"{n}.jpg", config).probabilities) for n in names]


def synthetic_maps(height: int, width: int, frames: int = 90) -> list[np.ndarray]:
    import cv2

    rng = np.random.default_rng(0)
    scenes = scene_sequence(CAMERA, frames, ClipStyle(curved=True), rng, frames_apart=30)
    out = []
    for k, scene in enumerate(scenes):
        maps = render_maps(scene, ClipStyle(), k, rng)
        out.append(np.stack([cv2.resize(m, (width, height), interpolation=cv2.INTER_LINEAR) for m in maps]))
    return out


def timed(function, frames, repeats) -> np.ndarray:
    times = []
    for _ in range(repeats):
        for maps in frames:
            start = time.perf_counter()
            function(maps)
            times.append(time.perf_counter() - start)
    return np.array(times) * 1e3


def bench(name: str, frames: list[np.ndarray], repeats: int) -> None:
    height, width = frames[0].shape[1:]
    geometry = MapGeometry(1640, 590, width, height)
    tracker = RoneldTracker(RoneldParams(), geometry)
    rows = sample_rows(BaselineParams(), geometry)
    from roneld_eval.model import FrameMaps

    wrapped = [FrameMaps(m) for m in frames]

    def roneld(maps):
        tracker(maps)

    def baseline(maps):
        baseline_lanes(maps, BaselineParams(), geometry, rows)

    def one_pass(maps):
        maps.probabilities.max()

    results = {}
    for label, function in (("one pass over the maps", one_pass), ("baseline", baseline), ("RONELD (PFT)", roneld)):
        tracker.reset()
        function(wrapped[0])
        results[label] = timed(function, wrapped, repeats)
    floor = np.median(results["one pass over the maps"])
    print(f"\n{name}: {len(frames)} frames of 4x{height}x{width}, {repeats} repeats")
    print(f"  {'':26s} {'median ms':>10s} {'p95 ms':>8s} {'x one pass':>10s}")
    for label, values in results.items():
        median = np.median(values)
        print(f"  {label:26s} {median:10.3f} {np.percentile(values, 95):8.3f} {median / floor:10.1f}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=20, help="passes over each set of frames")
    args = parser.parse_args()
    start = time.perf_counter()
    warm_up()
    print(f"numba compile time of the RONELD kernels (empty cache): {time.perf_counter() - start:.2f} s")
    real = real_clip_maps()
    if real is None:
        print("real clip: ../shared/data/culane-scnn-clip not found, skipped")
    else:
        bench("real CULane clip (SCNN maps, 976x351)", real, args.repeats)
    bench("synthetic SCNN-shaped maps (288x800)", synthetic_maps(288, 800), args.repeats)
    bench("synthetic ENet-SAD-shaped maps (208x976)", synthetic_maps(208, 976), args.repeats)
    # The authors' implementation is not run here, so no figure of theirs is printed as if measured.
    print("\nTarget for RONELD: <= 0.4 ms median per frame.")


if __name__ == "__main__":
    main()
