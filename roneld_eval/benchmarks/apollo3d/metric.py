"""Apollo 3D Synthetic's official metric in memory (`roneld_eval.metric("apollo3d", labels=...)`):
each frame's counts at every threshold and its counted matches' errors, as `score apollo3d` gets
them (official.frame_sweep), from lanes held in memory: (N, 3) arrays of ground coordinates (x
right, y forward, z up, metres) with a probability each, for lane lines and, where given, centre
lines. The averages run over the frames in the label file's order (the evaluator follows the
prediction file's, which `score apollo3d` does)."""

from __future__ import annotations

from pathlib import Path
from typing import Any, Sequence

import numpy as np

from ...in_memory import scored_3d_lanes
from ...scoring import PlainTable
from .official import COUNTS, LANE_TYPES, THRESHOLDS, FrameSweep, frame_sweep
from .score import NUMBERS, _read_labels, _score


class Apollo3dMetric:
    """AP, F, recall, precision and the x/z errors near and far, for lane lines and centre lines."""

    name = "apollo3d"

    def __init__(self, labels: str | Path):
        self.labels = Path(labels)
        keys, truths = _read_labels(self.labels)
        self.frames = tuple(keys)
        self._truth = dict(zip(keys, truths))

    def frame_counts(self, frame: str, lanes: Any, scores: Any = None, center_lanes: Any = None,
                     center_scores: Any = None) -> dict[str, FrameSweep]:
        """The frame's sweep for lane lines (`lanes` with their probabilities `scores`) and, when
        `center_lanes` are given, centre lines (with `center_scores`)."""
        truth = self._truth[frame]
        found = {}
        for kind, given, probabilities in (("laneline", lanes, scores), ("centerline", center_lanes, center_scores)):
            if given is None:
                continue
            arrays, chances = scored_3d_lanes(given, probabilities, kind, ("probability", "probabilities"),
                                              widths=(2, 3))
            found[kind] = frame_sweep(arrays, chances, truth.lanes[kind] or (), truth.visibility[kind] or ())
        return found

    def _nothing(self, frame: str, kind: str) -> FrameSweep:
        """A frame of no predicted lane of this type (never updated, or updated without them)."""
        truth = self._truth[frame]
        return frame_sweep([], [], truth.lanes[kind] or (), truth.visibility[kind] or ())

    def _arrays(self, counts: Sequence[dict[str, FrameSweep] | None]) -> tuple[np.ndarray, np.ndarray, tuple]:
        centres = any(value is not None and "centerline" in value for value in counts)
        kinds = LANE_TYPES if centres else LANE_TYPES[:1]
        array = np.zeros((len(self.frames), 1, 2, len(THRESHOLDS), len(COUNTS)))
        rows = []
        for f, frame in enumerate(self.frames):
            value = counts[f] or {}
            for t, kind in enumerate(kinds):
                sweep = value.get(kind) or self._nothing(frame, kind)
                array[f, 0, t] = sweep.counts
                for k, errors in enumerate(sweep.errors):
                    rows.append(np.column_stack([np.tile([0, f, t, k], (len(errors), 1)), errors]))
        return array, np.concatenate(rows) if rows else np.zeros((0, 8)), kinds

    def tables(self, counts: Sequence[dict[str, FrameSweep] | None]) -> dict[str, PlainTable]:
        """official.csv's and sweep.csv's rows as `score apollo3d` writes them (method '-')."""
        array, errors, kinds = self._arrays(counts)
        score = _score(["-"], [kinds], [np.arange(len(self.frames))], array, errors, len(self.frames), [])
        return {"official": score.rows, "sweep": score.sweep}

    def compute(self, counts: Sequence[dict[str, FrameSweep] | None]) -> dict[str, float]:
        rows = self.tables(counts)["official"]
        found = {}
        for row in rows.rows:
            prefix = "" if row[1] == "laneline" else "centerline_"
            named = dict(zip(rows.columns, row))
            found.update({f"{prefix}{name}": float(named[name]) for name in ("threshold", *NUMBERS)})
        return found

