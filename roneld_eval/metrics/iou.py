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
    km = _KuhnMunkres((similarity.T if swapped else similarity).tolist())
    for u in range(km.n_left):
        if not km.match(u):
            break  # no edge can ever be tight for u: the matching stays as it is (the C++ returns here)
    return _rows_view(km.left_match, km.right_match, swapped, rows)


class _KuhnMunkres:
    """The C++ evaluator's KM state over a matrix with no more rows (left) than columns
    (right): labels (weights), matches, and the marks of one augmenting search."""

    def __init__(self, matrix: list[list[float]]):
        self.matrix = matrix
        self.n_left, self.n_right = len(matrix), len(matrix[0])
        self.left_match = [-1] * self.n_left
        self.right_match = [-1] * self.n_right
        self.right_weight = [0.0] * self.n_right
        self.left_weight = []
        for row in matrix:
            best = -1e5
            for value in row:
                if best < value:
                    best = value
            self.left_weight.append(best)
        self.left_used = [False] * self.n_left
        self.right_used = [False] * self.n_right

    def match(self, u: int) -> bool:
        """Match row u, relabelling until an augmenting path is tight; False where no slack is
        left to relabel by (the official loop then stops the whole matching)."""
        while True:
            self.left_used = [False] * self.n_left
            self.right_used = [False] * self.n_right
            if self.augment(u):
                return True
            d = self.least_slack()
            if d == 1e10:
                return False
            for i in range(self.n_left):
                if self.left_used[i]:
                    self.left_weight[i] -= d
            for j in range(self.n_right):
                if self.right_used[j]:
                    self.right_weight[j] += d

    def augment(self, u: int) -> bool:
        self.left_used[u] = True
        row = self.matrix[u]
        for v in range(self.n_right):
            if not self.right_used[v] and abs(self.left_weight[u] + self.right_weight[v] - row[v]) < KM_TOLERANCE:
                self.right_used[v] = True
                if self.right_match[v] == -1 or self.augment(self.right_match[v]):
                    self.right_match[v] = u
                    self.left_match[u] = v
                    return True
        return False

    def least_slack(self) -> float:
        """The least slack between a row the search reached and a column it did not (1e10: none)."""
        d = 1e10
        for i in range(self.n_left):
            if self.left_used[i]:
                for j in range(self.n_right):
                    if not self.right_used[j]:
                        slack = self.left_weight[i] + self.right_weight[j] - self.matrix[i][j]
                        if slack < d:
                            d = slack
        return d


def _rows_view(left_match, right_match, swapped: bool, rows: int) -> np.ndarray:
    return np.array(right_match if swapped else left_match, np.int64).reshape(rows)
