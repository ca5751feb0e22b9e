"""LLAMAS' official F1 in memory (`roneld_eval.metric("llamas", labels=...)`): each frame's TP, FP and
FN per threshold as `score llamas` counts them (official.frame_counts of the lanes drawn as
evaluate.py draws them), F1 at each threshold and CLRNet's mF1. The AP of probability maps is
not offered in memory (`score llamas --maps` scores the PNGs)."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any, Sequence

import numpy as np

from ...in_memory import TruthMemo, point_arrays
from ...lanes_io import MAX_PREDICTED_COORDINATE
from ...metrics.lane_iou_f1 import highlight_name
from ...model import Lane
from ...scoring import PlainTable
from ...thresholds import parse_thresholds
from .official import f1_of, frame_counts
from .reader import every_label, label_of, read_record
from .score import (AP_COLUMNS, COLUMNS, DEFAULT_IOU, LANE_WIDTH, MF1_THRESHOLDS, clrnet_mf1, predicted_masks,
                    truth_masks)


class LlamasMetric:
    """`F1@50`, `precision@50`, `recall@50` (each threshold of `iou`) and `mF1` (CLRNet's)."""

    name = "llamas"

    def __init__(self, labels: str | Path, iou: str | None = None, width: int = LANE_WIDTH):
        from ...config import check_lane_width

        check_lane_width(width)
        self.thresholds = parse_thresholds(iou or DEFAULT_IOU)
        self.scored_at = tuple(self.thresholds.values) + MF1_THRESHOLDS
        self.width = width
        self.labels = every_label(Path(labels))
        self.frames = tuple(self.labels)
        self.truth = TruthMemo(self._drawn_truth)

    def _drawn_truth(self, frame: str):
        path = self.labels[frame]
        return truth_masks(label_of(read_record(path), path), self.width)

    def frame_counts(self, frame: str, lanes: Any, scores: Any = None) -> tuple[np.ndarray, int]:
        """((thresholds, 3) counts, lanes splprep refuses) of the frame: `lanes`, (N, 2) arrays
        of (x, y) image pixels, as a `.lines.txt` lists them."""
        checked = []
        for index, points in enumerate(point_arrays(lanes)):
            if not np.isfinite(points).all() or (points.size and np.abs(points).max() > MAX_PREDICTED_COORDINATE):
                raise ValueError(f"lane {index}: a coordinate that is not a finite lane coordinate")
            checked.append(Lane(points))
        predicted, refused = predicted_masks(checked, self.width)
        return frame_counts(self.truth(frame), predicted, self.scored_at), refused

    def _sums(self, counts: Sequence[tuple[np.ndarray, int] | None]) -> np.ndarray:
        """Frames never updated have no lanes, as a missing prediction file."""
        total = np.zeros((len(self.scored_at), 3), np.int64)
        for frame, value in zip(self.frames, counts):
            total += (self.frame_counts(frame, []) if value is None else value)[0]
        return total

    def tables(self, counts: Sequence[tuple[np.ndarray, int] | None]) -> dict[str, PlainTable]:
        """official.csv's rows as `score llamas` writes them for lane files (method '-', no AP)."""
        total = self._sums(counts)
        rows = []
        for t, label in enumerate(self.thresholds.labels):
            tp, fp, fn = (int(v) for v in total[t])
            rows.append(("-", label, tp, fp, fn, *f1_of(tp, fp, fn), *(math.nan,) * len(AP_COLUMNS)))
        return {"official": PlainTable(COLUMNS + AP_COLUMNS, tuple(rows))}

    def compute(self, counts: Sequence[tuple[np.ndarray, int] | None]) -> dict[str, float]:
        total = self._sums(counts)
        out: dict[str, float] = {}
        for t, label in enumerate(self.thresholds.labels):
            precision, recall, f1 = f1_of(*(int(v) for v in total[t]))
            percent = highlight_name(label)[len("F1@"):]
            out.update({f"F1@{percent}": float(f1), f"precision@{percent}": float(precision),
                        f"recall@{percent}": float(recall)})
        out["mF1"] = clrnet_mf1(total[len(self.thresholds.values):])
        return out
