"""Benchmark map loading per format against the decode floor, and the whole run against it.

For each map format (npy, npz, grey PNG as `roneld-eval synth --maps-format scnn-png` writes
it, RGB PNG as the authors' real clip stores it: 976x351 grey repeated in R, G and B), on the
same files:
- a library alone: the same stack as numpy (np.load) or OpenCV (cv2.imread, one grey channel)
  read it, none of our code in the path, in ms per frame on one process;
- the decode floor: the fastest way found to read a frame's files into the same (C, H, W)
  uint8 stack, skipping every check (npy: one read; npz: libdeflate on the member; PNG:
  libdeflate and the row filters undone on one channel only, by load_maps' own kernel), against
  `roneld_eval.maps.load_maps`, in ms per frame on one process (both then take the stack's
  maximum, so that a memory map is read too);
- the whole `roneld-eval run` (baseline and RONELD, every output) in frames per second,
  against the floor decoding the same frames with as many processes; with the peak resident
  memory of the run's largest process (wait4's rusage of the command).
Synthetic sets are written to a temporary folder; the real clip (../shared/data/culane-scnn-clip)
is linked as several videos to reach --frames and skipped when absent. Medians of --repeats.
With --before, load_maps and the run are also timed with their libdeflate paths switched off,
which is how every map was read before (np.load, OpenCV).

    python scripts/bench_maps.py [--frames 600] [--repeats 3] [--workers N] [--before] [--loads-only]
"""

from __future__ import annotations

import argparse
import functools
import multiprocessing
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

import deflate  # noqa: E402

from roneld_eval.config import EvalConfig  # noqa: E402
from roneld_eval.maps import load_maps, map_stem  # noqa: E402
from roneld_eval.maps._kernels import unfilter_stream  # noqa: E402
from roneld_eval.benchmarks.culane.synth import synth_culane  # noqa: E402
from roneld_eval.workers import default_workers  # noqa: E402

REAL_CLIP = REPO.parent / "shared" / "data" / "culane-scnn-clip"
CHANNELS = 4


# ---- the decode floor: no checks, one way of storing each ---------------------------------------


def floor_npy(stem: Path) -> np.ndarray:
    data = (stem.parent / (stem.name + ".npy")).read_bytes()
    header = 10 + int.from_bytes(data[8:10], "little")
    shape = tuple(int(v) for v in data[10:header].split(b"(")[1].split(b")")[0].split(b",") if v.strip())
    return np.frombuffer(data, np.uint8, offset=header).reshape(shape)


def floor_npz(stem: Path) -> np.ndarray:
    """The 'probs' member, inflated with libdeflate straight from the archive's bytes."""
    import zipfile

    path = stem.parent / (stem.name + ".npz")
    data = path.read_bytes()
    with zipfile.ZipFile(path) as archive:
        info = archive.getinfo("probs.npy")
    start = info.header_offset + 30 + int.from_bytes(data[info.header_offset + 26:info.header_offset + 28], "little")
    start += int.from_bytes(data[info.header_offset + 28:info.header_offset + 30], "little")
    raw = deflate.deflate_decompress(data[start:start + info.compress_size], info.file_size)
    return floor_npy_bytes(raw)


def floor_npy_bytes(raw) -> np.ndarray:
    header = 10 + int.from_bytes(raw[8:10], "little")
    shape = tuple(int(v) for v in bytes(raw[10:header]).split(b"(")[1].split(b")")[0].split(b",") if v.strip())
    return np.frombuffer(raw, np.uint8, offset=header).reshape(shape)


def floor_png_channel(path: Path) -> np.ndarray:
    """Inflate (libdeflate), then undo the row filters on the first channel only with the same
    kernel as load_maps (maps._kernels.unfilter_stream: it skips zero bytes eight at a time, and
    its channel comparison comes at no cost there); numpy's running sum over every pixel took
    1.4 ms of a real 976x351 map."""
    data = path.read_bytes()
    offset, parts, width, height, samples = 8, [], 0, 0, 1
    while offset < len(data):
        length = int.from_bytes(data[offset:offset + 4], "big")
        kind = data[offset + 4:offset + 8]
        if kind == b"IHDR":
            width = int.from_bytes(data[offset + 8:offset + 12], "big")
            height = int.from_bytes(data[offset + 12:offset + 16], "big")
            samples = {0: 1, 2: 3, 6: 4}[data[offset + 17]]
        elif kind == b"IDAT":
            parts.append(data[offset + 8:offset + 8 + length])
        offset += 12 + length
    stream = np.frombuffer(deflate.zlib_decompress(b"".join(parts), height * (1 + width * samples)), np.uint8)
    return unfilter_stream(stream, height, width, samples)[0]


def floor_png(stem: Path) -> np.ndarray:
    channels = [floor_png_channel(stem.parent / f"{stem.name}_{k}_avg.png") for k in range(1, CHANNELS + 1)]
    return np.stack(channels)


