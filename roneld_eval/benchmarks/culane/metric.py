"""CULane's official metric in memory (`roneld_eval.metric("culane", ...)`): the counts and sums of
`score culane` (metrics.lane_iou_f1: FrameMatches per frame, GroupCounts per category and
threshold), fed lanes held in memory instead of `.lines.txt` files."""

from __future__ import annotations

from pathlib import Path
from typing import Any, Sequence

import numpy as np

from ...in_memory import TruthMemo, pixel_lanes
from ...metrics.lane_iou_f1 import (OFFICIAL_COLUMNS, UNMATCHED, FrameMatches, GroupCounts, ScoredFrames,
                                    frame_result, highlight_name, official_masks, summary_records)
from ...scoring import PlainTable
from .reader import category_files, read_culane, read_frame_labels
from .score import _thresholds


class CulaneMetric:
    """The official CULane F1 of every listed frame, per category and IoU threshold."""

    name = "culane"

    def __init__(self, data_root: str | Path, list_file: str | Path | None = None, iou: str | float | None = None,
                 preset: str | None = None, width: int = 30):
        from ...config import check_lane_width

        check_lane_width(width)
        self.thresholds, self.highlighted = _thresholds(iou, preset)
        dataset = read_culane(data_root, list_file, labels=False, require_labels=True)
        self.root = dataset.root
        self.frames = tuple(frame.relpath for clip in dataset.clips for frame in clip.frames)
        self.categories = dataset.categories
        self.size = (dataset.image_width, dataset.image_height, width)
        self.truth = TruthMemo(self._drawn_truth)
        # CLRerNet's key names use the category files' names (test0_normal), read with the lists
        self.category_files = {name: path.stem for _, name, path in category_files(self.root)}

    def _drawn_truth(self, frame: str) -> tuple[int, Any]:
        truth = read_frame_labels(self.root, frame)
        return len(truth), official_masks(truth, *self.size) if truth else None

    def frame_counts(self, frame: str, lanes: Any, scores: Any = None) -> FrameMatches:
        """The frame's matched IoUs (`scores` are not read: CULane's F1 counts every lane)."""
        predicted = pixel_lanes(lanes)
        n_gt, masks = self.truth(frame)
        return frame_result(n_gt, masks, predicted, *self.size)

    def _missing(self, frame: str) -> FrameMatches:
        """A frame never updated: no lanes, as the C++ evaluator reads a missing file."""
        n_gt, _ = self.truth(frame)
        return FrameMatches(n_gt, 0, np.full(n_gt, UNMATCHED))

    def _rows(self, counts: Sequence[FrameMatches | None]) -> list[tuple]:
        results = {frame: result if result is not None else self._missing(frame)
                   for frame, result in zip(self.frames, counts)}
        sums = GroupCounts.zeros(1, len(self.categories) + 1, self.thresholds.values)
        sums.add(ScoredFrames.from_results([results]), self.categories)
        return sums.records(["-"], list(self.categories), self.thresholds.labels)

    def tables(self, counts: Sequence[FrameMatches | None]) -> dict[str, PlainTable]:
        """official.csv's and summary.csv's rows as `score culane` writes them (method '-')."""
        rows = self._rows(counts)
        columns, summary = summary_records(rows, self.highlighted, self.thresholds.labels)
        return {"official": PlainTable(OFFICIAL_COLUMNS, tuple(rows)), "summary": PlainTable(tuple(columns),
                                                                                          tuple(summary))}

    def compute(self, counts: Sequence[FrameMatches | None]) -> dict[str, float]:
        return scores_by_name(self._rows(counts), len(self.thresholds.labels))

    def compute_as_clrernet(self, counts: Sequence[FrameMatches | None]) -> dict[str, float]:
        """The names CLRerNet's mmengine CULaneMetric logs (hirotomusiker/CLRerNet 4bd8e7d,
        libs/datasets/metrics/culane_metric.py, eval_predictions): `TP0.5`, `FP0.5`, `FN0.5`,
        `Precision0.5`, `Recall0.5`, `F1_0.5` over every frame and `F1_test0_normal_0.5` per
        category list, at each threshold of `iou` (CLRerNet's are 0.1, 0.5 and 0.75). The values
        are the official evaluator's: CLRerNet's own divide by a sum + 1e-8 and draw lanes as
        LaneATT does, so its printed F1 differs from these in the last digits or more."""
        stems = self.category_files
        out: dict[str, float] = {}
        for _, category, label, tp, fp, fn, precision, recall, f1 in self._rows(counts):
            threshold = str(float(label))
            if category == "all":
                out.update({f"TP{threshold}": float(tp), f"FP{threshold}": float(fp), f"FN{threshold}": float(fn),
                            f"Precision{threshold}": float(precision), f"Recall{threshold}": float(recall),
                            f"F1_{threshold}": float(f1)})
            elif category in stems:
                out[f"F1_{stems[category]}_{threshold}"] = float(f1)
        return out



def scores_by_name(rows: Sequence[tuple], n_thresholds: int) -> dict[str, float]:
    """`F1@50`, `precision@50`, `recall@50` over every frame, and per category `normal/F1@50`, ...
    (the category in front, as loggers group names), from GroupCounts.records' rows; `mF1` (and
    `normal/mF1`) over a grid of two or more thresholds, as summary.csv's mF1."""
    out: dict[str, float] = {}
    f1s: dict[str, list[float]] = {}
    for _, category, label, _, _, _, precision, recall, f1 in rows:
        prefix = "" if category == "all" else f"{category}/"
        percent = highlight_name(label)[len("F1@"):]
        out[f"{prefix}F1@{percent}"] = float(f1)
        out[f"{prefix}precision@{percent}"] = float(precision)
        out[f"{prefix}recall@{percent}"] = float(recall)
        f1s.setdefault(prefix, []).append(float(f1))
    if n_thresholds > 1:
        for prefix, values in f1s.items():
            out[f"{prefix}mF1"] = float(np.mean(np.array(values, np.float64)))
    return out
