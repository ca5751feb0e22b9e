"""Benchmark `score llamas` on a generated LLAMAS-like split (`synth --dataset llamas`: labels as
dashed markers, a detector's lanes), end to end in a fresh process, beside unsupervised_llamas'
culane_metric/evaluate.py on the same files when given (its official discrete IoU, in parallel
with p_map as its main does); with --maps, the AP of a segmentation model's maps
(`synth --maps-format llamas-png`) beside evaluation/evaluate_segmentation.py --multi_class
(its evaluate_set, in a process pool of --workers).

    python scripts/bench_llamas.py [--labels 2000] [--workers 2] [--maps] \
        [--official-python /path/venv/bin/python --official-path DIR_HOLDING_unsupervised_llamas]

The official code is karstenBehrendt/unsupervised_llamas (9b99f46), importable as the package
`unsupervised_llamas` with numpy, scipy, opencv, shapely and p_tqdm; this project does not ship it.
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
def generate(out: Path, n_labels: int, seed: int = 0, maps_format: str = "lanes") -> None:
    """`synth --dataset llamas`: labels as dashed markers and a detector's lanes (or a model's
    maps), 100 a recording."""
    from roneld_eval.benchmarks.llamas.synth import synth_llamas

    clips = max(1, n_labels // 100)
    synth_llamas(out / "set", clips, max(1, n_labels // clips), seed, maps_format)
    (out / "labels").symlink_to(out / "set" / "labels")
    (out / "pred").symlink_to(out / "set" / "predictions")


# evaluate_set reads its labels from dataset_constants.LABELS/<split>: pointed at ours here
_OFFICIAL_AP = """
import sys, warnings
warnings.simplefilter('ignore')
from unsupervised_llamas.label_scripts import dataset_constants
dataset_constants.LABELS = sys.argv[1]
from unsupervised_llamas.evaluation import evaluate_segmentation as es
result = es.evaluate_set(sys.argv[2], es.multi_eval_single_image, dataset_split='valid', max_workers=int(sys.argv[3]))
print(repr({lane: dict(values) for lane, values in result.items()}))
"""


def bench_maps(args, work: Path) -> None:
    generate(work, args.labels, maps_format="llamas-png")
    (work / "split").mkdir()
    (work / "split" / "valid").symlink_to(work / "labels")
    start = time.perf_counter()
    subprocess.run([sys.executable, "-m", "roneld_eval", "score", "llamas", "--labels", str(work / "labels"),
                    "--maps", str(work / "pred"), "--workers", str(args.workers), "--quiet",
                    "--out", str(work / "ours")], check=True, cwd=REPO)
    ours = time.perf_counter() - start
    print(f"score llamas --maps: {args.labels:,} labels, 4 classes, {args.workers} workers: {ours:.1f} s")
    if args.official_python is None:
        return
    environment = dict(os.environ, PYTHONPATH=str(args.official_path))
    start = time.perf_counter()
    result = subprocess.run([str(args.official_python), "-c", _OFFICIAL_AP, str(work / "split"), str(work / "pred"),
                             str(args.workers)], check=True, capture_output=True, text=True, env=environment)
    theirs = time.perf_counter() - start
    import numpy  # the script prints numpy scalars: np.float64(...)

    official = eval(result.stdout.strip().splitlines()[-1], {"np": numpy})  # {class: {recall, precision, ...}}
    with open(work / "ours" / "official.csv") as table:
        header, row = (line.split(",") for line in table.read().splitlines()[:2])
    ours_ap = [float(row[header.index(f"ap_{name}")]) for name in ("l1", "l0", "r0", "r1")]
    theirs_ap = [official[c]["auc"] for c in (1, 2, 3, 4)]
    same = all(abs(a - b) < 5e-7 for a, b in zip(ours_ap, theirs_ap))  # what was checked: 6 decimals
    print(f"evaluate_segmentation.py ({args.workers} processes): {theirs:.1f} s; ratio {theirs / ours:.1f}x; "
          f"AP l1, l0, r0, r1 {'identical to 6 decimals' if same else 'DIFFER'}: "
          + ", ".join(f"{v:.6f}" for v in theirs_ap))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--labels", type=int, default=2000)
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--official-python", type=Path)
    parser.add_argument("--official-path", type=Path)
    parser.add_argument("--maps", action="store_true", help="time the AP of probability maps instead of F1")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as folder:
        work = Path(folder)
        if args.maps:
            bench_maps(args, work)
            return
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
