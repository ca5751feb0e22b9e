"""OpenLane 2D's official metric in memory (`roneld_eval.metric("openlane", labels=...)`): each
frame's TP, FP and FN per matching and threshold as `score openlane` counts them (score.frame_counts),
lanes read as the evaluator reads a prediction file's (reader.lanes_of_record)."""

from __future__ import annotations

from pathlib import Path
from typing import Any, Sequence

import numpy as np

from ...in_memory import TruthMemo, point_arrays
from ...metrics.lane_iou_f1 import f_measure, highlight_name, official_masks
from ...scoring import PlainTable
from ...thresholds import parse_thresholds
from .reader import IMAGE_HEIGHT, IMAGE_WIDTH, every_labelled_frame, json_path, lanes_of_record, read_lanes, read_list
from .score import COLUMNS, DEFAULT_IOU, LANE_WIDTH, MODES, frame_counts


class OpenLaneMetric:
    """F1, precision and recall per threshold, lanes matched within their category (`F1@30`) and
    whatever their category (`F1@30/any-category`)."""

    name = "openlane"

    def __init__(self, labels: str | Path, list_file: str | Path | None = None, iou: str | None = None,
                 width: int = LANE_WIDTH, modes: tuple[str, ...] = MODES):
        from ...config import check_lane_width

        check_lane_width(width)
        self.thresholds = parse_thresholds(iou or DEFAULT_IOU)
        self.modes = tuple(modes)
        if not self.modes or any(mode not in MODES for mode in self.modes) or len(set(self.modes)) != len(self.modes):
            raise ValueError(f"matching must be among {', '.join(MODES)}")
        self.labels = Path(labels)
        self.frames = tuple(read_list(Path(list_file)) if list_file is not None else every_labelled_frame(self.labels))
        self.size = (IMAGE_WIDTH, IMAGE_HEIGHT, width)
        self.need_categories = MODES[0] in self.modes
        self.truth = TruthMemo(self._drawn_truth)

    def _drawn_truth(self, frame: str):
        truth = read_lanes(json_path(self.labels, frame), self.need_categories)
        return truth, official_masks(truth.lanes, *self.size) if truth.lanes else None

    def frame_counts(self, frame: str, lanes: Any, scores: Any = None, categories: Any = None) -> np.ndarray:
        """(modes, thresholds, 3) of the frame: `lanes`, (N, 2) arrays of (u, v) image pixels;
        `categories`, one per lane (OpenLane's numbers), needed to match within categories."""
        arrays = point_arrays(lanes, "u, v")
        if categories is not None and len(categories) != len(arrays):
            raise ValueError(f"{len(categories)} categories for {len(arrays)} lanes")
        lines = []
        for index, array in enumerate(arrays):
            line: dict[str, Any] = {"uv": [array[:, 0].tolist(), array[:, 1].tolist()]}
            if categories is not None:
                line["category"] = categories[index]
            lines.append(line)
        predicted = lanes_of_record({"lane_lines": lines}, frame, self.need_categories)
        truth, masks = self.truth(frame)
        return frame_counts(truth, masks, predicted, self.size, self.modes, self.thresholds.values)

    def _sums(self, counts: Sequence[np.ndarray | None]) -> np.ndarray:
        """Frames never updated have no lanes, as a missing prediction file."""
        total = np.zeros((len(self.modes), len(self.thresholds.values), 3), np.int64)
        for frame, value in zip(self.frames, counts):
            if value is None:
                value = self.frame_counts(frame, [])
            total += value
        return total

    def tables(self, counts: Sequence[np.ndarray | None]) -> dict[str, PlainTable]:
        """official.csv's rows as `score openlane` writes them (method '-')."""
        total = self._sums(counts)
        rows = []
        for k, mode in enumerate(self.modes):
            for t, label in enumerate(self.thresholds.labels):
                tp, fp, fn = (int(v) for v in total[k, t])
                rows.append(("-", mode, label, tp, fp, fn, *f_measure(tp, fp, fn)))
        return {"official": PlainTable(COLUMNS, tuple(rows))}

    def compute(self, counts: Sequence[np.ndarray | None]) -> dict[str, float]:
        out = {}
        for _, mode, label, _, _, _, precision, recall, f1 in self.tables(counts)["official"].rows:
            suffix = "" if mode == MODES[0] else "/" + mode.replace(" ", "-")
            percent = highlight_name(label)[len("F1@"):]
            out.update({f"F1@{percent}{suffix}": float(f1), f"precision@{percent}{suffix}": float(precision),
                        f"recall@{percent}{suffix}": float(recall)})
        return out
