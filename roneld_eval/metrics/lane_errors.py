"""Why a lane-IoU F1 is not higher: each false positive and false negative given one error type,
TIDE's method (Bolya et al., ECCV 2020) carried over to lanes matched by IoU.

At a threshold t a matched pair with IoU > t is a true positive (the official rule); every other
prediction is a false positive and every other ground-truth lane a false negative. A false-positive
prediction takes its highest-IoU ground-truth lane (the first of equal ones):

- **Loc** if that IoU is at least `loc_iou` and that lane is not a true positive: the prediction
  found the lane but drew it too far off. Of several such predictions on one lane, the one of
  highest IoU is Loc (the first of equal ones) and the others Dupe;
- **Dupe** if that lane is already a true positive;
- **Bkg** if no IoU reaches `loc_iou` (or the frame has no ground truth).

A false-negative lane is **Loc** when it is some Loc prediction's lane, else **Miss**. So the false
positives' types add up to FP and the false negatives' to FN exactly, and each Loc prediction has
one Loc lane. The change in F1 when every error of one type is fixed (`delta_f1`) is how TIDE
gives its dAP: a Loc pair becomes a true positive (FP and FN one less each, TP one more), a Dupe
or Bkg prediction is removed (FP one less), a Miss is removed (FN one less).

`frame_errors` counts a frame at every threshold in one kernel call (_kernels.lane_error_counts);
`classify` is the same rule written plainly, one threshold, naming each lane's type (its twin).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Sequence

import numpy as np

from . import _kernels
from .iou import KM_TOLERANCE, match_lanes
from .lane_iou_f1 import f_measure

# (side, type) of each column of frame_errors' counts, in order
ERROR_TYPES = (("fp", "Loc"), ("fp", "Dupe"), ("fp", "Bkg"), ("fn", "Loc"), ("fn", "Miss"))
ERROR_COLUMNS = ("fp_loc", "fp_dupe", "fp_bkg", "fn_loc", "fn_miss")
DEFAULT_LOC_IOU = 0.1


@dataclass(frozen=True)
class FrameErrors:
    """One frame's matching and its error types: each ground-truth lane's matched IoU (-inf
    where unmatched, as FrameMatches holds it), and (thresholds, 5) counts in ERROR_TYPES order."""

    n_gt: int
    n_pred: int
    matched_iou: np.ndarray
    counts: np.ndarray


def frame_errors(similarity: np.ndarray, limits: np.ndarray, loc_iou: float) -> FrameErrors:
    """The official matching of a (ground truth, predictions) IoU matrix and its error types at
    each threshold of `limits`."""
    matrix = np.ascontiguousarray(similarity, np.float64)
    n_gt, n_pred = matrix.shape
    rows, columns = np.arange(n_gt, dtype=np.int64), np.arange(n_pred, dtype=np.int64)
    match = _kernels.matched_columns(matrix, rows, columns, KM_TOLERANCE)
    matched = np.full(n_gt, -np.inf)
    found = np.flatnonzero(match >= 0)
    matched[found] = matrix[found, match[found]]
    counts = _kernels.lane_error_counts(matrix, match, np.ascontiguousarray(limits, np.float64), float(loc_iou))
    return FrameErrors(n_gt, n_pred, matched, counts)


def classify(similarity: np.ndarray, threshold: float, loc_iou: float) -> tuple[list[str], list[str]]:
    """Each prediction's and each ground-truth lane's outcome at one threshold: "TP", or its
    error type ("Loc", "Dupe", "Bkg"; "Loc", "Miss"). The rule of the module's docstring, plainly."""
    n_gt, n_pred = similarity.shape
    match = match_lanes(similarity) if n_gt and n_pred else np.full(n_gt, -1)
    gt_hit = [bool(match[g] >= 0 and similarity[g, match[g]] > threshold) for g in range(n_gt)]
    pred_hit = [any(gt_hit[g] and match[g] == p for g in range(n_gt)) for p in range(n_pred)]
    preds = ["TP" if hit else "" for hit in pred_hit]
    candidates: dict[int, list[tuple[float, int]]] = {}
    for p in range(n_pred):
        if pred_hit[p]:
            continue
        ious = [(-np.inf if np.isnan(v) else float(v)) for v in similarity[:, p]]
        g = int(np.argmax(ious)) if n_gt and max(ious) > -np.inf else -1
        if g < 0 or not ious[g] >= loc_iou:
            preds[p] = "Bkg"
        elif gt_hit[g]:
            preds[p] = "Dupe"
        else:
            candidates.setdefault(g, []).append((ious[g], p))
    for found in candidates.values():
        top = max(iou for iou, _ in found)
        chosen = min(p for iou, p in found if iou == top)
        for _, p in found:
            preds[p] = "Loc" if p == chosen else "Dupe"
    truth = ["TP" if gt_hit[g] else ("Loc" if g in candidates else "Miss") for g in range(n_gt)]
    return preds, truth


def delta_f1(tp: int, fp: int, fn: int, counts: Sequence[int]) -> list[float]:
    """dF1 of each error type (ERROR_TYPES order) from summed counts: F1 with every error of that
    type fixed, minus F1 as it is (NaN where F1 is undefined either way)."""
    f1 = f_measure(tp, fp, fn)[2]
    loc, dupe, bkg, _, miss = (int(c) for c in counts)
    fixed = [(tp + loc, fp - loc, fn - loc), (tp, fp - dupe, fn), (tp, fp - bkg, fn), (tp + loc, fp - loc, fn - loc),
             (tp, fp, fn - miss)]
    return [f_measure(*after)[2] - f1 for after in fixed]
