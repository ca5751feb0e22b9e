"""CurveLanes' official metric in memory (`roneld_eval.metric("curvelanes", labels=..., image_root=...)`):
each image's hits, predicted and ground-truth lanes per score threshold as `score curvelanes`
counts them (score.frame_counts), lanes read as its reader reads a `.lines.json`
(reader.frame_of_record), each image at its own size."""

from __future__ import annotations

from pathlib import Path
from typing import Any, Sequence

import numpy as np

from ...in_memory import TruthMemo, point_arrays
from ...scoring import PlainTable

from .reader import (every_labelled_image, frame_of_record, image_size, lanes_path, read_frame, read_list)
from .score import COLUMNS, checked_truth, frame_counts, method_rows, score_thresholds


class CurveLanesMetric:
    """`F1`, `precision`, `recall` at the fixed score threshold (and `best/F1`, ... with its
    threshold `best/score_threshold`, over `best_of`, chosen on the test set as vega's summary)."""

    name = "curvelanes"

    def __init__(self, labels: str | Path, image_root: str | Path, list_file: str | Path | None = None,
                 score_threshold: float = 0.0, best_of: Sequence[float] = ()):
        if isinstance(best_of, (str, bytes)) or not isinstance(best_of, Sequence):
            raise ValueError(f"best_of must be a sequence of score thresholds, got a {type(best_of).__name__}")
        self.best_of = tuple(float(t) for t in best_of)
        self.thresholds = score_thresholds(float(score_threshold), self.best_of)
        self.labels, self.images = Path(labels), Path(image_root)
        self.frames = tuple(read_list(Path(list_file)) if list_file is not None else every_labelled_image(self.labels))
        self.truth = TruthMemo(self._sized_truth)

    def _sized_truth(self, frame: str):
        width, height = image_size(self.images, frame)
        path = lanes_path(self.labels, frame)
        return width, height, checked_truth(read_frame(path, True), path, width, height)

    def frame_counts(self, frame: str, lanes: Any, scores: Any = None) -> np.ndarray:
        """(thresholds, 3) of the image: `lanes`, (N, 2) arrays of (x, y) pixels; `scores`, one
        per lane (a lane without one is always kept, as a file's plain list of points)."""
        arrays = point_arrays(lanes)
        if scores is not None and len(scores) != len(arrays):
            raise ValueError(f"{len(scores)} scores for {len(arrays)} lanes")
        lines = []
        for index, array in enumerate(arrays):
            line: Any = [{"x": x, "y": y} for x, y in array.tolist()]
            if scores is not None:
                line = {"points": line, "score": float(scores[index])}
            lines.append(line)
        predicted = frame_of_record({"Lines": lines}, frame)
        width, height, truth = self.truth(frame)
        return frame_counts(truth, predicted, frame, width, height, self.thresholds)

    def tables(self, counts: Sequence[np.ndarray | None]) -> dict[str, PlainTable]:
        """official.csv's rows as `score curvelanes` writes them (method '-'); frames never
        updated have no lanes, as a missing prediction file."""
        total = np.zeros((len(self.thresholds), 3), np.int64)
        for frame, value in zip(self.frames, counts):
            total += self.frame_counts(frame, []) if value is None else value
        return {"official": PlainTable(COLUMNS, tuple(method_rows("-", self.thresholds, self.best_of, total)))}

    def compute(self, counts: Sequence[np.ndarray | None]) -> dict[str, float]:
        out: dict[str, float] = {}
        for _, threshold, chosen, _, _, _, precision, recall, f1 in self.tables(counts)["official"].rows:
            prefix = "" if chosen == "fixed" else "best/"
            out.update({f"{prefix}F1": float(f1), f"{prefix}precision": float(precision),
                        f"{prefix}recall": float(recall)})
            if prefix:
                out["best/score_threshold"] = float(threshold)
        return out
