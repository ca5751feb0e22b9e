"""ONCE-3DLanes' official metric in memory (`roneld_eval.metric("once3d", labels=...)`): each
frame's counts at every score threshold as `score once3d` gets them (official.frame_counts), from
lanes held in memory: (N, 3) arrays of camera coordinates (x right, y down, z forward, metres) with
a score each. Frames are summed in the order the label folder lists them, as the evaluator sums."""

from __future__ import annotations

from pathlib import Path
from typing import Any, Sequence

import numpy as np

from ...in_memory import TruthMemo, scored_3d_lanes
from ...scoring import PlainTable
from .official import LABELS, THRESHOLDS, FrameCounts, frame_counts, totals
from .reader import listed_frames, read_truth
from .score import COLUMNS, REPORTED, _path


class Once3dMetric:
    """F1, precision, recall and distance error at each score threshold (`f1` and the others at
    0.95, the row PersFormer reported; `f1@0.5` and so on at each)."""

    name = "once3d"

    def __init__(self, labels: str | Path, iou_gate: float | None = None):
        self.labels = Path(labels)
        self.iou_gate = iou_gate
        self.frames = tuple(listed_frames(self.labels))
        self.truth = TruthMemo(lambda frame: read_truth(_path(self.labels, frame)))

    def frame_counts(self, frame: str, lanes: Any, scores: Any = None) -> FrameCounts:
        """The frame's counts: `lanes`, (N, 3) point arrays (x, y, z), and `scores`, one each."""
        arrays, chances = scored_3d_lanes(lanes, scores, "lane", ("score", "scores"), short_above=THRESHOLDS[0])
        return frame_counts(self.truth(frame), arrays, chances, self.iou_gate)

    def tables(self, counts: Sequence[FrameCounts | None]) -> dict[str, PlainTable]:
        """official.csv's rows as `score once3d` writes them (method '-')."""
        stacked = np.array([(value or self.frame_counts(frame, [], [])).stacked()
                            for frame, value in zip(self.frames, counts)]).reshape(len(self.frames), 4, len(LABELS))
        total = totals(stacked)
        rows = tuple(("-", label, THRESHOLDS[t], int(total.gt[t]), int(total.pred[t]), int(total.tp[t]),
                      float(total.distance_sum[t]), float(total.f1[t]), float(total.precision[t]),
                      float(total.recall[t]), float(total.distance[t])) for t, label in enumerate(LABELS))
        return {"official": PlainTable(COLUMNS, rows)}

    def compute(self, counts: Sequence[FrameCounts | None]) -> dict[str, float]:
        found: dict[str, float] = {}
        for row in self.tables(counts)["official"].rows:
            named = dict(zip(COLUMNS, row))
            for key in ("f1", "precision", "recall", "distance_error"):
                found[f"{key}@{row[1]}"] = float(named[key])
                if row[1] == REPORTED:
                    found[key] = float(named[key])
        return found