FLOORS = {"npy": floor_npy, "npz": floor_npz, "scnn-png": floor_png}


# ---- the same stack read by a well-kept library alone, none of our code: np.load, OpenCV ---------

def library_npy(stem: Path) -> np.ndarray:
    return np.load(stem.parent / (stem.name + ".npy"))


def library_npz(stem: Path) -> np.ndarray:
    with np.load(stem.parent / (stem.name + ".npz")) as archive:
        return archive["probs"]


def library_png(stem: Path) -> np.ndarray:
    """OpenCV's PNG decoder (libpng and zlib), one channel kept, as load_maps keeps one."""
    import cv2

    return np.stack([cv2.imread(str(stem.parent / f"{stem.name}_{k}_avg.png"), cv2.IMREAD_GRAYSCALE)
                     for k in range(1, CHANNELS + 1)])


LIBRARIES = {"npy": library_npy, "npz": library_npz, "scnn-png": library_png}


# ---- the sets ---------------------------------------------------------------------------------------


def real_clip_set(folder: Path, frames: int) -> Path | None:
    """The real clip linked as enough videos (CULane layout) to reach `frames`, or None."""
    if not REAL_CLIP.is_dir():
        return None
    names = sorted({p.name[:5] for p in REAL_CLIP.glob("*_1_avg.png")})
    listing = []
    for video in range(max(1, -(-frames // len(names)))):
        clip = f"driver_37_30frame/05181432_{203 + video:04d}.MP4"
        for root in (folder / "data" / clip, folder / "maps" / clip):
            root.mkdir(parents=True, exist_ok=True)
        for name in names:
            (folder / "data" / clip / f"{name}.lines.txt").symlink_to(REAL_CLIP / f"{name}.lines.txt")
            for k in range(1, CHANNELS + 1):
                (folder / "maps" / clip / f"{name}_{k}_avg.png").symlink_to(REAL_CLIP / f"{name}_{k}_avg.png")
            (folder / "maps" / clip / f"{name}.exist.txt").symlink_to(REAL_CLIP / f"{name}.exist.txt")
            listing.append(f"/{clip}/{name}.jpg")
    (folder / "data" / "list").mkdir(parents=True)
    (folder / "data" / "list" / "test.txt").write_text("".join(line + "\n" for line in listing))
    return folder


def load_stack(maps_root: Path, config, relpath: str) -> np.ndarray:
    return load_maps(maps_root, relpath, config).probabilities


def relpaths(folder: Path) -> list[str]:
    return [line.lstrip("/") for line in (folder / "data" / "list" / "test.txt").read_text().split()]


# ---- timing -----------------------------------------------------------------------------------------


def per_frame_ms(load, items, repeats: int) -> float:
    times = []
    for _ in range(repeats):
        start = time.perf_counter()
        for item in items:
            load(item).max()
        times.append((time.perf_counter() - start) / len(items) * 1e3)
    return statistics.median(times)


_FLOOR_JOB: tuple | None = None


def _floor_chunk(stems: list[Path]) -> int:
    decode = FLOORS[_FLOOR_JOB[0]]
    for stem in stems:
        decode(stem).max()
    return len(stems)


def floor_frames_per_s(fmt: str, stems: list[Path], workers: int, repeats: int) -> float:
    """Frames per second of the floor decoding every frame with `workers` processes."""
    global _FLOOR_JOB
    _FLOOR_JOB = (fmt,)
    chunks = [stems[i::workers * 4] for i in range(workers * 4)]
    times = []
    with multiprocessing.get_context("fork").Pool(workers) as pool:
        pool.map(_floor_chunk, chunks[:workers])  # start the processes
        for _ in range(repeats):
            start = time.perf_counter()
            pool.map(_floor_chunk, chunks)
            times.append(time.perf_counter() - start)
    return len(stems) / statistics.median(times)


# `python -m roneld_eval` reading maps as before: np.load and OpenCV for every file.
_AS_BEFORE = ("import sys; import roneld_eval.maps.npy as a, roneld_eval.maps.scnn_png as b\n"
              "a._libdeflate = b._libdeflate = None\n"
              "from roneld_eval.cli import main; main(sys.argv[1:], prog_name='roneld-eval')")


class as_before:
    """Within the block, load_maps reads every file as before (libdeflate paths off)."""

    def __enter__(self):
        from roneld_eval.maps import npy, scnn_png

        self.saved = npy._libdeflate, scnn_png._libdeflate
        npy._libdeflate = scnn_png._libdeflate = None

    def __exit__(self, *exc):
        from roneld_eval.maps import npy, scnn_png

        npy._libdeflate, scnn_png._libdeflate = self.saved


def whole_run(folder: Path, fmt: str, workers: int, repeats: int, before: bool = False) -> tuple[float, float]:
    """(frames/s of `roneld-eval run`, peak RSS in MB of its largest process), medians."""
    frames = len(relpaths(folder))
    python = [sys.executable, "-c", _AS_BEFORE] if before else [sys.executable, "-m", "roneld_eval"]
    command = python + ["run", "--dataset", "culane", "--data-root", str(folder / "data"),
               "--maps-root", str(folder / "maps"), "--maps-format", fmt, "--methods", "baseline,roneld",
               "--workers", str(workers), "--out", str(folder / "out"), "--quiet"]
    seconds, peaks = [], []
    for _ in range(repeats):
        start = time.perf_counter()
        process = subprocess.Popen(command)
        _, status, usage = os.wait4(process.pid, 0)
        seconds.append(time.perf_counter() - start)
        if os.waitstatus_to_exitcode(status) != 0:
            raise SystemExit(f"roneld-eval run failed on {folder}")
        peaks.append(usage.ru_maxrss / 1024)  # wait4's rusage covers the command and the workers it reaped
    return frames / statistics.median(seconds), statistics.median(peaks)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--frames", type=int, default=600, help="frames per set (several hundred)")
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--loads-only", action="store_true", help="time the loads only, not whole runs")
    parser.add_argument("--workers", type=int, default=default_workers())
    parser.add_argument("--before", action="store_true",
                        help="also time load_maps and the run as maps were read before")
    args = parser.parse_args()
    workspace = Path(tempfile.mkdtemp(prefix="roneld-bench-maps-"))
    sets = []
    for fmt, label in (("npy", "npy"), ("npz", "npz"), ("scnn-png", "grey PNG (synth)")):
        folder = workspace / fmt
        synth_culane(folder, clips=max(args.frames // 30, 1), frames=30, seed=1, maps_format=fmt)
        sets.append((label, fmt, folder))
    real = real_clip_set(workspace / "real", args.frames)
    if real is None:
        print("(the real clip is absent: no RGB PNG row)")
    else:
        sets.append(("RGB PNG (real clip)", "scnn-png", real))
    print(f"{args.workers} worker(s) for the runs and the floor's processes; medians of {args.repeats}; "
          f"sets in {workspace}")
    print(f"{'format':22s} {'frames':>6s} {'library ms':>10s} {'floor ms':>9s} {'load_maps ms':>12s} {'ratio':>6s}   "
          f"{'floor fr/s':>10s} {'run fr/s':>9s} {'ratio':>6s} {'peak RSS':>9s}")
    for label, fmt, folder in sets:
        config = EvalConfig.preset("scnn-culane").with_overrides(**{"maps.format": fmt}).maps
        maps_root = folder / "maps"
        frames = relpaths(folder)
        stems = [map_stem(maps_root, relpath) for relpath in frames]
        reference = load_maps(maps_root, frames[0], config).probabilities
        assert np.array_equal(FLOORS[fmt](stems[0]), reference), f"the {label} floor reads other values"
        assert np.array_equal(LIBRARIES[fmt](stems[0]), reference), f"the {label} library reads other values"
        load = functools.partial(load_stack, maps_root, config)
        per_frame_ms(load, frames, 1)  # the page cache
        tool_ms = per_frame_ms(load, frames, args.repeats)
        floor_ms = per_frame_ms(FLOORS[fmt], stems, args.repeats)
        library_ms = per_frame_ms(LIBRARIES[fmt], stems, args.repeats)
        line = (f"{label:22s} {len(frames):6d} {library_ms:10.2f} {floor_ms:9.2f} {tool_ms:12.2f} "
                f"{tool_ms / floor_ms:5.2f}x")
        if args.loads_only:
            print(line)
            continue
        floor_fps = floor_frames_per_s(fmt, stems, args.workers, args.repeats)
        run_fps, peak_mb = whole_run(folder, fmt, args.workers, args.repeats)
        print(f"{line}   {floor_fps:10.0f} {run_fps:9.0f} {floor_fps / run_fps:5.1f}x {peak_mb:7.0f} MB")
        if args.before:
            with as_before():
                before_ms = per_frame_ms(load, frames, args.repeats)
            before_fps, before_mb = whole_run(folder, fmt, args.workers, args.repeats, before=True)
            print(f"{'  as before':22s} {'':6s} {'':10s} {'':9s} {before_ms:12.2f} {before_ms / floor_ms:5.2f}x   "
                  f"{'':10s} {before_fps:9.0f} {floor_fps / before_fps:5.1f}x {before_mb:7.0f} MB")
    print("ms: per frame, one process (4 channel maps, then the stack's maximum); ratio: load_maps / floor. "
          "fr/s: frames per second, "
          "the floor decoding with the runs' number of processes. peak RSS: the run's largest process.")


if __name__ == "__main__":
    main()
