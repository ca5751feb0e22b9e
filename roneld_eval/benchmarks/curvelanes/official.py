"""CurveLanes' F1 as the field computes it: CondLaneNet's tools/condlanenet/lane_metric.py
(aliyun/conditional-lane-detection c57b242; the same as vega's LaneMetricCore), there being no
official tool. Per image: every lane scaled to a 224x224 grid (x and y by the image's own width and
height), resampled by that file's natural cubic spline over chord length (end moments 0) every unit
of the parameter plus its last point, truncated to integers and drawn with cv2.line 5 px wide; IoU
from the two drawings; scipy's linear_sum_assignment on 1 - IoU; a matched pair with IoU > 0.5 is a
hit. Precision, recall and F1 from hits and lanes summed over images, each denominator plus
sys.float_info.epsilon.

The spline's arithmetic follows that file operation for operation (float64, numpy's sqrt), so the
same points are drawn. Where it would divide by zero (two equal consecutive points) its drawing
stops on a NaN; such a lane is refused here with its file named.
"""

from __future__ import annotations

import sys
from typing import Sequence

import numpy as np

EVAL_SIZE = 224  # test_curvelanes.py: eval_width, eval_height
LANE_WIDTH = 5
IOU_THRESHOLD = 0.5
EPSILON = sys.float_info.epsilon

Point = tuple[float, float]


def _segments(points: Sequence[Point]) -> list[tuple]:
    """(a_x, b_x, c_x, d_x, a_y, b_y, c_y, d_y, h) per interval, as lane_metric.calc_params."""
    n = len(points)
    if n == 2:
        (x0, y0), (x1, y1) = points
        h0 = np.sqrt((x0 - x1) * (x0 - x1) + (y0 - y1) * (y0 - y1))
        return [(x0, (x1 - x0) / h0, 0, 0, y0, (y1 - y0) / h0, 0, 0, h0)]
    h = []
    for i in range(n - 1):
        dx = points[i][0] - points[i + 1][0]
        dy = points[i][1] - points[i + 1][1]
        h.append(np.sqrt(dx * dx + dy * dy))
    c, d_x, d_y = [], [], []
    for i in range(n - 2):
        a, b, c_i = h[i], 2 * (h[i] + h[i + 1]), h[i + 1]
        tmpx = 6 * ((points[i + 2][0] - points[i + 1][0]) / h[i + 1] - (points[i + 1][0] - points[i][0]) / h[i])
        tmpy = 6 * ((points[i + 2][1] - points[i + 1][1]) / h[i + 1] - (points[i + 1][1] - points[i][1]) / h[i])
        if i == 0:
            c.append(c_i / b)
            d_x.append(tmpx / b)
            d_y.append(tmpy / b)
        else:
            base = b - a * c[i - 1]
            c.append(c_i / base)
            d_x.append((tmpx - a * d_x[i - 1]) / base)
            d_y.append((tmpy - a * d_y[i - 1]) / base)
    mx, my = np.zeros(n), np.zeros(n)
    mx[n - 2], my[n - 2] = d_x[n - 3], d_y[n - 3]
    for i in range(n - 4, -1, -1):
        mx[i + 1] = d_x[i] - c[i] * mx[i + 2]
        my[i + 1] = d_y[i] - c[i] * my[i + 2]
    mx[0] = mx[-1] = my[0] = my[-1] = 0
    out = []
    for i in range(n - 1):
        (x0, y0), (x1, y1) = points[i], points[i + 1]
        out.append((x0, (x1 - x0) / h[i] - (2 * h[i] * mx[i] + h[i] * mx[i + 1]) / 6, mx[i] / 2,
                    (mx[i + 1] - mx[i]) / (6 * h[i]),
                    y0, (y1 - y0) / h[i] - (2 * h[i] * my[i] + h[i] * my[i + 1]) / 6, my[i] / 2,
                    (my[i + 1] - my[i]) / (6 * h[i]), h[i]))
    return out


