"""IoU of lane masks and the official CULane one-to-one matching. No thresholds here."""

from __future__ import annotations

from typing import Sequence

import numpy as np

from .. import _numba_cache  # noqa: F401  (numba imported first, a signal deferred meanwhile)
from ._kernels import run_overlap
from .raster import LaneMask

# SCNN lane_evaluation hungarianGraph.hpp: an edge is tight when |lw + rw - w| < 1e-2.
KM_TOLERANCE = 1e-2


def mask_iou(a: LaneMask, b: LaneMask) -> float:
    """Intersection over union of two masks; NaN when both are empty (0/0, as the C++ tool)."""
    inter = a.intersection(b)
    union = a.area + b.area - inter
    return inter / union if union else float("nan")


def iou_matrix(gt: Sequence[LaneMask | None], pred: Sequence[LaneMask | None]) -> np.ndarray:
    """(len(gt), len(pred)) IoUs; a lane of fewer than 2 points (None) has IoU 0 with anything."""
    out = np.zeros((len(gt), len(pred)), np.float64)
    for i, a in enumerate(gt):
        if a is None:
            continue
        for j, b in enumerate(pred):
            if b is None:
                continue
            if a.lo is not None and b.lo is not None:  # mask_iou, the two calls before the kernel saved
                inter = int(run_overlap(a.y0, a.lo, a.hi, b.y0, b.lo, b.hi)) if a.area and b.area else 0
                union = a.area + b.area - inter
                out[i, j] = inter / union if union else float("nan")
            else:
                out[i, j] = mask_iou(a, b)
    return out


def match_lanes(similarity: np.ndarray) -> np.ndarray:
    """For each row (ground-truth lane), the column (prediction) it is matched to, or -1.

    The official evaluator's Kuhn-Munkres (maximum total IoU), step for step: rows and
    columns swap when there are more rows, edges count as tight within 1e-2, and NaN IoUs
    (two empty masks) never match. Scipy's exact assignment can pick another matching among
    near-ties, which changes TP counts; the official one is reproduced instead. Scoring runs it
    as _kernels.matched_ious (one kernel call a frame); this is that kernel's reference.
    """
    rows, columns = similarity.shape
    if rows == 0 or columns == 0:
        return np.full(rows, -1, np.int64)
    swapped = rows > columns
    matrix = (similarity.T if swapped else similarity).tolist()
    n_left, n_right = len(matrix), len(matrix[0])
    left_match = [-1] * n_left
    right_match = [-1] * n_right
    right_weight = [0.0] * n_right
    left_weight = []
    for row in matrix:
        best = -1e5
        for value in row:
            if best < value:
                best = value
        left_weight.append(best)
    left_used = [False] * n_left
    right_used = [False] * n_right

    def augment(u: int) -> bool:
        left_used[u] = True
        row = matrix[u]
        for v in range(n_right):
            if not right_used[v] and abs(left_weight[u] + right_weight[v] - row[v]) < KM_TOLERANCE:
                right_used[v] = True
                if right_match[v] == -1 or augment(right_match[v]):
                    right_match[v] = u
                    left_match[u] = v
                    return True
        return False

    for u in range(n_left):
        while True:
            for i in range(n_left):
                left_used[i] = False
            for j in range(n_right):
                right_used[j] = False
            if augment(u):
                break
            d = 1e10
            for i in range(n_left):
                if left_used[i]:
                    for j in range(n_right):
                        if not right_used[j]:
                            slack = left_weight[i] + right_weight[j] - matrix[i][j]
                            if slack < d:
                                d = slack
            if d == 1e10:
                return _rows_view(left_match, right_match, swapped, rows)
            for i in range(n_left):
                if left_used[i]:
                    left_weight[i] -= d
            for j in range(n_right):
                if right_used[j]:
                    right_weight[j] += d
    return _rows_view(left_match, right_match, swapped, rows)


def _rows_view(left_match, right_match, swapped: bool, rows: int) -> np.ndarray:
    return np.array(right_match if swapped else left_match, np.int64).reshape(rows)
