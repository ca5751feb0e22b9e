"""The row accuracy of the TuSimple benchmark's lane.py (LaneEval), shared by TuSimple's official
score and VIL-100's Acc (RVLD's evaluate_acc.py uses the same formula): a ground-truth lane's
threshold is 20 / cos(atan(k)), k the least-squares slope of x over y of its valid points; a
prediction meets a row when |x_pred - x_gt| is strictly below it; a lane is found at 0.85."""

from __future__ import annotations

import numpy as np

PIXEL_THRESHOLD = 20  # LaneEval.pixel_thresh
POINT_THRESHOLD = 0.85  # LaneEval.pt_thresh


def lane_slope(xs: np.ndarray, y_samples: np.ndarray) -> float:
    """The slope of x over y (least squares with intercept) over the points with x >= 0; 0 for
    fewer than two."""
    valid = xs >= 0
    xs, ys = xs[valid], y_samples[valid]
    if len(xs) <= 1:
        return 0.0
    # As sklearn's LinearRegression: centre both, then least squares (LAPACK gelsd).
    yc = ys - ys.mean()
    xc = xs - xs.mean()
    return np.linalg.lstsq(yc[:, None], xc, rcond=None)[0][0]


def lane_angle(xs: np.ndarray, y_samples: np.ndarray) -> float:
    """atan of the lane's slope (lane_slope).

    numpy's arctan and cos, as lane.py: they differ from the math module's in the last bit for
    some slopes (9 of TuSimple's 9,944 test lanes on an AVX-512 machine, where numpy has its own
    SIMD arctan and cos; none where it has not), and the threshold is compared with pixel
    distances, so one bit can decide a row.
    """
    return float(np.arctan(lane_slope(xs, y_samples)))


def lane_threshold(xs: np.ndarray, y_samples: np.ndarray) -> float:
    """The pixel distance under which a row of this ground-truth lane counts as matched."""
    return float(PIXEL_THRESHOLD / np.cos(lane_angle(xs, y_samples)))


def row_hits(preds: np.ndarray, gt: np.ndarray, threshold: float) -> np.ndarray:
    """The rows of `gt` each prediction (a row of `preds`) meets closer than `threshold`, as
    lane.py's line_accuracy counts them (a missing x, negative, stands at -100)."""
    preds = np.where(preds >= 0, preds, -100.0)
    gt = np.where(gt >= 0, gt, -100.0)
    return np.count_nonzero(np.abs(preds - gt) < threshold, axis=-1)


def line_accuracy(pred: np.ndarray, gt: np.ndarray, threshold: float) -> float:
    # lane.py sums 1.0 per row met: a whole number of rows, the same double as their count
    return float(row_hits(pred, gt, threshold) / len(gt))