def resampled(points: Sequence[Point]) -> list[Point]:
    """lane_metric.spline_interp(step_t=1): each interval at t = 0, 1, ... < h, then the last point."""
    if len(points) < 2:
        return list(points)
    out = []
    for a_x, b_x, c_x, d_x, a_y, b_y, c_y, d_y, h in _segments(points):
        t = 0
        while t < h:
            out.append((a_x + b_x * t + c_x * t * t + d_x * t * t * t, a_y + b_y * t + c_y * t * t + d_y * t * t * t))
            t += 1
    out.append(points[-1])
    return out


def scaled(points: Sequence[Point], width: int, height: int) -> list[Point]:
    """lane_metric.resize_lane: divided by the image's size over the 224x224 grid."""
    x_ratio, y_ratio = np.true_divide(width, EVAL_SIZE), np.true_divide(height, EVAL_SIZE)
    return [(float(x) / x_ratio, float(y) / y_ratio) for x, y in points]


def drawing(points: Sequence[Point]) -> np.ndarray:
    import cv2

    canvas = np.zeros((EVAL_SIZE, EVAL_SIZE), np.uint8)
    drawn = resampled(points)
    for (x0, y0), (x1, y1) in zip(drawn[:-1], drawn[1:]):
        cv2.line(canvas, (int(x0), int(y0)), (int(x1), int(y1)), 255, LANE_WIDTH)
    return canvas


def iou(first: np.ndarray, second: np.ndarray) -> float:
    union = int(np.count_nonzero(first | second))
    if union == 0:
        return 0
    inter = int(np.count_nonzero(first)) + int(np.count_nonzero(second)) - union
    return (255 * inter) / float(255 * union)  # the file's sums of 255s


def iou_matrix(truth: Sequence[Sequence[Point]], predicted: Sequence[Sequence[Point]], width: int,
               height: int) -> np.ndarray:
    """IoU of every ground-truth lane with every predicted lane of one image (image pixels)."""
    gt = [drawing(scaled(lane, width, height)) for lane in truth]
    pr = [drawing(scaled(lane, width, height)) for lane in predicted]
    matrix = np.zeros((len(gt), len(pr)))
    for i, a in enumerate(gt):
        for j, b in enumerate(pr):
            matrix[i][j] = iou(a, b)
    return matrix


def hits(matrix: np.ndarray) -> int:
    """Hits of one image from its IoU matrix (predictions already filtered by score), as evaluate_core."""
    from scipy.optimize import linear_sum_assignment

    if matrix.size == 0:
        return 0
    rows, columns = linear_sum_assignment(1 - np.array(matrix))
    return sum(1 for r, c in zip(rows, columns) if matrix[r][c] > IOU_THRESHOLD)


def matched_lanes(matrix: np.ndarray) -> np.ndarray:
    """hits' assignment as each ground-truth lane's prediction (-1 for none), from the same
    (truth, predicted) IoUs: what the lane error types need (metrics.lane_errors)."""
    from scipy.optimize import linear_sum_assignment

    match = np.full(matrix.shape[0], -1, np.int64)
    if matrix.size:
        rows, columns = linear_sum_assignment(1 - np.array(matrix))
        match[rows] = columns
    return match


def f_measure(hits: int, predicted: int, truth: int) -> tuple[float, float, float]:
    """LaneMetricCore.summary: (precision, recall, F1) with its epsilon guards."""
    precision = hits / (predicted + EPSILON)
    recall = hits / (truth + EPSILON)
    return precision, recall, 2 * precision * recall / (precision + recall + EPSILON)


def has_zero_step(points: Sequence[Point], width: int, height: int) -> bool:
    """Two equal consecutive points once scaled: the spline divides by zero there."""
    grid = scaled(points, width, height)
    return len(grid) >= 2 and any(a == b for a, b in zip(grid[:-1], grid[1:]))
