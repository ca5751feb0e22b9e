"""The lane-IoU F1 of SCNN's CULane evaluator (tools/lane_evaluation), TP/FP/FN for every threshold
at once: the official metric of CULane, and the matching of VIL-100, OpenLane 2D and LLAMAS.

Per frame: every ground-truth lane against every predicted lane at 1640x590, drawn 30 px
wide as the C++ tool draws them (float32 points, its spline for 3+ points); IoU matrix; the
tool's Kuhn-Munkres matching; a matched pair is a TP when IoU > threshold (strictly).
FP = predictions - TP, FN = ground truth - TP. A lane of fewer than 2 points counts with
IoU 0. Matching does not depend on the threshold, so storing each ground-truth lane's
matched IoU scores a whole sweep in one pass (the C++ tool needs one run per threshold).
`sweep_rows` turns those IoUs into one row per method, category and threshold, counts summed
before any ratio; `f1_summary` picks F1@50/F1@75 and the mean over the grid (CLRNet's mF1).
"""

from __future__ import annotations

from dataclasses import dataclass
from decimal import Decimal
from typing import TYPE_CHECKING, Iterable, Mapping, Sequence

import numpy as np

from ..model import Lane
from .. import _numba_cache  # noqa: F401  (numba imported first, a signal deferred meanwhile)
from . import _kernels
from .iou import KM_TOLERANCE
from .raster import LaneMask, LaneRuns, MaskList, MaskSet, official_mask_set

if TYPE_CHECKING:  # pandas only where a DataFrame is asked for: `score culane` starts without it
    import pandas as pd

UNMATCHED = -np.inf
OFFICIAL_COLUMNS = ("method", "category", "threshold", "tp", "fp", "fn", "precision", "recall", "f1")


@dataclass(frozen=True, eq=False)
class FrameMatches:
    """One frame's outcome: lane counts and each ground-truth lane's matched IoU (-inf if none)."""

    n_gt: int
    n_pred: int
    matched_iou: np.ndarray

    def true_positives(self, threshold: float) -> int:
        return int(np.count_nonzero(self.matched_iou > threshold))


def official_masks(lanes: Sequence[Lane], width: int, height: int, lane_width: int) -> MaskSet:
    """Masks of a frame's lanes as the official evaluator draws them (a lane of < 2 points is
    not drawn), all in one kernel call."""
    return official_mask_set(lanes, width, height, lane_width)


def matched_result(similarity: np.ndarray, rows: Sequence[int] | None = None,
                   columns: Sequence[int] | None = None) -> FrameMatches:
    """The outcome of a frame from its (ground truth, predictions) IoU matrix, or from the rows
    and columns of it given: the official matching (iou.match_lanes, in one kernel call), and
    each ground-truth lane's matched IoU."""
    picked = [np.arange(size, dtype=np.int64) if chosen is None else np.asarray(chosen, np.int64)
              for chosen, size in ((rows, similarity.shape[0]), (columns, similarity.shape[1]))]
    n_gt, n_pred = picked[0].size, picked[1].size
    if n_gt == 0 or n_pred == 0:
        return FrameMatches(n_gt, n_pred, np.full(n_gt, UNMATCHED))
    matrix = np.ascontiguousarray(similarity, np.float64)
    return FrameMatches(n_gt, n_pred, _kernels.matched_ious(matrix, *picked, KM_TOLERANCE))


def match_frame(
    gt_lanes: Sequence[Lane],
    pred_lanes: Sequence[Lane],
    width: int = 1640,
    height: int = 590,
    lane_width: int = 30,
    gt_masks: MaskSet | Sequence[LaneMask | None] | None = None,
    pred_masks: MaskSet | Sequence[LaneMask | None] | None = None,
) -> FrameMatches:
    """Match one frame's predictions to its ground truth as the official evaluator does.

    Masks already drawn (official_masks of the same lanes) can be passed to save drawing.
    """
    n_gt, n_pred = len(gt_lanes), len(pred_lanes)
    if n_gt == 0 or n_pred == 0:
        return FrameMatches(n_gt, n_pred, np.full(n_gt, UNMATCHED))
    gt = official_masks(gt_lanes, width, height, lane_width) if gt_masks is None else _mask_set(gt_masks)
    pred = official_masks(pred_lanes, width, height, lane_width) if pred_masks is None else _mask_set(pred_masks)
    return matched_result(gt.ious(pred))


def frame_result(n_gt: int, gt_masks: MaskSet | None, pred_lanes: Sequence[Lane], width: int, height: int,
                 lane_width: int) -> FrameMatches:
    """match_frame of ground truth already drawn: its number of lanes and their masks
    (None without lanes)."""
    n_pred = len(pred_lanes)
    if n_gt == 0 or n_pred == 0:
        return FrameMatches(n_gt, n_pred, np.full(n_gt, UNMATCHED))
    assert gt_masks is not None
    return matched_result(gt_masks.ious(official_masks(pred_lanes, width, height, lane_width)))


