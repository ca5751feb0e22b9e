"""ONCE-3DLanes' official comparison, as its evaluator does it (once-3dlanes/once_3dlanes_benchmark
7582fbb, evaluation/eval_utils.py with cfg/eval.json), written out so that every count and every
printed digit comes out the same:

- at each score threshold store * 0.01 for store = 10, 15, ..., 95 (0.35000000000000003,
  0.7000000000000001 and 0.9500000000000001 among them), a prediction is kept when its score is
  above it; labelled lanes of two points or more are kept; a lane whose first point is farther
  (z) than its second is turned round;
- each lane is drawn in a top view, 0.05 m a pixel, x -10..10 m by z 0..50 m (400 x 1000 pixels):
  its points nearer than z 10 m, truncated to pixels, joined by OpenCV lines 30 pixels thick
  (OpenCV 4.5's drawing, as roneld_eval.metrics.raster draws CULane's lanes: the same pixels);
  a pair's IoU is that of their drawings (0 where both are empty);
- labelled and kept lanes are matched by the Munkres algorithm on 1 - IoU as the `munkres`
  package solves it (matching.py: the same pairs, ties included), every pair it returns tested;
- a pair is a true positive when the mean distance from 10 points along the labelled lane (at
  5%, 15%, ..., 95% of its length) to the predicted line is below 0.3 m, measured as shapely (GEOS)
  measures it: in x and y alone, z (depth) left out (`mean_distance`);
- the counts go into float32 sums, the files dealt to 10 workers in turn in the order the folders
  list them, each worker's sums added in worker order; precision, recall, F1 and the distance
  error (its sum over true positives / (tp + 1e-5)) in float32, with no guard (0/0 is nan).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Sequence

import numpy as np

from ...metrics.raster import LaneMask, mask_from_pixels
from .matching import munkres_pairs

RES = 0.05
SIDE = (-10, 10)  # side_range_l, side_range_h
FORWARD = (0, 50)  # fwd_range_l, fwd_range_h
WIDTH = int((SIDE[1] - SIDE[0]) / RES)  # zx_xmax: 400
HEIGHT = int((FORWARD[1] - FORWARD[0]) / RES)  # zx_ymax: 1000
LINE_WIDTH = 30  # lane_width_x
NEAR = 10  # only points nearer than this are drawn (written into proj_oneline_zx)
DISTANCE_TH = 0.3
STORES = tuple(range(10, 100, 5))  # score_l, score_h, score_step
THRESHOLDS = tuple(store * 0.01 for store in STORES)
LABELS = tuple(str(store / 100) for store in STORES)  # prob_thresh as printed
WORKERS = 10  # process_num: the files are dealt to them in turn, and their sums added in order
SAMPLES = np.arange(0.05, 1, 0.1)


def top_view(lane: np.ndarray) -> LaneMask:
    """Bev_Projector.proj_oneline_zx: the lane's points nearer than NEAR, to pixels (int32,
    truncated), joined by lines LINE_WIDTH thick; the drawing as a mask (its pixels and area)."""
    near = lane[lane[:, 2] < NEAR]
    with np.errstate(invalid="ignore", over="ignore"):  # far beyond the view: int32 as the evaluator casts it
        x_img = (near[:, 0] / RES).astype(np.int32)
        y_img = (-near[:, 2] / RES).astype(np.int32)
        x_img += int(SIDE[1] / RES)
        y_img += int(FORWARD[1] / RES)
    if len(x_img) < 2:
        return LaneMask.empty()
    return mask_from_pixels(x_img.astype(np.int64), y_img.astype(np.int64), LINE_WIDTH, WIDTH, HEIGHT)


def iou(a: LaneMask, b: LaneMask) -> float:
    """calc_iou of two drawings: intersection over union of their pixels, 0 when both are empty
    (the evaluator's sums of 255s give the same quotient, exactly)."""
    union = a.area + b.area - a.intersection(b)
    if union == 0:
        return 0
    return (a.area + b.area - union) / float(union)


def _segment_distance(px: float, py: float, ax: float, ay: float, bx: float, by: float) -> float:
    """GEOS' Distance::pointToSegment in x and y."""
    if ax == bx and ay == by:
        return math.sqrt((px - ax) * (px - ax) + (py - ay) * (py - ay))
    len2 = (bx - ax) * (bx - ax) + (by - ay) * (by - ay)
    r = ((px - ax) * (bx - ax) + (py - ay) * (by - ay)) / len2
    if r <= 0.0:
        return math.sqrt((px - ax) * (px - ax) + (py - ay) * (py - ay))
    if r >= 1.0:
        return math.sqrt((px - bx) * (px - bx) + (py - by) * (py - by))
    s = ((ay - py) * (bx - ax) - (ax - px) * (by - ay)) / len2
    return abs(s) * math.sqrt(len2)


def _along(line: np.ndarray, fraction: float) -> tuple[float, float]:
    """shapely's interpolate(fraction, normalized=True) in x and y: GEOS' length of the line (in x
    and y), times the fraction, then LengthLocationMap's walk to the segment it falls in and
    LinearLocation's point along it."""
    xs, ys = line[:, 0].tolist(), line[:, 1].tolist()
    lengths = [math.sqrt((xs[i] - xs[i - 1]) * (xs[i] - xs[i - 1]) + (ys[i] - ys[i - 1]) * (ys[i] - ys[i - 1]))
               for i in range(1, len(xs))]
    total = 0.0
    for length in lengths:
        total += length
    at = fraction * total
    if at <= 0.0:
        return xs[0], ys[0]
    walked = 0.0
    for i, length in enumerate(lengths):
        if walked + length > at:
            part = (at - walked) / length
            if part >= 1.0:  # LinearLocation normalises a fraction of 1 to the next vertex
                return xs[i + 1], ys[i + 1]
            if part <= 0.0:
                return xs[i], ys[i]
            return (xs[i + 1] - xs[i]) * part + xs[i], (ys[i + 1] - ys[i]) * part + ys[i]
        walked += length
    return xs[-1], ys[-1]  # beyond the line: its end


def mean_distance(gt: np.ndarray, pred: np.ndarray) -> float:
    """cal_mean_dist: the mean over SAMPLES of the distance from the point that far along the
    labelled line to the predicted line, both taken in x and y (as GEOS measures), summed in order."""
    px, py = pred[:, 0].tolist(), pred[:, 1].tolist()
    total: float = 0
    for fraction in SAMPLES:
        x, y = _along(gt, float(fraction))
        total += min(_segment_distance(x, y, px[i], py[i], px[i + 1], py[i + 1]) for i in range(len(px) - 1))
    return total / SAMPLES.shape[0]


def sorted_near_first(lane: np.ndarray) -> np.ndarray:
    """sort_lanes_z: turned round when its first point is farther than its second."""
    return lane[::-1] if lane[0, -1] > lane[1, -1] else lane


@dataclass(frozen=True)
class FrameCounts:
    """One file at each threshold: labelled lanes, predictions kept, true positives and the sum of
    their distances (each 18 long), and Munkres' pairs ((label, kept prediction, IoU, distance))."""

    gt: np.ndarray
    pred: np.ndarray
    tp: np.ndarray
    distance: np.ndarray
    pairs: tuple[tuple[tuple[int, int, float, float], ...], ...] = ()

    def stacked(self) -> np.ndarray:
        return np.stack([self.gt, self.pred, self.tp, self.distance])


def frame_counts(gt_lanes: Sequence[np.ndarray], pred_lanes: Sequence[np.ndarray],
                 scores: Sequence[float] | np.ndarray, iou_gate: float | None = None) -> FrameCounts:
    """One file as LaneEvalOneFile.eval scores it at every threshold; with `iou_gate`, a pair counts
    only when its IoU is at least that (the paper's gate, which the evaluator reads and never uses).
    Each drawing, IoU and distance is computed once, and Munkres solved once for each different
    set of predictions kept."""
    gt = [sorted_near_first(lane) for lane in gt_lanes if len(lane) >= 2]
    score = np.asarray(scores, dtype=float).reshape(len(pred_lanes))
    live = [j for j in range(len(pred_lanes)) if score[j] > THRESHOLDS[0]]
    pred = {j: sorted_near_first(pred_lanes[j]) for j in live}
    gt_views = [top_view(lane) for lane in gt]
    pred_views = {j: top_view(lane) for j, lane in pred.items()}
    ious = {(i, j): iou(gt_views[i], pred_views[j]) for i in range(len(gt)) for j in live}
    distances: dict[tuple[int, int], float] = {}
    counts = np.zeros((4, len(THRESHOLDS)))
    pairs, done = [], {}
    for t, threshold in enumerate(THRESHOLDS):
        kept = tuple(j for j in live if score[j] > threshold)
        if kept not in done:
            done[kept] = _at(kept, gt, pred, ious, distances, iou_gate)
        (tp, distance), found = done[kept]
        counts[:, t] = len(gt), len(kept), tp, distance
        pairs.append(found)
    return FrameCounts(counts[0], counts[1], counts[2], counts[3], tuple(pairs))


def _at(kept: tuple[int, ...], gt: list[np.ndarray], pred: dict[int, np.ndarray], ious: dict, distances: dict,
        iou_gate: float | None) -> tuple[tuple[int, float], tuple[tuple[int, int, float, float], ...]]:
    """cal_tp among the predictions kept: (true positives, their distances' sum) and the pairs."""
    tp, total = 0, 0  # the evaluator's ints, a float once a distance is added
    found = []
    if gt and kept:
        cost = [[1.0 - ious[i, j] for j in kept] for i in range(len(gt))]
        for row, col in munkres_pairs(cost):
            j = kept[col]
            if (row, j) not in distances:
                distances[row, j] = mean_distance(gt[row], pred[j])
            distance = distances[row, j]
            found.append((row, col, float(ious[row, j]), distance))
            if distance < DISTANCE_TH and (iou_gate is None or ious[row, j] >= iou_gate):
                total += distance
                tp += 1
    return (tp, total), tuple(found)


@dataclass(frozen=True)
class Totals:
    """The evaluator's float32 sums and numbers at each threshold."""

    gt: np.ndarray
    pred: np.ndarray
    tp: np.ndarray
    distance_sum: np.ndarray
    precision: np.ndarray
    recall: np.ndarray
    f1: np.ndarray
    distance: np.ndarray


def totals(files: np.ndarray) -> Totals:
    """From every file's counts (files, 4, 18) in the order the evaluator lists them: each
    worker's float32 sums over its files (file k goes to worker k % 10), added in worker order,
    then its float32 arithmetic."""
    sums = np.zeros((4, len(THRESHOLDS)), dtype=np.float32)
    for worker in range(WORKERS):
        own = np.zeros((4, len(THRESHOLDS)), dtype=np.float32)
        for counts in files[worker::WORKERS]:
            for k in range(4):
                own[k] += counts[k]  # as `gt_all += gt_num` adds a list: float64, then float32
        for k in range(4):
            sums[k] += own[k].tolist()  # through JSON and back: the same float32 values
    gt, pred, tp, distance = (sums[k].copy() for k in range(4))
    with np.errstate(invalid="ignore", divide="ignore"):
        precision = tp / pred
        recall = tp / gt
        f1 = 2 * precision * recall / (precision + recall)
    mean = distance.copy()
    mean /= tp + 1e-5
    return Totals(gt, pred, tp, distance, precision, recall, f1, mean)


def printed(value: np.float32 | float) -> str:
    """A number as the evaluator's table prints it: str() of the float32."""
    return str(np.float32(value))
