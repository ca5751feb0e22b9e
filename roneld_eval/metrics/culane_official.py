"""The official CULane protocol (SCNN tools/lane_evaluation), TP/FP/FN for every threshold at once.

Per frame: every ground-truth lane against every predicted lane at 1640x590, drawn 30 px
wide as the C++ tool draws them (float32 points, its spline for 3+ points); IoU matrix; the
tool's Kuhn-Munkres matching; a matched pair is a TP when IoU > threshold (strictly).
FP = predictions - TP, FN = ground truth - TP. A lane of fewer than 2 points counts with
IoU 0. Matching does not depend on the threshold, so storing each ground-truth lane's
matched IoU scores a whole sweep in one pass (the C++ tool needs one run per threshold).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Iterable, Mapping, Sequence

import numpy as np
import pandas as pd

from ..model import Lane
from .iou import iou_matrix, match_lanes
from .raster import LaneMask, official_mask

UNMATCHED = -np.inf


@dataclass(frozen=True, eq=False)
class CulaneFrameResult:
    """One frame's outcome: lane counts and each ground-truth lane's matched IoU (-inf if none)."""

    n_gt: int
    n_pred: int
    matched_iou: np.ndarray

    def true_positives(self, threshold: float) -> int:
        return int(np.count_nonzero(self.matched_iou > threshold))


def official_masks(lanes: Sequence[Lane], width: int, height: int, lane_width: int) -> list[LaneMask | None]:
    """Masks of a frame's lanes as the official evaluator draws them (None: < 2 points)."""
    return [official_mask(lane, width, height, lane_width) for lane in lanes]


def evaluate_culane_frame(
    gt_lanes: Sequence[Lane],
    pred_lanes: Sequence[Lane],
    width: int = 1640,
    height: int = 590,
    lane_width: int = 30,
    gt_masks: Sequence[LaneMask | None] | None = None,
    pred_masks: Sequence[LaneMask | None] | None = None,
) -> CulaneFrameResult:
    """Match one frame's predictions to its ground truth as the official evaluator does.

    Masks already drawn (official_masks of the same lanes) can be passed to save drawing.
    """
    n_gt, n_pred = len(gt_lanes), len(pred_lanes)
    if n_gt == 0 or n_pred == 0:
        return CulaneFrameResult(n_gt, n_pred, np.full(n_gt, UNMATCHED))
    if gt_masks is None:
        gt_masks = official_masks(gt_lanes, width, height, lane_width)
    if pred_masks is None:
        pred_masks = official_masks(pred_lanes, width, height, lane_width)
    similarity = iou_matrix(gt_masks, pred_masks)
    match = match_lanes(similarity)
    matched = np.full(n_gt, UNMATCHED)
    rows = np.flatnonzero(match >= 0)
    matched[rows] = similarity[rows, match[rows]]
    return CulaneFrameResult(n_gt, n_pred, matched)


@dataclass(frozen=True)
class CulaneCounts:
    """Summed counts at each threshold (arrays over thresholds)."""

    thresholds: tuple[float, ...]
    tp: np.ndarray
    fp: np.ndarray
    fn: np.ndarray
    n_frames: int


def sum_counts(results: Iterable[CulaneFrameResult], thresholds: Sequence[float]) -> CulaneCounts:
    """TP/FP/FN over frames for every threshold."""
    thresholds = tuple(float(t) for t in thresholds)
    limits = np.array(thresholds)[:, None]
    tp = np.zeros(len(thresholds), np.int64)
    n_gt = n_pred = n_frames = 0
    for result in results:
        n_frames += 1
        n_gt += result.n_gt
        n_pred += result.n_pred
        if result.matched_iou.size:
            tp += np.count_nonzero(result.matched_iou[None, :] > limits, axis=1)
    return CulaneCounts(thresholds, tp, n_pred - tp, n_gt - tp, n_frames)


def f_measure(tp: int, fp: int, fn: int) -> tuple[float, float, float]:
    """(precision, recall, F1); NaN where undefined (the C++ tool prints -1 there)."""
    precision = tp / (tp + fp) if tp + fp else float("nan")
    recall = tp / (tp + fn) if tp + fn else float("nan")
    if np.isnan(precision) or np.isnan(recall) or precision + recall == 0:
        f1 = 0.0 if (precision == 0 or recall == 0) else float("nan")
    else:
        f1 = 2 * precision * recall / (precision + recall)
    return precision, recall, f1


def category_table(
    frame_results: Mapping[str, CulaneFrameResult],
    categories: Mapping[str, frozenset[str]],
    threshold: float,
) -> pd.DataFrame:
    """Rows per category present, then `all`: category, tp, fp, fn, precision, recall, f1."""
    rows = []
    groups = [(name, [frame_results[f] for f in frame_results if f in members]) for name, members in categories.items()]
    groups.append(("all", list(frame_results.values())))
    for name, results in groups:
        counts = sum_counts(results, [threshold])
        tp, fp, fn = int(counts.tp[0]), int(counts.fp[0]), int(counts.fn[0])
        precision, recall, f1 = f_measure(tp, fp, fn)
        rows.append(dict(category=name, tp=tp, fp=fp, fn=fn, precision=precision, recall=recall, f1=f1))
    return pd.DataFrame(rows, columns=["category", "tp", "fp", "fn", "precision", "recall", "f1"])