def frame_similarity(n_gt: int, gt_masks: MaskSet | None, pred_lanes: Sequence[Lane], width: int, height: int,
                     lane_width: int) -> np.ndarray:
    """The (ground truth, predictions) IoU matrix frame_result matches, ground truth already drawn
    (an empty matrix when either side has no lanes)."""
    if n_gt == 0 or not pred_lanes:
        return np.zeros((n_gt, len(pred_lanes)))
    assert gt_masks is not None
    return gt_masks.ious(official_masks(pred_lanes, width, height, lane_width))


def _mask_set(masks: MaskSet | Sequence[LaneMask | None]) -> MaskSet:
    if isinstance(masks, (LaneRuns, MaskList)):
        return masks
    return MaskList(tuple(masks))


@dataclass(frozen=True)
class ThresholdCounts:
    """Summed counts at each threshold (arrays over thresholds)."""

    thresholds: tuple[float, ...]
    tp: np.ndarray
    fp: np.ndarray
    fn: np.ndarray
    n_frames: int


def sum_counts(results: Iterable[FrameMatches], thresholds: Sequence[float]) -> ThresholdCounts:
    """TP/FP/FN over frames for every threshold."""
    thresholds = tuple(float(t) for t in thresholds)
    limits = np.array(thresholds)[:, None]
    tp = np.zeros(len(thresholds), np.int64)
    n_gt = n_pred = n_frames = 0
    for result in results:
        n_frames += 1
        n_gt += result.n_gt
        n_pred += result.n_pred
        if result.matched_iou.size:
            tp += np.count_nonzero(result.matched_iou[None, :] > limits, axis=1)
    return ThresholdCounts(thresholds, tp, n_pred - tp, n_gt - tp, n_frames)


def f_measure(tp: int, fp: int, fn: int) -> tuple[float, float, float]:
    """(precision, recall, F1); NaN where undefined (the C++ tool prints -1 there)."""
    precision = tp / (tp + fp) if tp + fp else float("nan")
    recall = tp / (tp + fn) if tp + fn else float("nan")
    if np.isnan(precision) or np.isnan(recall) or precision + recall == 0:
        f1 = 0.0 if (precision == 0 or recall == 0) else float("nan")
    else:
        f1 = 2 * precision * recall / (precision + recall)
    return precision, recall, f1


@dataclass(frozen=True, eq=False)
class ScoredFrames:
    """Frame results of one or more methods on the same frames, as columns (what a sweep reads).

    Ground-truth lanes are shared by every method, so each lane's matched IoU is one column
    of `matched_iou`, one row per method.
    """

    frames: tuple[str, ...]  # frame relpaths, in scoring order
    n_gt: np.ndarray  # (frames,) ground-truth lanes of each frame
    n_pred: np.ndarray  # (methods, frames) predicted lanes of each frame
    matched_iou: np.ndarray  # (methods, ground-truth lanes) matched IoU, -inf when unmatched

    @property
    def lane_frame(self) -> np.ndarray:
        """Index into `frames` of each ground-truth lane."""
        return np.repeat(np.arange(len(self.frames)), self.n_gt)

    @classmethod
    def from_results(cls, per_method: Sequence[Mapping[str, FrameMatches]]) -> "ScoredFrames":
        """Columns from per-method {relpath: result} of the same frames (the first's order)."""
        frames = tuple(per_method[0])
        n_gt = np.array([per_method[0][f].n_gt for f in frames], np.int64)
        n_pred = np.array([[results[f].n_pred for f in frames] for results in per_method], np.int64)
        n_pred = n_pred.reshape(len(per_method), len(frames))
        ious = [np.concatenate([np.asarray(results[f].matched_iou, np.float64) for f in frames] or [np.zeros(0)])
                for results in per_method]
        return cls(frames, n_gt, n_pred, np.array(ious, np.float64).reshape(len(per_method), int(n_gt.sum())))


def category_groups(frames: Sequence[str], categories: Mapping[str, frozenset[str]]) -> list[tuple[str, np.ndarray]]:
    """(name, frame mask) per category list in its order, then ("all", every frame)."""
    groups = [(name, np.fromiter((f in members for f in frames), bool, len(frames)))
              for name, members in categories.items()]
    groups.append(("all", np.ones(len(frames), bool)))
    return groups


