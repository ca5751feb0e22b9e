"""The official matching: the maximum-weight assignment of lanes by IoU (SCNN lane_evaluation's hungarian)."""

from __future__ import annotations


import numpy as np

from ..._numba_cache import cached_njit


# ---- the official matching -----------------------------------------------------------------


@cached_njit(nogil=True)
def _augment(u, matrix, left_weight, right_weight, left_used, right_used, left_match, right_match, tolerance):
    """iou.match_lanes' augment(u): a depth-first search for an augmenting path on tight edges."""
    left_used[u] = True
    for v in range(matrix.shape[1]):
        if not right_used[v] and abs(left_weight[u] + right_weight[v] - matrix[u, v]) < tolerance:
            right_used[v] = True
            if right_match[v] == -1 or _augment(right_match[v], matrix, left_weight, right_weight, left_used,
                                                right_used, left_match, right_match, tolerance):
                right_match[v] = u
                left_match[u] = v
                return True
    return False


@cached_njit(nogil=True)
def matched_ious(similarity, rows, columns, tolerance):
    """Each row's matched IoU (-inf where unmatched) under the official Kuhn-Munkres matching of
    similarity[rows][:, columns] (ground truth x predictions): iou.match_lanes step for step."""
    match = matched_columns(similarity, rows, columns, tolerance)
    out = np.full(rows.size, -np.inf)
    for i in range(rows.size):
        if match[i] >= 0:
            out[i] = similarity[rows[i], match[i]]
    return out


@cached_njit(nogil=True)
def matched_columns(similarity, rows, columns, tolerance):
    """The column of `similarity` (a member of `columns`) each of `rows` is matched to, -1 where
    none, under the official Kuhn-Munkres matching of similarity[rows][:, columns]."""
    n_rows = rows.size
    n_columns = columns.size
    out = np.full(n_rows, -1, np.int64)
    if n_rows == 0 or n_columns == 0:
        return out
    swapped = n_rows > n_columns
    n_left = n_columns if swapped else n_rows
    n_right = n_rows if swapped else n_columns
    matrix = np.empty((n_left, n_right))
    for i in range(n_rows):
        for j in range(n_columns):
            if swapped:
                matrix[j, i] = similarity[rows[i], columns[j]]
            else:
                matrix[i, j] = similarity[rows[i], columns[j]]
    left_match = np.full(n_left, -1, np.int64)
    right_match = np.full(n_right, -1, np.int64)
    right_weight = np.zeros(n_right)
    left_weight = np.empty(n_left)
    for i in range(n_left):
        best = -1e5
        for j in range(n_right):
            if best < matrix[i, j]:
                best = matrix[i, j]
        left_weight[i] = best
    left_used = np.zeros(n_left, np.bool_)
    right_used = np.zeros(n_right, np.bool_)
    finished = True
    for u in range(n_left):
        while True:
            left_used[:] = False
            right_used[:] = False
            if _augment(u, matrix, left_weight, right_weight, left_used, right_used, left_match, right_match,
                        tolerance):
                break
            d = 1e10
            for i in range(n_left):
                if left_used[i]:
                    for j in range(n_right):
                        if not right_used[j]:
                            slack = left_weight[i] + right_weight[j] - matrix[i, j]
                            if slack < d:
                                d = slack
            if d == 1e10:
                finished = False
                break
            for i in range(n_left):
                if left_used[i]:
                    left_weight[i] -= d
            for j in range(n_right):
                if right_used[j]:
                    right_weight[j] += d
        if not finished:
            break
    match = right_match if swapped else left_match
    for i in range(n_rows):
        if match[i] >= 0:
            out[i] = columns[match[i]]
    return out
