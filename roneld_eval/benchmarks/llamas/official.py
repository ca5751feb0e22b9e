"""LLAMAS's F1, as its culane_metric/evaluate.py computes it (karstenBehrendt/unsupervised_llamas
9b99f46), on the official path (`discrete`, not its `--unofficial` shapely one):

- a predicted lane of fewer than two points is dropped when read (load_prediction); the rest lose
  their consecutive repeated points and are interpolated by scipy's splprep (s=0, degree
  min(3, points - 1)) sampled at 50 parameter values in all (interpolate_lane);
- every lane, predicted or labelled (datasets.llamas), is truncated to integers and drawn with
  cv2.line 30 px wide on a 1276x717 canvas (draw_lane); IoU = |A & B| / |A | B| (discrete_cross_iou);
- a frame: no predictions gives (0, 0, ground truth), no ground truth (0, predictions, 0); else
  scipy's linear_sum_assignment on 1 - IoU and a TP for an assigned pair with IoU > the threshold
  (culane_metric); P, R and F from TP, FP, FN summed over frames, all 0 when TP is 0.

Where the script stops, here: a lane splprep refuses (all its points one point) is left out and
counted (interpolated gives None); a pair of lanes both wholly outside the image (IoU 0 / 0) has
IoU 0.
"""

from __future__ import annotations

from typing import Sequence

import numpy as np

from ...model import Lane
from ...metrics.line_masks import LaneMask, drawn_mask, intersection

SAMPLES = 50  # interpolate_lane(n=50): t=n and 50 samples of u
LANE_WIDTH = 30


def _without_consecutive_repeats(lane: Lane) -> list[tuple[float, float]]:
    points: list[tuple[float, float]] = []
    for point in ((float(x), float(y)) for x, y in lane.points):
        if points and points[-1] == point:
            continue
        points.append(point)
    return points


def interpolated(lane: Lane) -> np.ndarray | None:
    """interpolate_lane: (50, 2) samples, or None where scipy's splprep refuses the lane (the
    script stops there)."""
    from scipy.interpolate import splev, splprep

    points = _without_consecutive_repeats(lane)
    xs, ys = [x for x, _ in points], [y for _, y in points]
    try:
        with np.errstate(all="ignore"):
            tck, _ = splprep([xs, ys], s=0, t=SAMPLES, k=min(3, len(points) - 1))
            return np.array(splev(np.linspace(0.0, 1.0, SAMPLES), tck)).T
    except (ValueError, TypeError, SystemError, np.linalg.LinAlgError):
        return None


def lane_mask(points: np.ndarray, width: int, height: int, thickness: int = LANE_WIDTH) -> LaneMask:
    """draw_lane: the points truncated to integers (astype(np.int32)), joined by cv2.line."""
    return drawn_mask(np.asarray(points, np.float64).astype(np.int32), width, height, thickness)


def iou_matrix(predicted: Sequence[LaneMask], truth: Sequence[LaneMask]) -> np.ndarray:
    """discrete_cross_iou: (predicted, truth) IoUs, 0 for a pair both wholly outside the image
    (0 / 0, where the script's assignment stops: "matrix contains invalid numeric entries")."""
    ious = np.zeros((len(predicted), len(truth)))
    with np.errstate(invalid="ignore", divide="ignore"):
        for i, a in enumerate(predicted):
            for j, b in enumerate(truth):
                inter = intersection(a, b)
                ious[i, j] = np.float64(inter) / np.float64(a.area + b.area - inter)
    return np.nan_to_num(ious, nan=0.0)


def matched_ious(ious: np.ndarray) -> np.ndarray:
    """culane_metric's assignment: the IoUs of the pairs linear_sum_assignment gives on 1 - IoU
    (none when either side has no lanes)."""
    from scipy.optimize import linear_sum_assignment

    if 0 in ious.shape:
        return np.zeros(0)
    rows, columns = linear_sum_assignment(1 - ious)
    return ious[rows, columns]


def matched_lanes(ious: np.ndarray) -> np.ndarray:
    """matched_ious' assignment as each ground-truth lane's prediction (-1 for none), from the same
    (predicted, truth) IoUs: what the lane error types need (metrics.lane_errors)."""
    from scipy.optimize import linear_sum_assignment

    match = np.full(ious.shape[1], -1, np.int64)
    if 0 not in ious.shape:
        rows, columns = linear_sum_assignment(1 - ious)
        match[columns] = rows
    return match


def counts_at(matched: np.ndarray, n_pred: int, n_gt: int, thresholds: Sequence[float]) -> np.ndarray:
    """(thresholds, 3): TP, FP, FN at each threshold, a TP an assigned pair with IoU > it."""
    out = np.zeros((len(thresholds), 3), np.int64)
    for t, threshold in enumerate(thresholds):
        tp = int((matched > threshold).sum())
        out[t] = (tp, n_pred - tp, n_gt - tp)
    return out


def frame_counts(truth: Sequence[LaneMask], predicted: Sequence[LaneMask], thresholds: Sequence[float]) -> np.ndarray:
    """(thresholds, 3): TP, FP, FN of one frame at each threshold (culane_metric)."""
    return counts_at(matched_ious(iou_matrix(predicted, truth)), len(predicted), len(truth), thresholds)


def f1_of(tp: int, fp: int, fn: int) -> tuple[float, float, float]:
    """eval_predictions' precision, recall and F1 (all 0 when TP is 0)."""
    if tp == 0:
        return 0.0, 0.0, 0.0
    precision = float(tp) / (tp + fp)
    recall = float(tp) / (tp + fn)
    return precision, recall, 2 * precision * recall / (precision + recall)
