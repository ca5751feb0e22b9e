"""Benchmark `score llamas` on a generated LLAMAS-like split (labels with markers, predictions
with shifts and dropped lanes), end to end in a fresh process, beside unsupervised_llamas'
culane_metric/evaluate.py on the same files when given (its official discrete IoU, in parallel
with p_map as its main does).

    python scripts/bench_llamas.py [--labels 2000] [--workers 2] \
        [--official-python /path/venv/bin/python --official-path DIR_HOLDING_unsupervised_llamas]

The official code is karstenBehrendt/unsupervised_llamas (9b99f46), importable as the package
`unsupervised_llamas` with numpy, scipy, opencv, shapely and p_tqdm; this project does not ship it.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
LANES = ((400, 0.6), (800, -0.5), (100, 1.2), (1100, -1.1))  # bottom x and slope of l0, r0, l1, r1


def generate(out: Path, n_labels: int, seed: int = 0) -> None:
    rng = np.random.default_rng(seed)
    for index in range(n_labels):
        recording = f"images-{index // 200:04d}"
        labels, predictions = out / "labels" / recording, out / "pred" / recording
        labels.mkdir(parents=True, exist_ok=True)
        predictions.mkdir(parents=True, exist_ok=True)
        lanes, lines = [], []
        for name, (bottom, slope) in zip(("l0", "r0", "l1", "r1"), LANES):
            bottom += rng.uniform(-40, 40)
            markers = []
            for k in range(8):
                y0, y1 = 716 - 45 * k, 696 - 45 * k
                if y1 < 250:
                    break
                x0, x1 = (bottom + slope * (716 - y) + rng.uniform(-3, 3) for y in (y0, y1))
                markers.append({"pixel_start": {"x": int(x0), "y": y0}, "pixel_end": {"x": int(x1), "y": y1},
                                "world_start": {"x": 1.0, "y": 1.5, "z": 5.0 + 6 * k},
                                "world_end": {"x": 1.0, "y": 1.5, "z": 8.0 + 6 * k}})
            lanes.append({"lane_id": name, "markers": markers})
            if rng.random() < 0.1:
                continue
            shift = rng.choice([0, 5, 15, 30])
            lines.append(" ".join(f"{bottom + slope * (716 - y) + shift:.1f} {y}" for y in range(716, 300, -20)))
        name = f"{1419283521 + index}_0004236000"
        (labels / f"{name}.json").write_text(json.dumps({"projection_matrix": [[1, 0, 0], [0, 1, 0], [0, 0, 1]],
                                                         "lanes": lanes}))
        (predictions / f"{name}.lines.txt").write_text("\n".join(lines) + "\n")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--labels", type=int, default=2000)
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--official-python", type=Path)
    parser.add_argument("--official-path", type=Path)
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as folder:
        work = Path(folder)
        generate(work, args.labels)
        start = time.perf_counter()
        subprocess.run([sys.executable, "-m", "roneld_eval", "score", "llamas", "--labels", str(work / "labels"),
                        "--pred-root", str(work / "pred"), "--iou", "0.5", "--workers", str(args.workers), "--quiet",
                        "--out", str(work / "ours")], check=True, cwd=REPO)
        ours = time.perf_counter() - start
        print(f"score llamas: {args.labels:,} labels, IoU 0.5, {args.workers} workers: {ours:.1f} s")
        if args.official_python is None:
            return
        code = ("import warnings; warnings.simplefilter('ignore')\n"
                "from unsupervised_llamas.culane_metric.evaluate import eval_predictions\n"
                f"print(eval_predictions({str(work / 'pred')!r}, {str(work / 'labels')!r}, width=30, "
                "unofficial=False, sequential=False))")
        environment = dict(os.environ, PYTHONPATH=str(args.official_path))
        start = time.perf_counter()
        result = subprocess.run([str(args.official_python), "-c", code], check=True, capture_output=True, text=True,
                                env=environment)
        theirs = time.perf_counter() - start
        official = eval(result.stdout.strip().splitlines()[-1], {})  # the script's printed dict
        with open(work / "ours" / "official.csv") as table:
            row = table.read().splitlines()[1].split(",")
        same = (int(row[2]), int(row[3]), int(row[4])) == (official["TP"], official["FP"], official["FN"])
        print(f"evaluate.py (p_map over all cores): {theirs:.1f} s; ratio {theirs / ours:.1f}x; "
              f"TP/FP/FN {'identical' if same else 'DIFFER'}: {official['TP']}/{official['FP']}/{official['FN']}")


if __name__ == "__main__":
    main()
