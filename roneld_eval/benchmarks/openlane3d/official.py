"""OpenLane 3D's official per-frame comparison, as OpenLane's lane3d evaluator does it
(OpenDriveLab/OpenLane 8a0ce6b, eval/LANE_evaluation/lane3d/eval_3D_lane.py `LaneEval.bench` and
utils/utils.py; PersFormer's utils/eval_3D_lane.py is the same code), written in NumPy with the same
operations in the same order, so every count and every digit it prints comes out the same:

- ground truth in camera coordinates goes to the ground frame by the label's extrinsic, as
  `bench_one_submit` rebuilds it (`ground_truth_lanes`), and keeps its points of visibility > 0;
- a lane is kept when its first point lies before y 102 and its last beyond y 3 (as listed, not
  sorted), then cut to 0 < y < 200 and -10 < x < 10, and dropped with fewer than two points;
- each lane is resampled at y = 3, 4, ..., 102 m and its samples' visibility found as Gen-LaneNet's
  evaluator, their common ancestor, does it (roneld_eval.metrics.lane3d_flow); a lane of fewer than
  two visible samples goes;
- each pair's distance at a sample is the x-z Euclidean distance, 0 where both are invisible and
  1.5 where one is; its cost is their sum, cast to an integer (1 where it is between 0 and 1);
- lanes are matched at minimum total cost by the same min-cost flow (lane3d_flow.matching); a match
  counts when its cost is below 150;
- a matched ground-truth lane is recalled, and a matched prediction precise, when at least 75% of
  its own visible samples lie within 1.5 m; its category is right when equal, or a prediction of
  20 on a lane of 21; its x and z errors near (y <= 40 m) and far are the means over the samples
  both see (-1 where there is none: left out of the averages).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Sequence

import numpy as np

from ...metrics.lane3d_flow import (MATCH_LIMIT, RATIO_TH, X_MAX, X_MIN, PairRule, in_range, matching,
                                    overlaps_samples, pair_distances, sampled)

# the lane3d evaluator: where neither lane sees a sample, no distance; a part no sample of which both see has
# no error (-1, left out of the averages); a cost between 0 and 1 is 1
PAIR_RULE = PairRule(both_unseen=0.0, no_error=-1.0, small_cost_is_one=True)

# bench_one_submit's change of axes: vehicle to ground, ground to camera, camera representation
_R_VG = np.array([[0, 1, 0], [-1, 0, 0], [0, 0, 1]], dtype=float)
_R_GC = np.array([[1, 0, 0], [0, 0, 1], [0, -1, 0]], dtype=float)
_CAMERA_REPRESENTATION = np.linalg.inv(np.array([[0, 0, 1, 0], [-1, 0, 0, 0], [0, -1, 0, 0], [0, 0, 0, 1]],
                                                dtype=float))


@dataclass(frozen=True)
class FrameCounts:
    """What `bench` returns for a frame: lanes recalled (r), precise (p), of the right category
    (c), ground-truth and predicted lanes kept, matches counted, and each counted match's x error
    near, x far, z near, z far (a row a match, in ground-truth order)."""

    r_lane: int
    p_lane: int
    c_lane: int
    cnt_gt: int
    cnt_pred: int
    match_num: int
    errors: np.ndarray  # (matches, 4)
    pairs: tuple[tuple[int, int, int], ...] = ()  # the matching: (ground truth, prediction, cost), counted or not

    def counts(self) -> tuple[int, int, int, int, int, int]:
        return self.r_lane, self.p_lane, self.c_lane, self.cnt_gt, self.cnt_pred, self.match_num


def ground_truth_lanes(extrinsic: np.ndarray, lanes_xyz: Sequence[np.ndarray]) -> list[np.ndarray]:
    """The label's lanes (each 3 x N, camera coordinates) in the ground frame, N x 3, as
    bench_one_submit computes them from the label's extrinsic."""
    cam_extrinsics = np.array(extrinsic, dtype=float)
    cam_extrinsics[:3, :3] = np.matmul(np.matmul(np.matmul(np.linalg.inv(_R_VG), cam_extrinsics[:3, :3]), _R_VG),
                                       _R_GC)
    cam_extrinsics[0:2, 3] = 0.0
    out = []
    for xyz in lanes_xyz:
        lane = np.vstack((xyz, np.ones((1, xyz.shape[1]))))
        lane = np.matmul(cam_extrinsics, np.matmul(_CAMERA_REPRESENTATION, lane))
        out.append(lane[0:3, :].T)
    return out


