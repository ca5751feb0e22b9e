"""Benchmark `score vil100` on the VIL-100 test ground truth: 2,000 frames, IoU 0.5 and 0.8 and
the temporal metrics, end to end in a fresh process, beside MMA-Net's C++ evaluator on the same
files when its binary is given (run as evaluate_iou.py runs it: once per sequence and threshold).

    python scripts/bench_vil100.py --labels ../shared/data/vil100/anno_txt \
        --sizes ../shared/data/vil100/test_sizes.json [--workers 2] [--repeats 3] [--evaluator PATH] \
        [--masks grey|palette]

Predictions are the ground truth with seeded shifts, dropped and spurious lanes and empty
frames (written to a temporary folder); with --masks they are also drawn as instance masks
(lane k in grey value k, or palette index k as MMA-Net writes them, 30 px wide at 1920) and scored
with `--pred-format png`. The evaluator is MMA-Net's evaluation/culane built from its sources
(yujun0-0/MMA-Net 8f95908); this project does not ship it.
"""

from __future__ import annotations

import argparse
import json
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]


def perturbed(labels: Path, out: Path, seed: int = 0) -> int:
    rng = np.random.default_rng(seed)
    frames = 0
    for path in sorted(labels.rglob("*.lines.txt")):
        lanes = [np.array(line.split(), float).reshape(-1, 2) for line in path.read_text().splitlines() if line.split()]
        kept = []
        if rng.random() > 0.05:
            for lane in lanes:
                if rng.random() < 0.1:
                    continue
                lane = lane.copy()
                lane[:, 0] += rng.choice([0, 3, 8, 20, 40])
                kept.append(lane)
            if rng.random() < 0.3:
                kept.append(np.array([[rng.uniform(0, 900), 400.0], [rng.uniform(0, 900), 250.0]]))
        target = out / path.relative_to(labels)
        target.parent.mkdir(parents=True, exist_ok=True)
        target.write_text("".join(" ".join(f"{v:.1f}" for v in lane.ravel()) + "\n" for lane in kept))
        frames += 1
    return frames


def as_masks(pred: Path, sizes: dict, out: Path, palette: bool = False) -> None:
    """Each frame's predicted lanes drawn as an instance mask: lane k in grey value k, or in
    palette index k of an indexed PNG, as MMA-Net writes them."""
    import cv2
    from PIL import Image

    colours = [0, 0, 0] + np.random.default_rng(0).integers(0, 256, 765, dtype=np.uint8).tolist()  # 0: black
    for path in sorted(pred.rglob("*.lines.txt")):
        relative = path.relative_to(pred)
        width, height = sizes[relative.parts[0]]["width"], sizes[relative.parts[0]]["height"]
        mask = np.zeros((height, width), np.uint8)
        for k, line in enumerate(path.read_text().splitlines()):
            points = np.round(np.array(line.split(), float).reshape(-1, 1, 2)).astype(np.int32)
            cv2.polylines(mask, [points], False, k + 1, thickness=max(1, round(30 * width / 1920)))
        target = out / relative.parent / (relative.name[:-len(".lines.txt")] + ".png")
        target.parent.mkdir(parents=True, exist_ok=True)
        if palette:
            indexed = Image.fromarray(mask, mode="P")
            indexed.putpalette(colours)
            indexed.save(target)
        else:
            cv2.imwrite(str(target), mask)


def ours(labels: Path, sizes: Path, pred: Path, workers: int, out: Path, *extra: str) -> float:
    start = time.perf_counter()
    subprocess.run([sys.executable, "-m", "roneld_eval", "score", "vil100", "--labels", str(labels), "--pred-root",
                    str(pred), "--sizes", str(sizes), "--workers", str(workers), "--quiet", "--out", str(out),
                    *extra], check=True, cwd=REPO)
    return time.perf_counter() - start


def official(evaluator: Path, labels: Path, sizes: dict, pred: Path, work: Path) -> float:
    """evaluate_iou.py's calls: one list per sequence, -w 30, each threshold, the sequence's size."""
    start = time.perf_counter()
    for threshold in ("0.5", "0.8"):
        for sequence in sorted(p.name for p in labels.iterdir() if p.is_dir()):
            listing = work / f"{sequence}.txt"
            frames = sorted(p.name[:-len(".lines.txt")] for p in (labels / sequence).glob("*.lines.txt"))
            listing.write_text("".join(f"/{sequence}/{frame}.jpg\n" for frame in frames))
            size = sizes[sequence]
            subprocess.run([str(evaluator), "-a", f"{labels}/", "-d", f"{pred}/", "-i", f"{work}/", "-l", str(listing),
                            "-w", "30", "-t", threshold, "-c", str(size["width"]), "-r", str(size["height"]), "-f", "1",
                            "-o", str(work / f"{sequence}-{threshold}.out")], check=True, capture_output=True)
    return time.perf_counter() - start


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--labels", type=Path, required=True)
    parser.add_argument("--sizes", type=Path, required=True)
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--evaluator", type=Path, help="MMA-Net's culane_evaluator, built from its sources")
    parser.add_argument("--masks", choices=("grey", "palette"),
                        help="also score the predictions drawn as instance masks: 8-bit grey, or indexed PNGs")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as folder:
        pred = Path(folder) / "pred"
        frames = perturbed(args.labels.resolve(), pred)
        times = [ours(args.labels.resolve(), args.sizes.resolve(), pred, args.workers, Path(folder) / f"out{k}")
                 for k in range(args.repeats)]
        median = statistics.median(times)
        print(f"score vil100: {frames:,} frames, IoU 0.5 and 0.8 + Rs/Rj/Rm, {args.workers} workers: "
              f"median {median:.1f} s of {args.repeats} ({', '.join(f'{t:.1f}' for t in times)})")
        if args.evaluator is not None:
            sizes = json.loads(args.sizes.read_text())
            work = Path(folder) / "official"
            work.mkdir()
            seconds = official(args.evaluator.resolve(), args.labels.resolve(), sizes, pred, work)
            print(f"MMA-Net's C++ evaluator (F1 and mIoU only, its own OpenMP threads): {seconds:.1f} s, "
                  f"{seconds / median:.1f}x ours")
        if args.masks:
            masks = Path(folder) / "masks"
            as_masks(pred, json.loads(args.sizes.read_text()), masks, palette=args.masks == "palette")
            times = [ours(args.labels.resolve(), args.sizes.resolve(), masks, args.workers, Path(folder) / f"png{k}",
                          "--pred-format", "png") for k in range(args.repeats)]
            median = statistics.median(times)
            print(f"score vil100 --pred-format png ({args.masks} instance masks, read and fitted as MMA-Net's "
                  "scripts do): "
                  f"median {median:.1f} s of {args.repeats} ({', '.join(f'{t:.1f}' for t in times)}), "
                  f"{1000 * median / frames:.1f} ms a frame")


if __name__ == "__main__":
    main()
