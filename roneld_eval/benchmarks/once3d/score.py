"""`score once3d`: ONCE-3DLanes predictions scored as its evaluator scores them
(once-3dlanes/once_3dlanes_benchmark 7582fbb, evaluation/eval_utils.py, cfg/eval.json): F1,
precision, recall and the distance error at each score threshold 0.10, 0.15, ..., 0.95, from every
frame's counts (official.py). With `iou_gate`, a labelled opt-in: a pair also needs that top-view
IoU, as the paper describes and the evaluator reads from its config without using.

official.csv has a row per method and threshold: the float32 sums the evaluator adds (labelled
lanes, predictions kept, true positives, their distances) and its four numbers; summary.md prints
them as it prints them (str() of each float32), the 0.95 row marked as the one PersFormer reported.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Callable, Sequence

import numpy as np

from ...errors import ConfigError
from ...scoring import (PlainTable, PredictionRoots, _taking, find_prediction_trees, scored_pieces, stopping_gaps,
                        write_texts)
from ...shards import Merged, Sharding, given_options
from .official import LABELS, THRESHOLDS, frame_counts, printed, totals
from .reader import listed_frames, read_prediction, read_truth

COLUMNS = ("method", "threshold", "score_above", "gt_lanes", "pred_lanes", "tp", "distance_sum", "f1", "precision",
           "recall", "distance_error")
REPORTED = "0.95"  # PersFormer's ONCE-3DLanes numbers are of this row (PersFormer#65)
CHUNK_FRAMES = 200
KERNELS = ("topview",)  # the top views are drawn by numba kernels (metrics.raster)


@dataclass(frozen=True)
class Once3dScore:
    rows: PlainTable
    methods: tuple[str, ...]
    n_frames: int
    iou_gate: float | None = None
    warnings: tuple[str, ...] = ()

    def describe(self) -> str:
        if self.iou_gate is None:
            return "as coded: no IoU gate (the evaluator reads iou_thresh and never uses it)"
        return (f"--iou-gate {self.iou_gate:g}: a pair also needs a top-view IoU of at least {self.iou_gate:g} (the "
                "paper's gate; NOT the official evaluator, which has none)")

    def value(self, method: str, column: str, threshold: str = REPORTED):
        at = COLUMNS.index(column)
        return next(row[at] for row in self.rows.rows if row[0] == method and row[1] == threshold)


def _path(root: Path, relpath: str) -> Path:
    return Path(root) / relpath


def _score_frames(args) -> np.ndarray:
    """(frames, methods, 4, 18) counts of a chunk: labelled lanes, kept predictions, true positives,
    distance sums at each threshold."""
    relpaths, labels, roots, iou_gate = args
    counts = np.zeros((len(relpaths), len(roots), 4, len(THRESHOLDS)))
    for f, relpath in enumerate(relpaths):
        truth = read_truth(_path(labels, relpath))
        for m, root in enumerate(roots):
            lanes, scores = read_prediction(_path(root, relpath))
            counts[f, m] = frame_counts(truth, lanes, scores, iou_gate).stacked()
    return counts


def score_once3d(labels: str | Path, pred_root: PredictionRoots, iou_gate: float | None = None,
                 out: str | Path | None = None, workers: int | None = None, progress: bool = False,
                 announce: Callable[[str], None] | None = None, strict: bool = False, shard: str | None = None,
                 merged: Merged | None = None) -> Once3dScore | None:
    """Score ONCE-3DLanes prediction trees mirroring `labels` (`<segment>/cam01/<frame>.json`) as
    its evaluator does; `iou_gate`: also require that top-view IoU of a pair (not the evaluator's
    rule; labelled). With `shard` ('I/N'), only that share of the segments, written as a part to
    `out` (None is returned)."""
    if iou_gate is not None and not (isinstance(iou_gate, (int, float)) and 0.0 <= iou_gate <= 1.0):
        raise ConfigError(f"--iou-gate {iou_gate!r} must be an IoU, from 0 to 1")
    sharding = Sharding("score once3d", shard, out, merged, dict(
        labels=labels, pred_root=pred_root, strict=strict, **given_options(iou_gate=iou_gate)), paths=("labels",))
    labels = Path(labels)
    with _taking(out, "score once3d", reads=(labels,)) as folder:
        relpaths = listed_frames(labels, out)
        trees, warnings = find_prediction_trees(pred_root, relpaths, strict, announce, suffix=".json")
        warnings += stopping_gaps(trees, "labelled frames")
        label_files = [_path(labels, relpath) for relpath in relpaths]

        def files_of(m: int, relpath: str) -> tuple[Path]:
            return (_path(trees[m].root, relpath),)

        segment = _segment_of
        if merged is not None:
            sharding.check_merged(relpaths, trees, label_files, segment, files_of=files_of)
            counts = sharding.merged_array("cat_counts", (len(relpaths), len(trees), 4, len(THRESHOLDS)), kind="f",
                                           within=(0, 1e12))
        else:
            scored = sharding.share(relpaths, segment)
            counts = _scored(scored, labels, trees, iou_gate, workers, progress, announce)
            if sharding.shard is not None:
                assert folder is not None
                sharding.write_part(folder, relpaths, trees, label_files, scored, {"cat_counts": counts},
                                    files_of=files_of)
                return None
        score = Once3dScore(_table(trees, counts), tuple(tree.method for tree in trees), len(relpaths), iou_gate,
                            tuple(warnings))
        write_texts(folder, {"official.csv": score.rows.to_csv(), "summary.md": summary_markdown(score)})
    return score


def _segment_of(relpath: str) -> str:
    return relpath.split("/", 1)[0]


def _scored(scored: Sequence[str], labels: Path, trees, iou_gate, workers, progress, announce) -> np.ndarray:
    chunks = [scored[i:i + CHUNK_FRAMES] for i in range(0, len(scored), CHUNK_FRAMES)]
    roots = tuple(tree.root for tree in trees)
    pieces = scored_pieces(_score_frames, [(chunk, labels, roots, iou_gate) for chunk in chunks], workers,
                           progress, announce, kernel_groups=KERNELS, trees=trees)
    if not pieces:
        return np.zeros((0, len(trees), 4, len(THRESHOLDS)))
    return np.concatenate(pieces)


def _table(trees, counts: np.ndarray) -> PlainTable:
    """A row per method and threshold, from every frame's counts in the evaluator's order."""
    rows = []
    for m, tree in enumerate(trees):
        total = totals(counts[:, m])
        for t, label in enumerate(LABELS):
            rows.append((tree.method, label, THRESHOLDS[t], int(total.gt[t]), int(total.pred[t]), int(total.tp[t]),
                         float(total.distance_sum[t]), float(total.f1[t]), float(total.precision[t]),
                         float(total.recall[t]), float(total.distance[t])))
    return PlainTable(COLUMNS, tuple(rows))


def summary_table(score: Once3dScore, method: str) -> str:
    lines = ["| prob_thresh | F1 | precision | recall | D error |", "|---|---|---|---|---|"]
    for row in score.rows.rows:
        if row[0] == method:
            mark = " (PersFormer's)" if row[1] == REPORTED else ""
            lines.append(f"| {row[1]}{mark} | " + " | ".join(printed(v) for v in row[7:]) + " |")
    return "\n".join(lines)


def summary_markdown(score: Once3dScore) -> str:
    parts = [f"# ONCE-3DLanes, official protocol\n\n{score.n_frames:,} frames, scored as ONCE-3DLanes' evaluator "
             f"(evaluation/eval_utils.py, once_3dlanes_benchmark 7582fbb; {score.describe()}). At each threshold a "
             "prediction is kept when its score is above it; pairs by Munkres on the top-view IoU (z < 10 m); a true "
             "positive when the mean x-y distance of 10 points of the labelled lane to the predicted one is below "
             "0.3 m (depth is not measured). Printed as the evaluator prints them (float32).\n"]
    for method in score.methods:
        parts.append(f"\n## {method}\n\n{summary_table(score, method)}\n")
    return "".join(parts) + "".join(f"\n{line}\n" for line in score.warnings)

