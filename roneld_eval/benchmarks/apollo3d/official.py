"""Apollo 3D Synthetic's official comparison, as Gen-LaneNet's evaluator does it
(yuliangguo/Pytorch_Generalized_3D_Lane_Detection 45c6cc4, tools/eval_3D_lane.py `LaneEval`, run as
its `__main__` runs it), in NumPy with the same operations in the same order, so that every count
and every digit it prints comes out the same:

- ground truth keeps its points of visibility > 0 and lanes of two points or more, then the lanes
  whose first point lies before y 102 and last beyond y 3 (as listed), cut to 0 < y < 200 and
  -30 < x < 30 (three times the x range), again of two points or more; predictions are all kept;
- lanes are resampled, their samples' visibility found, and matched by the min-cost flow of
  roneld_eval.metrics.lane3d_flow; where a lane does not see a sample the pair's distance there is
  1.5 m, whichever lane it is, and a part (near or far) no sample of which both see has the error
  1.5; a match counts when its cost is below 150;
- a counted match's ground-truth lane is recalled, and its prediction precise, when at least 75% of
  its own visible samples lie within 1.5 m (a lane of no visible sample is neither: 0/0);
- `bench_one_submit_varying_probs` keeps the predictions of probability above each of
  np.linspace(0.05, 0.95, 19) (several a hair below their decimal: 0.49999999999999994, so that a
  probability of exactly 0.5 passes "0.5"); recall, precision and F = 2RP / (R + P + 1e-6) at each,
  from sums over frames with 1e-6 added to each denominator; AP is the mean over recall 0.05, 0.10,
  ..., 0.95 of the precision interpolated (scipy's interp1d, lane3d_flow.linear) along the curve with (1, 0) and (0, 1)
  added at its ends; the threshold of the highest lane-line F (the first of equals) is chosen on the
  test set, and the centre lines are read at that same threshold;
- `bench_one_submit` at that threshold gives F, recall and precision again and the x/z errors near
  (y <= 40 m) and far: np.average over every counted match, frames in prediction-file order.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Sequence

import numpy as np

from ...metrics.lane3d_flow import (DIST_TH, MATCH_LIMIT, RATIO_TH, X_MAX, X_MIN, PairRule, in_range, linear,
                                    matching, overlaps_samples, pair_distances, sampled)

PAIR_RULE = PairRule(both_unseen=DIST_TH, no_error=DIST_TH, small_cost_is_one=False)
THRESHOLDS = np.linspace(0.05, 0.95, 19)  # varying_th
RECALLS = np.linspace(0.05, 0.95, 19)  # r_range, where AP reads the precision
LANE_TYPES = ("laneline", "centerline")
COUNTS = ("recalled", "precise", "gt_lanes", "pred_lanes", "matches")


@dataclass(frozen=True)
class FrameSweep:
    """One frame of one lane type at each threshold: the five counts (recalled, precise, ground-truth
    lanes, predictions kept, matches counted), each counted match's errors (x near, x far, z near,
    z far, in ground-truth order) and the matching (ground truth, prediction among those kept, cost)."""

    counts: np.ndarray  # (19, 5)
    errors: tuple[np.ndarray, ...]  # 19 arrays of (matches, 4)
    pairs: tuple[tuple[tuple[int, int, int], ...], ...]


def truth_kept(lanes: Sequence[np.ndarray], visibility: Sequence[np.ndarray]) -> list[np.ndarray]:
    """The labelled lanes the evaluator compares (its gt_lanes after the pruning in `bench`)."""
    seen = [lane[np.asarray(visible) > 0, ...] for lane, visible in zip(lanes, visibility)]
    seen = [lane for lane in seen if lane.shape[0] > 1]
    cut = [in_range(lane, 3 * X_MIN, 3 * X_MAX) for lane in seen if overlaps_samples(lane)]
    return [lane for lane in cut if lane.shape[0] > 1]


def frame_sweep(pred_lanes: Sequence[np.ndarray], probabilities: Sequence[float] | np.ndarray,
                gt_lanes: Sequence[np.ndarray], gt_visibility: Sequence[np.ndarray]) -> FrameSweep:
    """One frame at every threshold. Each lane is resampled and every pair measured once; the
    evaluator's matching at a threshold is that of the same costs among the predictions kept, so
    only the matching is solved again (once for each different set of predictions kept)."""
    scores = np.asarray(probabilities, dtype=float).reshape(len(pred_lanes))
    live = np.flatnonzero(scores > THRESHOLDS[0])  # the others are never compared (nor need two points)
    scores = scores[live]
    truth = truth_kept(gt_lanes, gt_visibility)
    points, visible = sampled(truth + [pred_lanes[int(j)] for j in live])  # one pass over every lane
    n = len(truth)
    num_match, cost, errors = pair_distances(points[:n], points[n:], visible[:n], visible[n:], PAIR_RULE)
    gt_seen, pred_seen = np.sum(visible[:n], axis=1), np.sum(visible[n:], axis=1)
    counts = np.zeros((len(THRESHOLDS), len(COUNTS)))
    found: list[np.ndarray] = []
    pairs: list[tuple[tuple[int, int, int], ...]] = []
    done: dict[bytes, tuple] = {}
    for t, above in enumerate(scores[None, :] > THRESHOLDS[:, None]):
        key = above.tobytes()
        if key not in done:
            done[key] = _at(np.flatnonzero(above), num_match, cost, errors, gt_seen, pred_seen)
        counts[t], matched, pairs_t = done[key]
        found.append(matched)
        pairs.append(pairs_t)
    return FrameSweep(counts, tuple(found), tuple(pairs))


def _at(kept: np.ndarray, num_match: np.ndarray, cost: np.ndarray, errors: np.ndarray, gt_seen: np.ndarray,
        pred_seen: np.ndarray) -> tuple[np.ndarray, np.ndarray, tuple[tuple[int, int, int], ...]]:
    """The counts, counted matches' errors and matching among the predictions `kept`."""
    chosen = cost[:, kept]
    pairs = matching(chosen)
    counted = [(i, int(kept[j])) for i, j in pairs if chosen[i, j] < MATCH_LIMIT]
    with np.errstate(invalid="ignore", divide="ignore"):  # a lane of no visible sample: 0/0, never enough
        recalled = sum(bool(num_match[i, j] / gt_seen[i] >= RATIO_TH) for i, j in counted)
        precise = sum(bool(num_match[i, j] / pred_seen[j] >= RATIO_TH) for i, j in counted)
    row = np.array([recalled, precise, len(gt_seen), len(kept), len(counted)], dtype=float)
    matched = np.array([errors[i, j] for i, j in counted], dtype=float).reshape(len(counted), 4)
    return row, matched, tuple((i, j, int(chosen[i, j])) for i, j in pairs)