def _kept(lanes: list[np.ndarray], categories: list) -> tuple[list[np.ndarray], list]:
    """The lanes overlapping the sampled range (first point before the last sample, last beyond
    the first), cut to the x range, with at least two points left."""
    overlapping = [k for k, lane in enumerate(lanes) if overlaps_samples(lane)]
    cut = [in_range(lanes[k], X_MIN, X_MAX) for k in overlapping]
    kept = [k for k, lane in enumerate(cut) if lane.shape[0] > 1]
    return [cut[k] for k in kept], [categories[overlapping[k]] for k in kept]


def _sampled(lanes: list[np.ndarray], categories: list) -> tuple[np.ndarray, list, np.ndarray]:
    """Each lane at Y_SAMPLES (x, z), its visibility matrix, those of at least two visible samples."""
    points, visibility = sampled(lanes)
    keep = np.sum(visibility, axis=-1) > 1
    return points[keep], [c for c, kept in zip(categories, keep) if kept], visibility[keep, :]


def frame_counts(pred_lanes: list[np.ndarray], pred_category: Sequence[int | float], gt_lanes: list[np.ndarray],
                 gt_visibility: Sequence[np.ndarray], gt_category: Sequence[int | float]) -> FrameCounts:
    """One frame as `LaneEval.bench` scores it (ground truth already in the ground frame)."""
    seen = [lane[np.asarray(visible) > 0, ...] for lane, visible in zip(gt_lanes, gt_visibility)]
    pred_kept, pred_category = _kept(pred_lanes, list(pred_category))
    gt_kept, gt_category = _kept([lane for lane in seen if lane.shape[0] > 1],
                                 [gt_category[k] for k, lane in enumerate(seen) if lane.shape[0] > 1])
    gt, gt_category, gt_visible = _sampled(gt_kept, gt_category)
    pred, pred_category, pred_visible = _sampled(pred_kept, pred_category)
    cnt_gt, cnt_pred = len(gt), len(pred)
    num_match, cost, errors = pair_distances(gt, pred, gt_visible, pred_visible, PAIR_RULE)
    pairs = matching(cost)
    counted = [(i, j) for i, j in pairs if cost[i, j] < MATCH_LIMIT]
    recalled = sum(num_match[i, j] / np.sum(gt_visible[i, :]) >= RATIO_TH for i, j in counted)
    precise = sum(num_match[i, j] / np.sum(pred_visible[j, :]) >= RATIO_TH for i, j in counted)
    return FrameCounts(int(recalled), int(precise), _right_categories(counted, gt_category, pred_category), cnt_gt,
                       cnt_pred, len(counted),
                       np.array([errors[i, j] for i, j in counted], dtype=float).reshape(len(counted), 4),
                       tuple((i, j, int(cost[i, j])) for i, j in pairs))


def _right_categories(counted: list[tuple[int, int]], gt_category: list, pred_category: list) -> int:
    """Counted matches of the same category, or of a prediction of 20 on a lane of 21 (its rule)."""
    return sum(pred_category[j] == gt_category[i] or (pred_category[j] == 20 and gt_category[i] == 21)
               for i, j in counted)


def totals(stats: np.ndarray, errors: np.ndarray) -> list[float]:
    """bench_one_submit's output_stats from every frame's counts (frames x 6, in list order) and
    every counted match's errors (matches x 4, in the same order): F, recall, precision, category
    accuracy, x error near and far, z error near and far, then the six sums."""
    sums = [np.sum(stats[:, k]) for k in range(6)]

    def ratio(numerator, denominator):
        return numerator / denominator if denominator != 0 else numerator / (denominator + 1e-6)

    recall, precision, category = ratio(sums[0], sums[3]), ratio(sums[1], sums[4]), ratio(sums[2], sums[5])
    f_lane = (2 * recall * precision / (recall + precision) if recall + precision != 0
              else 2 * recall * precision / (recall + precision + 1e-6))
    averages = []
    with np.errstate(invalid="ignore", divide="ignore"):
        for k in range(4):
            column = errors[:, k]
            chosen = column[column > -1 + 1e-6]
            averages.append(float(np.average(chosen)) if chosen.size else float("nan"))
    return [float(f_lane), float(recall), float(precision), float(category), *averages, *(float(s) for s in sums)]
