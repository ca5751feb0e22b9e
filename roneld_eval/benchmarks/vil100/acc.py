"""VIL-100's Acc, FP and FN: TuSimple's rule (a point within 20 px over the cosine of the ground
truth's slope, a lane found at 85 % of its points, at most 8 lanes a frame) in the two versions
papers print, which give different numbers for the same lanes:

- MMA-Net's evaluation/evaluate_acc.py (yujun0-0/MMA-Net 8f95908): each predicted lane is the
  degree-2 fit x(y) of its instance mask's pixels (maps.vil100_png, `InstanceMask.fits`), in
  the mask's flipped rows (y = height - row - 1), evaluated at every ground-truth point, whose y
  is flipped as height - y (:42-57, one row apart from the mask's);
- RVLD's Modeling/VIL-100/PLD/code/evaluation/evaluate_acc.py (dongkwonjin/RVLD 4d90de1): each
  predicted lane is SciPy's cubic interp1d of x over y through its points, evaluated at the
  ground-truth points within its rows (-2 elsewhere), in float32 (:36-44).

In both a frame's accuracy is the mean of its ground-truth lanes' best accuracies over at most
8 lanes (the worst dropped beyond 8, and one FN forgiven), FP = (predictions - found ground
truth) / predictions (negative where two ground-truth lanes find one prediction), FN = missed /
ground truth; a frame without ground truth scores accuracy 0. Figures are means over frames.

RVLD's script never meets a lane its interp1d(kind="cubic") refuses (two points at one y, or
fewer than four points: ValueError), because RVLD's own writer never gives it one: its
Modeling/VIL-100/PLD/code/libs/save_prediction.py (4d90de1, Save_Prediction_for_eval_acc.
get_2D_lane_points) samples each lane at distinct rows and drops a lane of 3 points or fewer
(`if len(pts) <= 3: continue`). Lane files from elsewhere are put through that rule first: a lane
keeps its first point at each y, and one left with 3 points or fewer (a blank line too) is not a
prediction, so it adds neither to FP nor, drawn at x = -2 (-100 after line_accuracy), a match
near x = 0. `AccFrame.stopping` counts the lanes the script itself would stop at (a repeated y,
or 3 points or fewer). A lane without a fit in MMA-Net's version (its polyfit raising) still
counts as a prediction and matches no point, as there the mask is the prediction.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Sequence

import numpy as np

from ...model import Lane
from ...metrics.point_accuracy import POINT_THRESHOLD, lane_threshold, line_accuracy

MAX_LANES = 8.0  # evaluate_acc.py: min(8.0, len(gt))
OUTSIDE = -2  # RVLD: x_pred where a ground-truth row lies outside the prediction's rows
# RVLD 4d90de1 libs/save_prediction.py, Save_Prediction_for_eval_acc.get_2D_lane_points:
# `if len(pts) <= 3: continue`, so its evaluate_acc.py's cubic interp1d always has 4 points
WRITTEN_MIN_POINTS = 4


@dataclass(frozen=True)
class AccFrame:
    accuracy: float
    fp: float
    fn: float
    stopping: int = 0  # predicted lanes where the script stops (see the module docstring)


def _frame(accs_per_gt: Sequence[Sequence[float]], n_pred: int, n_gt: int) -> tuple[float, float, float]:
    """calculate_results / bench after the accuracies: the same lines in both scripts."""
    line_accs = []
    fn, matched = 0.0, 0.0
    for accs in accs_per_gt:
        max_acc = np.max(accs) if len(accs) > 0 else 0.0
        if max_acc < POINT_THRESHOLD:
            fn += 1
        else:
            matched += 1
        line_accs.append(max_acc)
    fp = n_pred - matched
    if n_gt > MAX_LANES and fn > 0:
        fn -= 1
    total = sum(line_accs)
    if n_gt > MAX_LANES:
        total -= min(line_accs)
    return (float(total / max(min(MAX_LANES, n_gt), 1.0)), float(fp / n_pred if n_pred > 0 else 0.0),
            float(fn / max(min(n_gt, MAX_LANES), 1.0)))


def _ground_truth(lanes: Sequence[Lane]) -> list[Lane]:
    return [lane for lane in lanes if len(lane.points)]  # lanes of no points are skipped (both scripts)


def mmanet_frame(fits: Sequence[tuple[float, float, float] | None], truth: Sequence[Lane], height: int) -> AccFrame:
    """One frame as MMA-Net's calculate_results: `fits` from the instance mask of `height` rows."""
    lanes = _ground_truth(truth)
    gtx = [lane.xs.tolist() for lane in lanes]
    gty = [[height - y for y in lane.ys.tolist()] for lane in lanes]
    accs_per_gt = []
    for x_gts, y_gts in zip(gtx, gty):
        threshold = lane_threshold(np.array(x_gts), np.array(y_gts))
        accs = []
        for p in fits:
            if p is None:
                accs.append(0.0)
                continue
            ys = np.array(y_gts)
            x_pred = (p[0] * ys * ys + p[1] * ys + p[2]).tolist()
            accs.append(line_accuracy(np.array(x_pred), np.array(x_gts), threshold))
        accs_per_gt.append(accs)
    return AccFrame(*_frame(accs_per_gt, len(fits), len(gtx)), stopping=sum(p is None for p in fits))


