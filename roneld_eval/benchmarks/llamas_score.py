"""`score llamas`: predicted `.lines.txt` files scored as LLAMAS's culane_metric/evaluate.py scores
them (karstenBehrendt/unsupervised_llamas 9b99f46: datasets.llamas for the labels,
metrics.llamas_official for the metric), every method and threshold in one pass over the labels.
Papers print F1 at IoU 0.5 (the script's), at 0.75, and mF1 as CLRNet computes it
(Turoad/CLRNet 7269e9d, clrnet/utils/llamas_metric.py:230-244 with the thresholds of
clrnet/datasets/llamas.py:178): F1 / 10 added up over np.linspace(0.5, 0.95, 10), whose ninth
value is 0.8999999999999999; it is always scored, whatever --iou asks.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass
from pathlib import Path
from typing import Callable

import numpy as np

from ..config import check_lane_width
from ..datasets.llamas import IMAGE_HEIGHT, IMAGE_WIDTH, every_label, prediction_path, read_label
from ..errors import InputError
from ..lanes_io import read_culane_lines
from ..metrics.llamas_official import f1_of, frame_counts, interpolated, lane_mask
from ..output import Staging
from ..report.tables import Table
from ..score import PlainTable, PredictionRoots, _taking, find_prediction_trees, percent, scored_pieces
from ..thresholds import Thresholds, parse_thresholds

DEFAULT_IOU = "0.50:0.95:0.05"  # mF1's grid; 0.5 is the script's own threshold
LANE_WIDTH = 30  # evaluate.py --width default
COLUMNS = ("method", "threshold", "tp", "fp", "fn", "precision", "recall", "f1")
CHUNK_FRAMES = 200
MF1_THRESHOLDS = tuple(np.linspace(0.5, 0.95, 10).tolist())


@dataclass(frozen=True)
class LlamasScore:
    rows: PlainTable
    thresholds: Thresholds
    methods: tuple[str, ...]
    n_frames: int
    stopping: dict  # where the script stops: "labels" (lanes add_ys refuses), per method "lanes" splprep refuses
    mf1s: dict  # method -> CLRNet's mF1
    warnings: tuple[str, ...] = ()

    def f1(self, method: str, label: str) -> float:
        return next(row[7] for row in self.rows.rows if row[0] == method and row[1] == label)

    def mf1(self, method: str) -> float:
        return self.mf1s[method]


def _predicted(path: Path, width: int) -> tuple[list, int]:
    """load_prediction then interpolate_lane: masks of the lanes of two points or more, and how
    many of them splprep refuses (where the script stops; here they are left out)."""
    masks, refused = [], 0
    for lane in read_culane_lines(path):  # a missing file: no lanes (the script stops: FileNotFoundError)
        if len(lane.points) < 2:
            continue
        if not np.isfinite(lane.points).all():
            raise InputError(path, "a lane holds a coordinate that is not a finite number")
        samples = interpolated(lane)
        if samples is None:
            refused += 1
            continue
        masks.append(lane_mask(samples, IMAGE_WIDTH, IMAGE_HEIGHT, width))
    return masks, refused


def _score_frames(args):
    keys, labels, pred_roots, thresholds, width = args
    counts = np.zeros((len(pred_roots), len(thresholds), 3), np.int64)
    dropped, refused = 0, np.zeros(len(pred_roots), np.int64)
    for key in keys:
        label = read_label(labels[key])
        dropped += label.dropped_above
        truth = [lane_mask(lane.points, IMAGE_WIDTH, IMAGE_HEIGHT, width) for lane in label.lanes]
        for m, root in enumerate(pred_roots):
            predicted, stopped = _predicted(prediction_path(root, key), width)
            refused[m] += stopped
            counts[m] += frame_counts(truth, predicted, thresholds)
    return counts, dropped, refused


def score_llamas(labels: str | Path, pred_root: PredictionRoots, iou: str | None = None, width: int = LANE_WIDTH,
                 out: str | Path | None = None, workers: int | None = None, progress: bool = False,
                 announce: Callable[[str], None] | None = None, strict: bool = False) -> LlamasScore:
    """Score `.lines.txt` predictions (`<recording>/<frame>.lines.txt`) against every label below
    `labels` (one split's folder of `<recording>/<frame>.json`)."""
    thresholds = parse_thresholds(iou or DEFAULT_IOU)
    check_lane_width(width)
    with _taking(out, "score llamas") as folder:
        found = every_label(Path(labels))
        keys = list(found)
        trees, warnings = find_prediction_trees(pred_root, keys, strict, announce, suffix=".lines.txt")
        roots = tuple(tree.root for tree in trees)
        chunks = [keys[i:i + CHUNK_FRAMES] for i in range(0, len(keys), CHUNK_FRAMES)]
        scored_at = tuple(thresholds.values) + MF1_THRESHOLDS
        tasks = [(chunk, {key: found[key] for key in chunk}, roots, scored_at, width) for chunk in chunks]
        pieces = scored_pieces(_score_frames, tasks, workers, progress, announce)
        counts = sum(piece[0] for piece in pieces)
        dropped = sum(piece[1] for piece in pieces)
        refused = sum(piece[2] for piece in pieces)
        rows, mf1s = [], {}
        for m, tree in enumerate(trees):
            for t, label in enumerate(thresholds.labels):
                tp, fp, fn = (int(v) for v in counts[m, t])
                rows.append((tree.method, label, tp, fp, fn, *f1_of(tp, fp, fn)))
            mean = 0.0
            for t in range(len(thresholds.values), len(scored_at)):  # llamas_metric.py: mean_f1 += f1 / 10
                mean += f1_of(*(int(v) for v in counts[m, t]))[2] / len(MF1_THRESHOLDS)
            mf1s[tree.method] = mean
        stopping = {"labels": int(dropped), **{tree.method: int(refused[m]) for m, tree in enumerate(trees)}}
        if dropped:
            warnings.append(f"warning: {dropped} labelled lanes have their valid points above row 300 only, where "
                            "evaluate.py stops (add_ys' assert): left out")
        for tree in trees:
            if stopping[tree.method]:
                warnings.append(f"warning: {tree.method}: {stopping[tree.method]} lanes that scipy's splprep "
                                "refuses, where evaluate.py stops: left out")
        score = LlamasScore(PlainTable(COLUMNS, tuple(rows)), thresholds, tuple(t.method for t in trees), len(keys),
                            stopping, mf1s, tuple(warnings))
        if folder is not None:
            staging = Staging(folder)
            staging.write_text("official.csv", score.rows.to_csv())
            staging.write_text("summary.csv", summary_rows(score).to_csv())
            staging.write_text("summary.md", summary_markdown(score, width))
            folder.commit()
    return score



def _headline(score: LlamasScore) -> list[tuple[str, Callable[[str], float]]]:
    labels = dict(zip((round(v, 2) for v in score.thresholds.values), score.thresholds.labels))
    out: list[tuple[str, Callable[[str], float]]] = []
    for value in (0.5, 0.75):
        if value in labels:
            out.append((f"F1@{labels[value]}", functools.partial(score.f1, label=labels[value])))
    out.append(("mF1", score.mf1))
    return out


def summary_rows(score: LlamasScore) -> PlainTable:
    heads = _headline(score)
    columns = ("method", *(name.lower() for name, _ in heads))
    return PlainTable(columns, tuple((method, *(f(method) for _, f in heads)) for method in score.methods))


def summary_table(score: LlamasScore) -> Table:
    """summary.csv in percent, as papers print it."""
    heads = [name for name, _ in _headline(score)]
    rows = tuple((row[0], *(percent(value) for value in row[1:])) for row in summary_rows(score).rows)
    return Table(("method", *(f"{name} (%)" for name in heads)), rows)


def summary_markdown(score: LlamasScore, width: int) -> str:
    return (f"# LLAMAS, official protocol\n\n{score.n_frames:,} labels on a {IMAGE_WIDTH}x{IMAGE_HEIGHT} canvas, lanes "
            f"{width} px wide, a match counts when IoU > the threshold (unsupervised_llamas "
            "culane_metric/evaluate.py, 9b99f46, its official discrete IoU): the labels' four lanes l1, l0, r0, r1 "
            "from its spline_creator over rows 300..716, predictions through splprep at 50 samples. mF1: CLRNet's "
            "(llamas_metric.py, 7269e9d), F1 / 10 summed over np.linspace(0.5, 0.95, 10). official.csv gives every "
            "threshold.\n\n"
            + summary_table(score).to_markdown())
