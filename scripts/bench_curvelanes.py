"""Benchmark `score curvelanes` on a generated CurveLanes set (`synth --dataset curvelanes`: labels,
a detector's scored lanes and blank images of three sizes), end to end in a fresh process, at score
threshold 0 and the best of 0.3, 0.5, 0.7, beside CondLaneNet's lane_metric.py on the same files
when given: a LaneMetricCore per threshold (224x224, IoU 0.5, lanes 5 px, as its test_curvelanes.py
builds it; Shape each image's size), fed every image, in a pool of --workers processes.

    python scripts/bench_curvelanes.py [--frames 600] [--workers 2] \
        [--official DIR_HOLDING_tools/condlanenet/lane_metric.py --official-python /path/venv/bin/python]

The metric is aliyun/conditional-lane-detection (c57b242) tools/condlanenet/lane_metric.py, run
unchanged (this project does not ship it) by a Python with numpy, scipy, opencv-python-headless and
imagesize (the images' sizes):

    git -C conditional-lane-detection archive c57b242 tools/condlanenet/lane_metric.py | tar x -C DIR
    python -m venv VENV && VENV/bin/pip install numpy scipy opencv-python-headless imagesize
"""

from __future__ import annotations

import argparse
import csv
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
THRESHOLDS = (0.0, 0.3, 0.5, 0.7)  # --score-threshold 0 and --best-of the rest

# lane_metric.py has no entry point reading files: its test feeds LaneMetricCore dicts as below
_OFFICIAL = """
import json, os, sys
from multiprocessing import Pool
import imagesize
from tools.condlanenet.lane_metric import LaneMetricCore

LABELS, PRED, IMAGES, WORKERS, *THRESHOLDS = sys.argv[1:]


def load(path):
    try:
        with open(path) as file:
            return json.load(file)
    except FileNotFoundError:  # no prediction: no lanes
        return {"Lines": []}


def cores():
    return [LaneMetricCore(eval_width=224, eval_height=224, iou_thresh=0.5, lane_width=5, prob_thresh=float(t))
            for t in THRESHOLDS]


def records(names):
    metrics = cores()
    for name in names:
        width, height = imagesize.get(os.path.join(IMAGES, name + ".png"))
        shape = dict(width=width, height=height)
        target = dict(load(os.path.join(LABELS, name + ".lines.json")), Shape=shape)
        predicted = dict(load(os.path.join(PRED, name + ".lines.json")), Shape=shape)
        for metric in metrics:
            metric(target, predicted)
    return [metric.result_record for metric in metrics]


if __name__ == "__main__":
    names = sorted(name[:-len(".lines.json")] for name in os.listdir(LABELS))
    n = int(WORKERS)
    with Pool(n) as pool:
        parts = pool.map(records, [names[i * len(names) // n:(i + 1) * len(names) // n] for i in range(n)])
    summaries = []
    for t, metric in enumerate(cores()):
        metric.result_record = [record for part in parts for record in part[t]]
        summaries.append(dict(metric.summary(), hit_num=sum(record["hit_num"] for record in metric.result_record)))
    print(json.dumps(summaries))
"""


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--frames", type=int, default=600)
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--official", type=Path, help="the folder holding tools/condlanenet/lane_metric.py")
    parser.add_argument("--official-python", type=Path, help="a Python with lane_metric.py's packages and imagesize")
    args = parser.parse_args()
    if (args.official is None) != (args.official_python is None):
        parser.error("--official and --official-python go together")
    with tempfile.TemporaryDirectory() as folder:
        from roneld_eval.benchmarks.curvelanes.synth import synth_curvelanes

        work = Path(folder)
        clips = max(1, args.frames // 100)  # 100 images a size, three sizes in turn
        result = synth_curvelanes(work, clips, max(1, args.frames // clips))
        start = time.perf_counter()
        subprocess.run([sys.executable, "-m", "roneld_eval", "score", "curvelanes", "--labels", str(result.data_root),
                        "--pred-root", str(result.maps_root), "--image-root", str(work / "images"),
                        "--best-of", ",".join(map(str, THRESHOLDS[1:])), "--workers", str(args.workers), "--quiet",
                        "--out", str(work / "ours")], check=True, cwd=REPO)
        ours = time.perf_counter() - start
        print(f"score curvelanes: {result.n_frames:,} images, score threshold 0 and best of 0.3/0.5/0.7, "
              f"{args.workers} workers: {ours:.1f} s")
        if args.official is None:
            return
        (work / "official.py").write_text(_OFFICIAL)
        start = time.perf_counter()
        output = subprocess.run([str(args.official_python), str(work / "official.py"), str(result.data_root),
                                 str(result.maps_root), str(work / "images"), str(args.workers)]
                                + [str(t) for t in THRESHOLDS], check=True, capture_output=True, text=True,
                                env=dict(os.environ, PYTHONPATH=str(args.official.resolve()))).stdout
        theirs = time.perf_counter() - start
        summaries = json.loads(output.strip().splitlines()[-1])
        best = max(range(1, len(THRESHOLDS)), key=lambda t: summaries[t]["f1_measure"])  # the first of equals
        expected = [(THRESHOLDS[t], summaries[t]["hit_num"], summaries[t]["pr_num"], summaries[t]["gt_num"],
                     summaries[t]["f1_measure"]) for t in (0, best)]  # official.csv: the same double
        with open(work / "ours" / "official.csv") as table:
            rows = [(float(row["score_threshold"]), int(row["hits"]), int(row["predicted"]), int(row["truth"]),
                     float(row["f1"])) for row in csv.DictReader(table)]  # the fixed threshold's, then the best's
        same = rows == expected
        print(f"lane_metric.py ({len(THRESHOLDS)} LaneMetricCores, {args.workers} processes): {theirs:.1f} s; "
              f"ratio {theirs / ours:.1f}x; hits/predicted/truth and F1 {'identical' if same else 'DIFFER'}: "
              + ", ".join(f"threshold {t:g} {h}/{p}/{g} F1 {f!r}" for t, h, p, g, f in expected))


if __name__ == "__main__":
    main()