@dataclass
class GroupCounts:
    """What official.csv's rows are made of, summed over frames as they are scored (memory flat
    in the number of frames): per category group (its lists, then 'all') the ground-truth lanes,
    per method and group the predicted lanes, and the matched IoUs strictly above each threshold."""

    limits: np.ndarray  # (thresholds,) float64
    n_gt: np.ndarray  # (groups,) int64
    n_pred: np.ndarray  # (methods, groups) int64
    tp: np.ndarray  # (methods, groups, thresholds) int64

    @classmethod
    def zeros(cls, n_methods: int, n_groups: int, thresholds: Sequence[float]) -> "GroupCounts":
        limits = np.asarray(thresholds, np.float64)
        return cls(limits, np.zeros(n_groups, np.int64), np.zeros((n_methods, n_groups), np.int64),
                   np.zeros((n_methods, n_groups, len(limits)), np.int64))

    def add(self, scored: ScoredFrames, categories: Mapping[str, frozenset[str]]) -> None:
        """Add these frames' counts (any number of frames: a chunk, or all at once)."""
        lane_frame = scored.lane_frame
        for g, (_, inside) in enumerate(category_groups(scored.frames, categories)):
            self.n_gt[g] += int(scored.n_gt[inside].sum())
            lanes = inside[lane_frame]
            for m in range(len(self.n_pred)):
                self.n_pred[m, g] += int(scored.n_pred[m, inside].sum())
                # IoUs strictly above t: those sorted after t (side="right" puts equal ones before);
                # a NaN is above nothing, as `NaN > t` is false.
                ious = np.sort(np.where(np.isnan(scored.matched_iou[m, lanes]), -np.inf, scored.matched_iou[m, lanes]))
                self.tp[m, g] += len(ious) - np.searchsorted(ious, self.limits, side="right")

    def records(self, methods: Sequence[str], categories: Sequence[str],
                labels: Sequence[str] | None = None) -> list[tuple]:
        """sweep_rows' rows as plain tuples in OFFICIAL_COLUMNS order (Python str, int and float)."""
        shown: list[str] | list[float] = list(labels) if labels is not None else [float(t) for t in self.limits]
        rows = []
        for m, method in enumerate(methods):
            for g, name in enumerate([*categories, "all"]):
                n_gt, n_pred = int(self.n_gt[g]), int(self.n_pred[m, g])
                for label, tp in zip(shown, self.tp[m, g].tolist()):
                    precision, recall, f1 = f_measure(tp, n_pred - tp, n_gt - tp)
                    rows.append((method, name, label, tp, n_pred - tp, n_gt - tp, precision, recall, f1))
        return rows


def sweep_records(scored: ScoredFrames, methods: Sequence[str], categories: Mapping[str, frozenset[str]],
                  thresholds: Sequence[float], labels: Sequence[str] | None = None) -> list[tuple]:
    """sweep_rows' rows as plain tuples in OFFICIAL_COLUMNS order (Python str, int and float)."""
    counts = GroupCounts.zeros(len(methods), len(categories) + 1, thresholds)
    counts.add(scored, categories)
    return counts.records(methods, list(categories), labels)


def sweep_rows(scored: ScoredFrames, methods: Sequence[str], categories: Mapping[str, frozenset[str]],
               thresholds: Sequence[float], labels: Sequence[str] | None = None) -> pd.DataFrame:
    """method, category, threshold, tp, fp, fn, precision, recall, f1: one row per method,
    category (its lists, then `all`) and threshold, counts summed before any ratio."""
    import pandas as pd

    return pd.DataFrame(sweep_records(scored, methods, categories, thresholds, labels), columns=list(OFFICIAL_COLUMNS))


def category_table(
    frame_results: Mapping[str, FrameMatches],
    categories: Mapping[str, frozenset[str]],
    threshold: float,
) -> pd.DataFrame:
    """Rows per category present, then `all`: category, tp, fp, fn, precision, recall, f1."""
    table = sweep_rows(ScoredFrames.from_results([frame_results]), ["-"], categories, [threshold])
    return table.drop(columns=["method", "threshold"]).reset_index(drop=True)


# The thresholds papers single out, shown one by one whenever a grid holds them.
HIGHLIGHTS = ("0.50", "0.75")


def highlighted(labels: Sequence[str]) -> tuple[str, ...]:
    """The thresholds of a grid that tables single out: those papers print (HIGHLIGHTS), else the first."""
    return tuple(label for label in labels if label in HIGHLIGHTS) or tuple(labels[:1])


def highlight_name(label: str) -> str:
    """'0.50' -> 'F1@50', '0.75' -> 'F1@75', '0.525' -> 'F1@52.5' (the papers' column names)."""
    percent = (Decimal(label) * 100).normalize()
    return f"F1@{percent:f}"


def summary_records(official: Iterable[Sequence], highlighted: Sequence[str],
                    labels: Sequence[str]) -> tuple[list[str], list[tuple]]:
    """(columns, rows) of f1_summary from sweep_records' rows, as plain tuples."""
    f1s: dict[tuple[str, str], dict] = {}  # (method, category) in order of first appearance
    for row in official:
        f1s.setdefault((row[0], row[1]), {})[row[2]] = row[-1]
    rows = []
    for (method, category), f1 in f1s.items():
        row = [method, category] + [float(f1[label]) for label in highlighted]
        if len(labels) > 1:
            row.append(float(np.mean(np.array([f1[label] for label in labels], np.float64))))
        rows.append(tuple(row))
    columns = ["method", "category"] + [highlight_name(t) for t in highlighted] + (["mF1"] if len(labels) > 1 else [])
    return columns, rows


def f1_summary(official: pd.DataFrame, highlighted: Sequence[str], labels: Sequence[str]) -> pd.DataFrame:
    """method, category, F1@<t> for each highlighted threshold, and mF1 (the mean F1 over
    every threshold in `labels`) when there is more than one: from sweep_rows' table."""
    import pandas as pd

    table = official[list(OFFICIAL_COLUMNS)]
    columns, rows = summary_records(table.itertuples(index=False, name=None), highlighted, labels)
    return pd.DataFrame(rows, columns=columns)
