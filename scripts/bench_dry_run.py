"""Benchmark `roneld-eval run --dry-run` on the full CULane test layout: 34,680 frames in 419
videos, a `.lines.txt` beside each image, and every frame's maps (npy: one file a frame;
scnn-png: four PNGs and an `.exist.txt`, 173,400 files).

The layout is the official test list (../shared/data/culane-lists/test.txt, with its category
lists, where present; else a list of the same shape). Only the first frame's maps are real (the
dry run reads the first map's geometry and looks every other file up); the other files are
empty. Prints the wall time of each dry run in a fresh process (median of --repeats) and what
it said; the target is under 5 s.

    python scripts/bench_dry_run.py [--repeats 3] [--formats npy,scnn-png]
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
SHARED_LISTS = REPO.parent / "shared" / "data" / "culane-lists"


def official_list() -> list[str]:
    """The CULane test list's relpaths, or a list of its shape (419 videos, 34,680 frames)."""
    if (SHARED_LISTS / "test.txt").is_file():
        return [line.split()[0].lstrip("/") for line in (SHARED_LISTS / "test.txt").read_text().splitlines()
                if line.strip()]
    frames, videos = 34680, 419
    per_video = [frames // videos + (1 if k < frames % videos else 0) for k in range(videos)]
    return [f"driver_{100 + k % 93}_30frame/{5181432 + 317 * k:08d}_{203 + k:04d}.MP4/{30 * i:05d}.jpg"
            for k, count in enumerate(per_video) for i in range(count)]


def build(root: Path, relpaths: list[str], maps_format: str) -> tuple[Path, Path]:
    """(data root, maps root) of the layout; the first frame's maps from `synth`."""
    from roneld_eval.benchmarks.culane.synth import synth_culane

    data, maps = root / "data", root / "maps"
    (data / "list").mkdir(parents=True)
    (data / "list" / "test.txt").write_text("".join(f"/{relpath}\n" for relpath in relpaths))
    if (SHARED_LISTS / "test_split").is_dir():
        shutil.copytree(SHARED_LISTS / "test_split", data / "list" / "test_split")
    one = synth_culane(root / "one", clips=1, frames=1, maps_format=maps_format)
    first_frame = next(path for path in sorted(one.maps_root.rglob("*")) if path.is_file())
    first_maps = sorted(path for path in first_frame.parent.iterdir() if path.is_file())
    suffixes = [path.name[len(first_frame.parent.joinpath("00000").name):] for path in first_maps]
    for index, relpath in enumerate(relpaths):
        stem = relpath.rsplit(".", 1)[0]
        (data / relpath).parent.mkdir(parents=True, exist_ok=True)
        (data / f"{stem}.lines.txt").touch()
        (maps / stem).parent.mkdir(parents=True, exist_ok=True)
        for source, suffix in zip(first_maps, suffixes):
            target = maps / f"{stem}{suffix}"
            if index == 0:
                shutil.copyfile(source, target)
            else:
                target.touch()
    return data, maps


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--formats", default="npy,scnn-png")
    args = parser.parse_args()
    relpaths = official_list()
    source = "the official test list" if (SHARED_LISTS / "test.txt").is_file() else "a list of its shape"
    print(f"{len(relpaths)} frames ({source}); {os.cpu_count()} cores; code: {REPO}")
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(REPO)] + [p for p in [os.environ.get("PYTHONPATH")] if p])}
    for maps_format in args.formats.split(","):
        with tempfile.TemporaryDirectory(prefix="roneld-bench-dry-run-") as folder:
            started = time.perf_counter()
            data, maps = build(Path(folder), relpaths, maps_format)
            files = sum(1 for _ in maps.rglob("*") if _.is_file())
            print(f"{maps_format}: layout of {files} map files built in {time.perf_counter() - started:.0f} s")
            walls, said = [], ""
            for _ in range(args.repeats):
                start = time.perf_counter()
                command = [sys.executable, "-m", "roneld_eval", "run", "--dry-run", "--data-root", str(data),
                           "--maps-root", str(maps), "--maps-format", maps_format]
                done = subprocess.run(command, env=env, capture_output=True, text=True)
                walls.append(time.perf_counter() - start)
                if done.returncode != 0:
                    sys.exit(f"dry run failed ({done.returncode}):\n{done.stdout}\n{done.stderr}")
                said = done.stdout.strip()
            print(f"  dry run: median {statistics.median(walls):.2f} s of {', '.join(f'{w:.2f}' for w in walls)}")
            print("  it said: " + said.replace("\n", "\n           "))


if __name__ == "__main__":
    main()
