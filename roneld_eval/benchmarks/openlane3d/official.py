"""OpenLane 3D's official per-frame comparison, as OpenLane's lane3d evaluator does it
(OpenDriveLab/OpenLane 8a0ce6b, eval/LANE_evaluation/lane3d/eval_3D_lane.py `LaneEval.bench` and
utils/utils.py; PersFormer's utils/eval_3D_lane.py is the same code), written in NumPy with the same
operations in the same order, so every count and every digit it prints comes out the same:

- ground truth in camera coordinates goes to the ground frame by the label's extrinsic, as
  `bench_one_submit` rebuilds it (`ground_truth_lanes`), and keeps its points of visibility > 0;
- a lane is kept when its first point lies before y 102 and its last beyond y 3 (as listed, not
  sorted), then cut to 0 < y < 200 and -10 < x < 10, and dropped with fewer than two points;
- each lane is resampled at y = 3, 4, ..., 102 m by scipy's interp1d (linear, extrapolated:
  `resample`, its `_call_linear` written out); a sample is visible when its x is in [-10, 10], its y
  within the lane's y range and within 5 m of it; a lane of fewer than two visible samples goes;
- each pair's distance at a sample is the x-z Euclidean distance, 0 where both are invisible and
  1.5 where one is; its cost is their sum, cast to an integer (1 where it is between 0 and 1);
- lanes are matched at minimum total cost by the same min-cost flow, solved by OR-Tools'
  SimpleMinCostFlow as the evaluator solves it where OR-Tools is installed (it alone decides which
  of several equally cheap matchings is taken: 9.3 and 9.15 take the same), else by
  `scipy.optimize.linear_sum_assignment` (the same total cost, and the same pairs wherever no other
  matching costs as little); a match counts when its cost is below 150;
- a matched ground-truth lane is recalled, and a matched prediction precise, when at least 75% of
  its own visible samples lie within 1.5 m; its category is right when equal, or a prediction of
  20 on a lane of 21; its x and z errors near (y <= 40 m) and far are the means over the samples
  both see (-1 where there is none: left out of the averages).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Sequence

import numpy as np

X_MIN, X_MAX = -10, 10  # top_view_region, as integers
Y_SAMPLES = np.linspace(3, 103, num=100, endpoint=False)
DIST_TH = 1.5
RATIO_TH = 0.75
CLOSE_RANGE = 40
CLOSE_INDEX = int(np.where(Y_SAMPLES > CLOSE_RANGE)[0][0])
MATCH_LIMIT = DIST_TH * Y_SAMPLES.shape[0]  # a match's cost must be below it

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


def resample(lane: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """x and z at Y_SAMPLES, and whether each sample lies within 5 m of the lane's y range
    (utils.resample_laneline_in_y with out_vis, its interp1d's linear extrapolation written out)."""
    y_min = np.min(lane[:, 1]) - 5
    y_max = np.max(lane[:, 1]) + 5
    if lane.shape[1] < 3:
        lane = np.concatenate([lane, np.zeros([lane.shape[0], 1], dtype=np.float32)], axis=1)
    order = np.argsort(lane[:, 1], kind="mergesort")  # interp1d sorts its x (assume_sorted=False)
    ys, xs, zs = lane[order, 1], lane[order, 0], lane[order, 2]
    index = np.searchsorted(ys, Y_SAMPLES).clip(1, len(ys) - 1).astype(int)
    lo, hi = index - 1, index
    with np.errstate(divide="ignore", invalid="ignore"):  # equal y: inf and NaN, as interp1d gives them
        x_values = (xs[hi] - xs[lo]) / (ys[hi] - ys[lo]) * (Y_SAMPLES - ys[lo]) + xs[lo]
        z_values = (zs[hi] - zs[lo]) / (ys[hi] - ys[lo]) * (Y_SAMPLES - ys[lo]) + zs[lo]
    inside = np.logical_and(Y_SAMPLES >= y_min, Y_SAMPLES <= y_max)
    return x_values, z_values, inside.astype(np.float32) + 1e-9


def _kept(lanes: list[np.ndarray], categories: list) -> tuple[list[np.ndarray], list]:
    """The lanes overlapping the sampled range (first point before the last sample, last beyond
    the first), cut to the x range, with at least two points left."""
    overlapping = [k for k, lane in enumerate(lanes) if lane[0, 1] < Y_SAMPLES[-1] and lane[-1, 1] > Y_SAMPLES[0]]
    cut = [_in_range(lanes[k]) for k in overlapping]
    kept = [k for k, lane in enumerate(cut) if lane.shape[0] > 1]
    return [cut[k] for k in kept], [categories[overlapping[k]] for k in kept]


def _in_range(lane: np.ndarray) -> np.ndarray:
    """utils.prune_3d_lane_by_range."""
    lane = lane[np.logical_and(lane[:, 1] > 0, lane[:, 1] < 200), ...]
    return lane[np.logical_and(lane[:, 0] > X_MIN, lane[:, 0] < X_MAX), ...]


def _sampled(lanes: list[np.ndarray], categories: list) -> tuple[list[np.ndarray], list, np.ndarray]:
    """Each lane at Y_SAMPLES (x, z), its visibility matrix, those of at least two visible samples."""
    sampled, visibility = [], np.zeros((len(lanes), 100))
    for i, lane in enumerate(lanes):
        min_y, max_y = np.min(lane[:, 1]), np.max(lane[:, 1])
        x_values, z_values, visibility_vec = resample(lane)
        sampled.append(np.vstack([x_values, z_values]).T)
        visibility[i, :] = np.logical_and(x_values >= X_MIN, np.logical_and(
            x_values <= X_MAX, np.logical_and(Y_SAMPLES >= min_y, Y_SAMPLES <= max_y)))
        visibility[i, :] = np.logical_and(visibility[i, :], visibility_vec)
    keep = np.sum(visibility, axis=-1) > 1
    return ([lane for lane, kept in zip(sampled, keep) if kept], [c for c, kept in zip(categories, keep) if kept],
            visibility[keep, :])


def frame_counts(pred_lanes: list[np.ndarray], pred_category: Sequence[int | float], gt_lanes: list[np.ndarray],
                 gt_visibility: Sequence[np.ndarray], gt_category: Sequence[int | float]) -> FrameCounts:
    """One frame as `LaneEval.bench` scores it (ground truth already in the ground frame)."""
    seen = [lane[np.asarray(visible) > 0, ...] for lane, visible in zip(gt_lanes, gt_visibility)]
    pred, pred_category = _kept(pred_lanes, list(pred_category))
    gt, gt_category = _kept([lane for lane in seen if lane.shape[0] > 1],
                            [gt_category[k] for k, lane in enumerate(seen) if lane.shape[0] > 1])
    gt, gt_category, gt_visible = _sampled(gt, gt_category)
    pred, pred_category, pred_visible = _sampled(pred, pred_category)
    cnt_gt, cnt_pred = len(gt), len(pred)
    num_match, cost, errors = pair_distances(np.array(gt).reshape(cnt_gt, 100, 2),
                                             np.array(pred).reshape(cnt_pred, 100, 2), gt_visible, pred_visible)
    pairs = _matching(cost)
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


PAIRS_AT_ONCE = 20000  # pairs whose 100 samples are held at once (some 100 MB of arrays)


def pair_distances(gt: np.ndarray, pred: np.ndarray, gt_visible: np.ndarray, pred_visible: np.ndarray
                   ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Every (ground truth, prediction) pair, from the lanes at Y_SAMPLES (lanes x 100 x (x, z)) and
    their visibility: samples within the distance minus those neither sees, the integer cost, and
    the errors x near, x far, z near, z far (-1 where no sample of that part is seen by both). Rows
    of ground truth a block at a time, so that a frame of many lanes stays in memory; a ValueError
    where a cost is beyond the evaluator's integers (its min-cost flow then runs without end)."""
    rows = max(1, PAIRS_AT_ONCE // max(1, len(pred)))
    blocks = [_pair_block(gt[i:i + rows], pred, gt_visible[i:i + rows], pred_visible)
              for i in range(0, len(gt), rows)] or [_pair_block(gt, pred, gt_visible, pred_visible)]
    return tuple(np.concatenate([block[k] for block in blocks]) for k in range(3))  # type: ignore[return-value]


def _pair_block(gt: np.ndarray, pred: np.ndarray, gt_visible: np.ndarray, pred_visible: np.ndarray
                ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """pair_distances of some rows. Each sum runs over a pair's own samples, a row of the last axis,
    which NumPy adds in the order np.sum adds the evaluator's one pair (pairwise, in blocks of
    eight): the same bits."""
    x_dist = np.abs(gt[:, None, :, 0] - pred[None, :, :, 0])
    z_dist = np.abs(gt[:, None, :, 1] - pred[None, :, :, 1])
    seen_gt, seen_pred = gt_visible[:, None, :], pred_visible[None, :, :]
    both_visible = np.logical_and(seen_gt >= 0.5, seen_pred >= 0.5)
    both_invisible = np.logical_and(seen_gt < 0.5, seen_pred < 0.5)
    other = np.logical_not(np.logical_or(both_visible, both_invisible))
    with np.errstate(invalid="ignore", over="ignore"):  # an extrapolated inf or NaN, as the evaluator meets it
        euclidean = np.sqrt(x_dist ** 2 + z_dist ** 2)
        euclidean[both_invisible] = 0
        euclidean[other] = DIST_TH
        matches = (np.sum(euclidean < DIST_TH, axis=-1) - np.sum(both_invisible, axis=-1)).astype(float)
        total = np.sum(euclidean, axis=-1)
        if not (total < 2.0 ** 62).all():  # inf, NaN or past int64: astype(int) would give nonsense
            raise ValueError("a lane lies so far off that its distance to another is beyond the evaluator's integer "
                             "cost (a coordinate of 1e17 m or more?)")
        cost = np.where(np.logical_and(total < 1, total > 0), 1, total.astype(int))
        near, far = slice(None, CLOSE_INDEX), slice(CLOSE_INDEX, None)
        errors = np.stack([_means(x_dist, both_visible, near), _means(x_dist, both_visible, far),
                           _means(z_dist, both_visible, near), _means(z_dist, both_visible, far)], axis=-1)
    return matches, cost, errors


def _means(dist: np.ndarray, both_visible: np.ndarray, part: slice) -> np.ndarray:
    seen = np.sum(both_visible[..., part], axis=-1)
    summed = np.sum(dist[..., part] * both_visible[..., part], axis=-1)
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(seen > 0, summed / np.maximum(seen, 1), -1.0)


def flow_solver():
    """OR-Tools' SimpleMinCostFlow where it is installed (the evaluator's own matcher), else None."""
    try:
        from ortools.graph.python import min_cost_flow
    except ImportError:
        return None
    return min_cost_flow.SimpleMinCostFlow


def matcher() -> str:
    """What matches lanes here, as the tables name it."""
    if flow_solver() is None:
        return ("scipy's linear_sum_assignment (OR-Tools not installed: the same total cost, but where "
                "another matching costs as little it may pick that one)")
    import ortools

    return f"OR-Tools {ortools.__version__} SimpleMinCostFlow, the evaluator's matcher"


def _matching(cost: np.ndarray) -> list[tuple[int, int]]:
    """The pairs of a minimum-cost matching of min(rows, columns) pairs, in ground-truth order (the
    min-cost flow's arcs are listed so): the min-cost flow MinCostFlow.SolveMinCostFlow builds,
    solved by OR-Tools where it is installed (so that of several matchings of equal cost the same
    one is taken), else an assignment of the same total cost."""
    if cost.size == 0:
        return []
    solver = flow_solver()
    if solver is None:
        from scipy.optimize import linear_sum_assignment

        rows, columns = linear_sum_assignment(cost)
        return sorted(zip(rows.tolist(), columns.tolist()))
    return _min_cost_flow(solver(), cost)


def _min_cost_flow(flow, cost: np.ndarray) -> list[tuple[int, int]]:
    """The graph and supplies of MinCostFlow.SolveMinCostFlow (every pair adjacent): source 0,
    ground-truth lanes 1..n, predictions n+1..n+m, sink n+m+1, arcs added in its order."""
    n, m = cost.shape
    sink = n + m + 1
    for i in range(n):
        flow.add_arc_with_capacity_and_unit_cost(0, i + 1, 1, 0)
    for i in range(n):
        for j in range(m):
            flow.add_arc_with_capacity_and_unit_cost(i + 1, n + 1 + j, 1, int(cost[i, j]))
    for j in range(m):
        flow.add_arc_with_capacity_and_unit_cost(n + 1 + j, sink, 1, 0)
    supply = min(n, m)
    flow.set_node_supply(0, supply)
    flow.set_node_supply(sink, -supply)
    if flow.solve() != flow.OPTIMAL:  # the evaluator prints a line and matches nothing
        return []
    return [(flow.tail(arc) - 1, flow.head(arc) - n - 1) for arc in range(n, n + n * m) if flow.flow(arc) > 0]


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