@dataclass(frozen=True)
class Totals:
    """What the evaluator's `__main__` computes for one lane type: the recall, precision and F of
    the sweep, its AP, and at the chosen threshold F, recall, precision and the four mean errors."""

    recall: np.ndarray  # (19,)
    precision: np.ndarray
    f: np.ndarray
    ap: float
    best: int  # the index of the chosen threshold
    at_best: tuple[float, float, float]  # F, recall, precision as bench_one_submit gives them
    errors: tuple[float, float, float, float]  # x near, x far, z near, z far


def sweep_curve(counts: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Recall, precision and F at each threshold from every frame's counts (frames, 19, 5)."""
    recall = np.sum(counts[:, :, 0], axis=0) / (np.sum(counts[:, :, 2], axis=0) + 1e-6)
    precision = np.sum(counts[:, :, 1], axis=0) / (np.sum(counts[:, :, 3], axis=0) + 1e-6)
    return recall, precision, 2 * recall * precision / (recall + precision + 1e-6)


def average_precision(recall: np.ndarray, precision: np.ndarray) -> float:
    """bench_one_submit_varying_probs' AP: the precision interpolated along the curve, with (1, 0)
    and (0, 1) at its ends, averaged over RECALLS."""
    return float(np.mean(linear(np.array([1.0] + recall.tolist() + [0.0]), np.array([0.0] + precision.tolist() + [1.0]),
                                RECALLS)))


def chosen_threshold(counts: np.ndarray) -> int:
    """The index of the threshold of the highest F (the first of equals) over every frame's lane-line
    counts (frames, 19, 5): where `__main__` reads both lane types."""
    return int(np.argmax(sweep_curve(counts)[2]))


def totals(counts: np.ndarray, errors: np.ndarray, chosen: int) -> Totals:
    """One lane type's numbers from every frame's counts (frames, 19, 5) and the counted matches'
    errors at the chosen threshold's index (matches, 4), frames in prediction-file order."""
    recall, precision, f = sweep_curve(counts)
    at = counts[:, chosen, :]
    r_lane = np.sum(at[:, 0]) / (np.sum(at[:, 2]) + 1e-6)
    p_lane = np.sum(at[:, 1]) / (np.sum(at[:, 3]) + 1e-6)
    f_lane = 2 * r_lane * p_lane / (r_lane + p_lane + 1e-6)
    with np.errstate(invalid="ignore", divide="ignore"):  # no match at all: nan, as np.average of nothing gives
        means = tuple(float(np.average(errors[:, k])) if len(errors) else float("nan") for k in range(4))
    return Totals(recall, precision, f, average_precision(recall, precision), chosen,
                  (float(f_lane), float(r_lane), float(p_lane)), means)  # type: ignore[arg-type]


def printed_line(title: str, total: Totals) -> str:
    """The evaluator's line for one lane type: AP, F, x near, x far, z near, z far, each `{:.3}`."""
    return "{}:  {:.3}  {:.3}  {:.3}  {:.3}  {:.3}  {:.3}".format(title, total.ap, total.at_best[0], *total.errors)
