"""3-D lanes compared as Gen-LaneNet's evaluator compares them (tools/eval_3D_lane.py with
tools/utils.py and tools/MinCostFlow.py, 45c6cc4), which OpenLane's lane3d evaluator and
PersFormer's copy inherit: each lane resampled at 100 y positions, every pair's distance summed
over them into an integer cost, and the lanes matched at minimum total cost by a min-cost flow.
The benchmarks differ in what a pair's distance is where a lane is unseen (`PairRule`), and in
which lanes they keep before this; they keep that in their own folders.

- a lane is resampled at y = 3, 4, ..., 102 m by scipy's interp1d (linear, extrapolated:
  `resample`, its `_call_linear` written out); a sample is visible when its x is in [-10, 10], its
  y within the lane's y range and within 5 m of it;
- at a sample, a pair's distance is the x-z Euclidean distance where both see it, 1.5 m where one
  does, and the rule's distance where neither does; its cost is their sum cast to an integer;
- lanes are matched by the min-cost flow MinCostFlow.SolveMinCostFlow builds, solved by OR-Tools'
  SimpleMinCostFlow as the evaluators solve it where OR-Tools is installed (it alone decides which of
  several equally cheap matchings is taken: 9.3 and 9.15 take the same), else by
  `scipy.optimize.linear_sum_assignment` (the same total cost, and the same pairs wherever no other
  matching costs as little).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

X_MIN, X_MAX = -10, 10  # top_view_region, as integers
Y_SAMPLES = np.linspace(3, 103, num=100, endpoint=False)
DIST_TH = 1.5
RATIO_TH = 0.75
CLOSE_RANGE = 40
CLOSE_INDEX = int(np.where(Y_SAMPLES > CLOSE_RANGE)[0][0])
MATCH_LIMIT = DIST_TH * Y_SAMPLES.shape[0]  # a match's cost must be below it


@dataclass(frozen=True)
class PairRule:
    """What an evaluator makes of samples a pair does not both see: the distance where neither lane
    sees a sample (`both_unseen`), the x/z error of a part (near or far) no sample of which both see
    (`no_error`), and whether a cost between 0 and 1 is made 1 (`small_cost_is_one`)."""

    both_unseen: float
    no_error: float
    small_cost_is_one: bool


def overlaps_samples(lane: np.ndarray) -> bool:
    """Whether a lane's first point lies before the last sample and its last beyond the first, as
    listed (not sorted): the evaluators keep only such lanes."""
    return bool(lane[0, 1] < Y_SAMPLES[-1] and lane[-1, 1] > Y_SAMPLES[0])


def in_range(lane: np.ndarray, x_min: float, x_max: float) -> np.ndarray:
    """utils.prune_3d_lane_by_range: the points of 0 < y < 200 and x_min < x < x_max."""
    lane = lane[np.logical_and(lane[:, 1] > 0, lane[:, 1] < 200), ...]
    return lane[np.logical_and(lane[:, 0] > x_min, lane[:, 0] < x_max), ...]


def linear(x: np.ndarray, y: np.ndarray, at: np.ndarray) -> np.ndarray:
    """scipy's interp1d(x, y, fill_value="extrapolate")(at), linear, written out (its `_call_linear`,
    the same operations): x sorted stably, each point's interval by np.searchsorted (left), the
    first or last one beyond the ends."""
    order = np.argsort(x, kind="mergesort")  # interp1d sorts its x (assume_sorted=False)
    xs, ys = x[order], y[order]
    index = np.searchsorted(xs, at).clip(1, len(xs) - 1).astype(int)
    lo, hi = index - 1, index
    with np.errstate(divide="ignore", invalid="ignore"):  # equal x: inf and NaN, as interp1d gives them
        return (ys[hi] - ys[lo]) / (xs[hi] - xs[lo]) * (at - xs[lo]) + ys[lo]


def resample(lane: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """x and z at Y_SAMPLES, and whether each sample lies within 5 m of the lane's y range
    (utils.resample_laneline_in_y with out_vis, its interp1d's linear extrapolation written out)."""
    y_min = np.min(lane[:, 1]) - 5
    y_max = np.max(lane[:, 1]) + 5
    if lane.shape[1] < 3:
        lane = np.concatenate([lane, np.zeros([lane.shape[0], 1], dtype=np.float32)], axis=1)
    x_values, z_values = linear(lane[:, 1], lane[:, 0], Y_SAMPLES), linear(lane[:, 1], lane[:, 2], Y_SAMPLES)
    inside = np.logical_and(Y_SAMPLES >= y_min, Y_SAMPLES <= y_max)
    return x_values, z_values, inside.astype(np.float32) + 1e-9


SAMPLED_AT_ONCE = 4_000_000  # lanes x points x samples compared at once in `sampled` (4 MB of booleans)


def sampled(lanes: list[np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
    """Each lane (N x 3, or N x 2, at least two points) at Y_SAMPLES, as (lanes, 100, (x, z)), and
    its visibility (lanes, 100): x in the range, y within the lane's own range and near it. The
    lanes of a frame are resampled together (`resample`'s operations on every lane at once: the
    same bits), a block of them at a time."""
    points, visibility = np.zeros((len(lanes), 100, 2)), np.zeros((len(lanes), 100))
    start = 0
    while start < len(lanes):
        stop, longest = start, 0
        while stop < len(lanes) and max(longest, len(lanes[stop])) * (stop + 1 - start) * 100 <= SAMPLED_AT_ONCE:
            longest = max(longest, len(lanes[stop]))
            stop += 1
        stop = max(stop, start + 1)  # one lane of more points than the block holds: alone
        points[start:stop], visibility[start:stop] = _sampled_block(lanes[start:stop])
        start = stop
    return points, visibility


def _sampled_block(lanes: list[np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
    """`sampled` of a few lanes at once: their points padded with y = inf (sorted last, never below a
    sample), sorted by y as interp1d sorts them, each sample's interval found by counting the points
    below it (np.searchsorted's left side), then interp1d's linear formula on every lane alike."""
    count = np.array([len(lane) for lane in lanes])
    ys = np.full((len(lanes), count.max()), np.inf)
    xs, zs = np.zeros(ys.shape), np.zeros(ys.shape)
    for i, lane in enumerate(lanes):
        ys[i, :count[i]], xs[i, :count[i]] = lane[:, 1], lane[:, 0]
        if lane.shape[1] > 2:
            zs[i, :count[i]] = lane[:, 2]
    rows = np.arange(len(lanes))[:, None]
    order = np.argsort(ys, axis=1, kind="mergesort")
    ys, xs, zs = ys[rows, order], xs[rows, order], zs[rows, order]
    below = np.sum(ys[:, :, None] < Y_SAMPLES[None, None, :], axis=1)
    hi = np.minimum(np.maximum(below, 1), (count - 1)[:, None])
    lo = hi - 1
    y_lo, y_hi = ys[rows, lo], ys[rows, hi]
    with np.errstate(divide="ignore", invalid="ignore"):  # equal y: inf and NaN, as interp1d gives them
        x_values = (xs[rows, hi] - xs[rows, lo]) / (y_hi - y_lo) * (Y_SAMPLES - y_lo) + xs[rows, lo]
        z_values = (zs[rows, hi] - zs[rows, lo]) / (y_hi - y_lo) * (Y_SAMPLES - y_lo) + zs[rows, lo]
    min_y, max_y = ys[:, :1], ys[rows, (count - 1)[:, None]]
    near = np.logical_and(Y_SAMPLES >= min_y - 5, Y_SAMPLES <= max_y + 5).astype(np.float32) + 1e-9
    visible = np.logical_and(x_values >= X_MIN, np.logical_and(
        x_values <= X_MAX, np.logical_and(Y_SAMPLES >= min_y, Y_SAMPLES <= max_y)))
    return np.stack([x_values, z_values], axis=-1), np.logical_and(visible, near).astype(float)


PAIRS_AT_ONCE = 20000  # pairs whose 100 samples are held at once (some 100 MB of arrays)


def pair_distances(gt: np.ndarray, pred: np.ndarray, gt_visible: np.ndarray, pred_visible: np.ndarray,
                   rule: PairRule) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Every (ground truth, prediction) pair, from the lanes at Y_SAMPLES (lanes x 100 x (x, z)) and
    their visibility: the samples both see within the distance, the integer cost, and the errors x
    near, x far, z near, z far (`rule.no_error` where no sample of that part is seen by both). Rows
    of ground truth a block at a time, so that a frame of many lanes stays in memory; a ValueError
    where a cost is beyond the evaluator's integers (its min-cost flow then runs without end)."""
    rows = max(1, PAIRS_AT_ONCE // max(1, len(pred)))
    blocks = [_pair_block(gt[i:i + rows], pred, gt_visible[i:i + rows], pred_visible, rule)
              for i in range(0, len(gt), rows)] or [_pair_block(gt, pred, gt_visible, pred_visible, rule)]
    return tuple(np.concatenate([block[k] for block in blocks]) for k in range(3))  # type: ignore[return-value]


def _pair_block(gt: np.ndarray, pred: np.ndarray, gt_visible: np.ndarray, pred_visible: np.ndarray,
                rule: PairRule) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
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
        euclidean[both_invisible] = rule.both_unseen
        euclidean[other] = DIST_TH
        # a count, whichever way the evaluator writes it: samples both see within the distance
        matches = np.sum(np.logical_and(both_visible, euclidean < DIST_TH), axis=-1).astype(float)
        total = np.sum(euclidean, axis=-1)
        if not (total < 2.0 ** 62).all():  # inf, NaN or past int64: astype(int) would give nonsense
            raise ValueError("a lane lies so far off that its distance to another is beyond the evaluator's integer "
                             "cost (a coordinate of 1e17 m or more?)")
        cost = total.astype(int)
        if rule.small_cost_is_one:
            cost = np.where(np.logical_and(total < 1, total > 0), 1, cost)
        errors = _means(np.stack([x_dist, z_dist], axis=-2), both_visible, rule.no_error)
    return matches, cost, errors


def _means(dist: np.ndarray, both_visible: np.ndarray, no_error: float) -> np.ndarray:
    """Each pair's mean x and z distance over the samples both lanes see, near (y <= 40 m) and
    far: (..., 4) as x near, x far, z near, z far (`no_error` where a part has none). Each mean
    sums its own samples as a row, as the evaluator's np.sum of that part does: the same bits."""
    seen = both_visible[..., None, :]
    weighted = dist * seen  # (..., 2, 100): x, z
    parts = []
    for part in (slice(None, CLOSE_INDEX), slice(CLOSE_INDEX, None)):
        count = np.sum(both_visible[..., part], axis=-1)[..., None]
        summed = np.sum(np.ascontiguousarray(weighted[..., part]), axis=-1)
        parts.append(np.where(count > 0, summed / np.maximum(count, 1), no_error))
    near, far = parts
    return np.stack([near[..., 0], far[..., 0], near[..., 1], far[..., 1]], axis=-1)


def flow_solver():
    """OR-Tools' SimpleMinCostFlow where it is installed (the evaluators' own matcher), else None."""
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


NO_ORTOOLS_WARNING = ("warning: OR-Tools is not installed, so lanes are matched by scipy at the same total cost; "
                      "where another matching costs as little, the evaluator's min-cost flow may take that one "
                      "(pip install ortools to match as it does)")


def matching(cost: np.ndarray) -> list[tuple[int, int]]:
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
