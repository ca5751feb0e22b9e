"""OpenLane 3D's official metric in memory (`roneld_eval.metric("openlane3d", labels=...)`): each
frame's counts and matched errors as `score openlane3d` gets them (official.frame_counts), from lanes
held in memory: (N, 3) arrays of ground coordinates (x right, y forward, z up, metres) and each
lane's category, or, with protocol "persformer-train", each lane's class probabilities."""

from __future__ import annotations

from pathlib import Path
from typing import Any, Sequence

import numpy as np

from ...in_memory import TruthMemo, numbers_of
from ...scoring import PlainTable
from .official import FrameCounts, frame_counts, ground_truth_lanes, totals
from .reader import json_path, read_list, read_truth
from .score import COLUMNS, PRINTED, PROB_THRESHOLD, _every_label, check_protocol

KEYS = {"f": "F", "recall": "recall", "precision": "precision", "category_accuracy": "category_accuracy",
        "x_error_near": "x_error_near", "x_error_far": "x_error_far", "z_error_near": "z_error_near",
        "z_error_far": "z_error_far"}


class OpenLane3dMetric:
    """F, recall, precision, category accuracy and the x/z errors near and far over the list."""

    name = "openlane3d"

    def __init__(self, labels: str | Path, list_file: str | Path | None = None, protocol: str = "file",
                 prob_threshold: float | None = None):
        self.protocol, self.prob_threshold = protocol, check_protocol(protocol, prob_threshold)
        self.labels = Path(labels)
        self.frames = tuple(read_list(Path(list_file)) if list_file is not None else _every_label(self.labels))
        self.truth = TruthMemo(self._read_truth)

    def _read_truth(self, frame: str):
        truth = read_truth(json_path(self.labels, frame))
        return ground_truth_lanes(truth.extrinsic, truth.lanes), list(truth.visibility), list(truth.categories)

    def frame_counts(self, frame: str, lanes: Any, scores: Any = None, categories: Any = None) -> FrameCounts:
        """The frame's counts: `lanes`, (N, 3) point arrays (x, y, z; or (N, 2) without z), each of
        at least one point; `categories`, one per lane (protocol "file"), or `scores`, each lane's
        class probabilities (protocol "persformer-train": a lane kept when its highest is above the
        threshold, its category the first highest)."""
        arrays = [numbers_of(lane, f"lane {k}") for k, lane in enumerate(lanes)]
        for k, array in enumerate(arrays):
            if array.ndim != 2 or array.shape[1] not in (2, 3) or len(array) == 0:
                raise ValueError(f"lane {k}: points must be an (N, 3) array of (x, y, z), at least one, "
                                 f"got shape {array.shape}")
        chosen = self._categories(arrays, scores, categories)
        gt_lanes, visibility, gt_categories = self.truth(frame)
        return frame_counts([arrays[k] for k in chosen], list(chosen.values()), gt_lanes, visibility, gt_categories)

    def _categories(self, arrays: list[np.ndarray], scores: Any, categories: Any) -> dict[int, int]:
        """Lane index -> its category, for the lanes kept."""
        if self.protocol == "file":
            if categories is None or len(categories) != len(arrays):
                raise ValueError("give `categories=`, one per lane (the results' `category`)")
            return {k: int(numbers_of(c, f"category {k}")) for k, c in enumerate(categories)}
        if scores is None or len(scores) != len(arrays):
            raise ValueError("give `scores=`, each lane's class probabilities (the results' `laneLines_prob`)")
        probabilities = [numbers_of(score, f"lane {k}'s probabilities").reshape(-1) for k, score in enumerate(scores)]
        if len({len(p) for p in probabilities}) > 1 or any(len(p) == 0 for p in probabilities):
            raise ValueError("every lane's class probabilities must be of one length")
        threshold = self.prob_threshold if self.prob_threshold is not None else PROB_THRESHOLD
        return {k: int(np.argmax(p)) for k, p in enumerate(probabilities) if max(p) > threshold}

    def _combined(self, counts: Sequence[FrameCounts | None]) -> tuple[np.ndarray, np.ndarray]:
        """Every frame's six counts and every counted match's errors, frames in list order (one never
        updated: no lanes, as a result file without them)."""
        found = [value if value is not None else self.frame_counts(frame, [], [], [])
                 for frame, value in zip(self.frames, counts)]
        stats = np.array([value.counts() for value in found], dtype=float).reshape(len(found), 6)
        errors = np.concatenate([value.errors for value in found]) if found else np.zeros((0, 4))
        return stats, errors

    def tables(self, counts: Sequence[FrameCounts | None]) -> dict[str, PlainTable]:
        """official.csv's row as `score openlane3d` writes it (method '-', scenario 'all')."""
        stats, errors = self._combined(counts)
        values = totals(stats, errors)
        row = ("-", "all", len(self.frames), *(int(v) for v in values[8:]), *values[:8])
        return {"official": PlainTable(COLUMNS, (row,))}

    def compute(self, counts: Sequence[FrameCounts | None]) -> dict[str, float]:
        row = self.tables(counts)["official"].rows[0]
        return {KEYS[name]: float(row[COLUMNS.index(name)]) for name in PRINTED}