def _as_written(lane: Lane) -> tuple[Lane | None, bool]:
    """(the lane as RVLD's writer could have written it: its first point at each y, in file order,
    or None where 3 points or fewer are left; whether the script would stop at the lane as given)."""
    ys, xs = lane.ys, lane.xs
    _, first = np.unique(ys, return_index=True)
    repeated = first.size < ys.size
    if repeated:
        keep = np.sort(first)
        ys, xs = ys[keep], xs[keep]
    if ys.size < WRITTEN_MIN_POINTS:
        return None, bool(ys.size) or repeated  # a blank line is no lane to the script either
    return Lane.from_xy(xs, ys), repeated


def _interpolator(lane: Lane):
    """The lane's cubic interp1d (4 points or more at distinct y), or None where the spline cannot
    be built. interp1d(kind="cubic") is make_interp_spline(k=3) of the points sorted by y (a stable
    sort) and evaluated by it: built here that way, without interp1d's copies and checks."""
    from scipy.interpolate import make_interp_spline

    order = np.argsort(lane.ys, kind="mergesort")
    try:
        with np.errstate(all="ignore"):
            return make_interp_spline(lane.ys[order], lane.xs[order], k=3, check_finite=False)
    except (ValueError, np.linalg.LinAlgError):
        return None


def rvld_frame(predictions: Sequence[Lane], truth: Sequence[Lane]) -> AccFrame:
    """One frame as RVLD's bench: `predictions` put through RVLD's writer's rule (_as_written) into
    the lanes its result pickles would hold."""
    lanes = _ground_truth(truth)
    written = [_as_written(lane) for lane in predictions]
    stopping = sum(stops for _, stops in written)
    preds: list[Lane] = []
    functions = []
    for lane, _ in written:
        if lane is None:  # not written: no prediction
            continue
        function = _interpolator(lane)
        if function is None:  # a spline numpy cannot solve: the script would stop too
            stopping += 1
            continue
        preds.append(lane)
        functions.append(function)
    accs_per_gt = []
    for lane in lanes:
        x_gts, y_gts = lane.xs, lane.ys
        threshold = lane_threshold(x_gts, y_gts)
        accs = []
        for pred, function in zip(preds, functions):
            y_min, y_max = np.min(pred.ys), np.max(pred.ys)
            check = (y_min <= y_gts) * (y_gts <= y_max)
            x_pred = np.zeros(check.shape[0], dtype=np.float32) + OUTSIDE
            x_pred[check] = function(y_gts[check])
            accs.append(line_accuracy(x_pred.astype(np.float64), x_gts, threshold))
        accs_per_gt.append(accs)
    return AccFrame(*_frame(accs_per_gt, len(preds), len(lanes)), stopping=stopping)


@dataclass(frozen=True)
class AccMeans:
    """Means over frames, as both scripts divide their sums by the number of frames."""

    accuracy: float
    fp: float
    fn: float
    frames: int
    stopping: int = 0  # lanes where the script stops (AccFrame.stopping)


def means(frames: Sequence[AccFrame]) -> AccMeans:
    total_acc, total_fp, total_fn = 0.0, 0.0, 0.0
    for frame in frames:  # in frame order, one addition at a time, as the scripts' loops
        total_acc += frame.accuracy
        total_fp += frame.fp
        total_fn += frame.fn
    n = len(frames)
    if not n:
        return AccMeans(float("nan"), float("nan"), float("nan"), 0)
    return AccMeans(total_acc / n, total_fp / n, total_fn / n, n, sum(f.stopping for f in frames))
