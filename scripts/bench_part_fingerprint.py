"""Benchmark what a part's fingerprint of its predictions costs: every listed prediction file of a
CULane set from `roneld-eval synth --maps-format lanes`, fingerprinted by stat (path, size,
modification time: shards.files_fingerprint, as parts record them) and by SHA-256 of the contents,
with the files in the page cache (as a shard finds them right after scoring) and out of it (as a
merge may find them later: each file's pages dropped with posix_fadvise), beside one unsharded
`score culane` of the set for scale.

    python scripts/bench_part_fingerprint.py [--clips 2890] [--set FOLDER]
"""

from __future__ import annotations

import argparse
import hashlib
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]


def content_fingerprint(paths: list[Path]) -> str:
    hasher = hashlib.sha256()
    for path in paths:
        try:
            hasher.update(f"{os.path.abspath(path)}\0".encode() + hashlib.sha256(path.read_bytes()).digest())
        except OSError:
            hasher.update(f"{os.path.abspath(path)}\0missing\n".encode())
    return hasher.hexdigest()


def dropped(paths: list[Path]) -> None:
    """The files' pages out of the page cache (no root needed for clean pages)."""
    for path in paths:
        descriptor = os.open(path, os.O_RDONLY)
        try:
            os.posix_fadvise(descriptor, 0, 0, os.POSIX_FADV_DONTNEED)
        finally:
            os.close(descriptor)


def median_s(function, paths: list[Path], cold: bool, repeat: int = 5) -> float:
    times = []
    for _ in range(repeat):
        if cold:
            dropped(paths)
        start = time.perf_counter()
        function(paths)
        times.append(time.perf_counter() - start)
    return statistics.median(times)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--clips", type=int, default=2890, help="12 frames each: 2890 is CULane's 34,680")
    parser.add_argument("--set", type=Path, help="a set `synth --maps-format lanes` wrote (else one is made)")
    args = parser.parse_args()
    from roneld_eval.benchmarks.culane.reader import labels_path
    from roneld_eval.shards import files_fingerprint

    with tempfile.TemporaryDirectory() as folder:
        work = Path(folder)
        root = args.set or work / "set"
        if args.set is None:
            subprocess.run([sys.executable, "-m", "roneld_eval", "synth", "--dataset", "culane", "--out", str(root),
                            "--clips", str(args.clips), "--maps-format", "lanes"], check=True, cwd=REPO,
                           stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        listed = [line.strip().lstrip("/") for line in (root / "data" / "list" / "test.txt").read_text().splitlines()]
        paths = [labels_path(root / "maps", relpath) for relpath in listed if relpath]
        start = time.perf_counter()
        subprocess.run([sys.executable, "-m", "roneld_eval", "score", "culane", "--data-root", str(root / "data"),
                        "--pred-root", str(root / "maps"), "--quiet", "--out", str(work / "score")], check=True,
                       cwd=REPO, stdout=subprocess.DEVNULL, env={**os.environ, "RONELD_EVAL_TRUTH_CACHE": "0"})
        scored = time.perf_counter() - start
        print(f"{len(paths):,} prediction files; one unsharded score culane: {scored:.1f} s")
        for cold in (False, True):
            for name, function in (("stat", lambda p: files_fingerprint(p)), ("content", content_fingerprint)):
                print(f"  {name:7s} {'out of' if cold else 'in'} the page cache: "
                      f"{median_s(function, paths, cold) * 1000:.0f} ms (median of 5)")


if __name__ == "__main__":
    main()
