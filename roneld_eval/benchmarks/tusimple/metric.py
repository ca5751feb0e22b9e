"""TuSimple's official metric in memory (`roneld_eval.metric("tusimple", labels=...)`): each frame's
(accuracy, FP, FN) as evaluate/lane.py's LaneEval.bench gives it (official.bench_frame), their
means over the labelled frames summed in the label file's order, and the two F1s papers print."""

from __future__ import annotations

import numbers

from pathlib import Path
from typing import Any, Sequence

import numpy as np

from ...in_memory import numbers_of
from ...lanes_io import MAX_PREDICTED_COORDINATE
from ...scoring import PlainTable
from .official import TusimpleScore, bench_frame, mean_scores, read_labels
from .score import official_table


class TusimpleMetric:
    """`Accuracy`, `FP`, `FN`, `F1_ufld`, `F1_clrnet` over every labelled frame."""

    name = "tusimple"

    def __init__(self, labels: str | Path):
        self.labels = read_labels(labels)
        self.frames = tuple(self.labels)

    def frame_counts(self, frame: str, lanes: Any, scores: Any = None, h_samples: Any = None,
                     run_time: float = 0.0) -> tuple[float, float, float]:
        """(accuracy, fp, fn) of the frame: `lanes`, each lane's x at every row of the label's
        h_samples (negative: no point), as a predictions.json line holds them; `h_samples`, when
        given, must have as many rows (lane.py reads the label's); `run_time` in ms (over 200 ms
        scores the frame (0, 0, 1), as lane.py)."""
        rows = self.labels[frame]["h_samples"]
        if h_samples is not None and len(h_samples) != len(rows):
            raise ValueError(f"h_samples has {len(h_samples)} rows, the label {len(rows)}")
        checked = []
        for index, lane in enumerate(lanes):
            xs = numbers_of(lane, f"lane {index}")
            if xs.ndim != 1 or xs.size != len(rows):
                raise ValueError(f"lane {index}: needs one x per h_samples row ({len(rows)}), got shape {xs.shape}")
            if not np.isfinite(xs).all() or (xs.size and np.abs(xs).max() > MAX_PREDICTED_COORDINATE):
                raise ValueError(f"lane {index}: an x that is not a finite lane coordinate")
            checked.append(xs.tolist())
        if isinstance(run_time, (bool, str, bytes)) or not isinstance(run_time, numbers.Real):
            raise ValueError(f"run_time must be a number of milliseconds, got {run_time!r}")  # as score tusimple
        time = float(run_time)
        if not np.isfinite(time):
            raise ValueError("run_time must be a finite number of milliseconds")
        gt = self.labels[frame]
        return bench_frame(checked, gt["lanes"], rows, time)

    def _score(self, counts: Sequence[tuple[float, float, float] | None]) -> TusimpleScore:
        missing = [frame for frame, value in zip(self.frames, counts) if value is None]
        if missing:  # lane.py: "We do not get the predictions of all the test tasks"
            raise ValueError(f"no lanes given for {len(missing)} of {len(self.frames)} labelled frames (first: "
                             f"{missing[0]}); TuSimple's lane.py refuses predictions that miss a frame")
        return mean_scores([value for value in counts if value is not None], len(self.frames))

    def tables(self, counts: Sequence[tuple[float, float, float] | None]) -> dict[str, PlainTable]:
        """official.csv's row as `score tusimple` writes it (method '-')."""
        return {"official": official_table({"-": self._score(counts)})}

    def compute(self, counts: Sequence[tuple[float, float, float] | None]) -> dict[str, float]:
        score = self._score(counts)
        return {"Accuracy": score.accuracy, "FP": score.fp, "FN": score.fn, "F1_ufld": score.f1_ufld,
                "F1_clrnet": score.f1_clrnet}
