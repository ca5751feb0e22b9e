"""Lane error types of one frame at every IoU threshold in one call (metrics.lane_errors says the
rules and holds their pure-Python twin, `classify`)."""

from __future__ import annotations

import numpy as np

from ..._numba_cache import cached_njit
from .matching import matched_ious

# Columns of lane_error_counts' rows, in this order (lane_errors.ERROR_TYPES names them).
FP_LOC, FP_DUPE, FP_CAT, FP_BKG, FN_LOC, FN_MISS = 0, 1, 2, 3, 4, 5
N_TYPES = 6


@cached_njit(nogil=True)
def lane_error_counts(similarity, match, other_iou, limits, loc_iou):
    """(thresholds, 6) counts: false positives as Loc, Dupe, Cat, Bkg and false negatives as Loc,
    Miss. `similarity`: (ground truth, predictions) IoUs as matched (0 between lanes of two
    categories where categories must agree); `match`: each ground-truth lane's matched prediction
    (-1 if none); `other_iou`: each prediction's highest IoU with a lane of another category (-inf
    where categories are not matched); a matched pair is a true positive when its IoU > the threshold."""
    n_gt, n_pred = similarity.shape
    out = np.zeros((limits.size, N_TYPES), np.int64)
    # each prediction's highest-IoU ground-truth lane (the first of equal ones; a NaN IoU is none)
    best = np.full(n_pred, -1, np.int64)
    best_iou = np.full(n_pred, -np.inf)
    for p in range(n_pred):
        for g in range(n_gt):
            if similarity[g, p] > best_iou[p]:
                best_iou[p] = similarity[g, p]
                best[p] = g
    gt_hit = np.zeros(n_gt, np.bool_)
    pred_hit = np.zeros(n_pred, np.bool_)
    loc_pred = np.empty(n_gt, np.int64)
    for t in range(limits.size):
        gt_hit[:] = False
        pred_hit[:] = False
        loc_pred[:] = -1
        for g in range(n_gt):
            if match[g] >= 0 and similarity[g, match[g]] > limits[t]:
                gt_hit[g] = True
                pred_hit[match[g]] = True
        for p in range(n_pred):
            if pred_hit[p]:
                continue
            g = best[p]
            if other_iou[p] > limits[t]:  # it would match a lane of another category (TIDE's Cls first)
                out[t, FP_CAT] += 1
            elif g < 0 or not best_iou[p] >= loc_iou:
                out[t, FP_BKG] += 1
            elif gt_hit[g]:
                out[t, FP_DUPE] += 1
            elif loc_pred[g] < 0:
                loc_pred[g] = p
            else:  # a second prediction on an unmatched lane: the higher IoU is Loc, the other a Dupe
                out[t, FP_DUPE] += 1
                if best_iou[p] > best_iou[loc_pred[g]]:
                    loc_pred[g] = p
        n_fn = 0
        for g in range(n_gt):
            if not gt_hit[g]:
                n_fn += 1
                if loc_pred[g] >= 0:
                    out[t, FP_LOC] += 1
                    out[t, FN_LOC] += 1
        out[t, FN_MISS] = n_fn - out[t, FN_LOC]
    return out


@cached_njit(nogil=True)
def swept_true_positives(similarity, scores, score_limits, limits, strict, tolerance):
    """A frame at each score threshold: the predictions kept (score >= it, or > it when `strict`)
    matched again as the official evaluator matches them; (true positives (score thresholds, IoU
    thresholds), predictions kept (score thresholds,))."""
    n_gt, n_pred = similarity.shape
    tp = np.zeros((score_limits.size, limits.size), np.int64)
    kept = np.zeros(score_limits.size, np.int64)
    rows = np.arange(n_gt)
    for c in range(score_limits.size):
        columns = np.empty(n_pred, np.int64)
        n = 0
        for p in range(n_pred):
            if scores[p] > score_limits[c] or (not strict and scores[p] == score_limits[c]):
                columns[n] = p
                n += 1
        kept[c] = n
        matched = matched_ious(similarity, rows, columns[:n], tolerance)
        for t in range(limits.size):
            for g in range(n_gt):
                if matched[g] > limits[t]:
                    tp[c, t] += 1
    return tp, kept
