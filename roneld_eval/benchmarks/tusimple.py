"""TuSimple (tusimple-benchmark): scored as its evaluate/lane.py does, lanes sampled at the
frame's h_samples; the labels are one file; lanes written as one JSON line per frame."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any, Sequence

import pandas as pd

from ..config import EvalConfig
from . import LaneFile
from ..extract.protocol import Prediction
from ..json_fields import json_number, read_float, read_list
from ..lanes_io import format_tusimple_record, sample_lane_at_rows, tusimple_xs
from ..metrics.tusimple_official import bench_frame, mean_scores
from ..model import Clip, Dataset, Frame, Lane


@dataclass(frozen=True)
class TusimpleOfficial:
    """One frame of one method: lane.py's accuracy, FP and FN ratios."""

    accuracy: float
    fp: float
    fn: float

    def to_json(self) -> Any:
        return {"scores": [json_number(v) for v in (self.accuracy, self.fp, self.fn)]}


@dataclass(frozen=True, eq=False)
class _Truth:
    rows: tuple[int, ...]
    lanes_xs: list[list[float]]


class TusimpleBenchmark:
    name = "tusimple"
    kernel_groups: tuple[str, ...] = ()
    missing_maps_hint = " (each TuSimple clip needs maps for all its 20 frames)"

    def label_paths(self, clip: Clip, data_root: Path | None, label_file: Path | None) -> list[Path]:
        return [] if label_file is None else [label_file]

    def prepare(self, frame: Frame, config: EvalConfig) -> _Truth:
        rows = frame.h_samples or ()
        return _Truth(rows, [tusimple_xs(lane, rows) for lane in frame.lanes])

    def score(self, prepared: _Truth, prediction: Prediction, config: EvalConfig) -> TusimpleOfficial:
        pred_xs = [sample_lane_at_rows(lane, prepared.rows) for lane in prediction.lanes]
        return TusimpleOfficial(*bench_frame(pred_xs, prepared.lanes_xs, prepared.rows, 0.0))

    def tally(self, methods: Sequence[str], dataset: Dataset, config: EvalConfig) -> "TusimpleTally":
        return TusimpleTally(tuple(methods))

    def decode(self, value: Any) -> TusimpleOfficial:
        if not isinstance(value, dict) or set(value) != {"scores"}:
            raise TypeError("not a TuSimple official record")
        scores = [read_float(v) for v in read_list(value["scores"])]
        if len(scores) != 3:
            raise ValueError("a TuSimple record holds accuracy, FP and FN")
        return TusimpleOfficial(*scores)

    def lane_file(self, method: str, frame: Frame, lanes: Sequence[Lane]) -> LaneFile:
        rows = frame.h_samples or ()
        lanes_xs = [sample_lane_at_rows(lane, rows) for lane in lanes]
        text = format_tusimple_record(frame.relpath, lanes_xs, rows, 0) + "\n"
        return LaneFile(f"{method}/predictions.json", text, append=True)


class TusimpleTally:
    """The official table, summed frame by frame in frame order as lane.py sums: three running
    sums and a count per method, whatever the number of frames."""

    def __init__(self, methods: Sequence[str]):
        self.sums = {method: [0.0, 0.0, 0.0] for method in methods}  # accuracy, FP, FN
        self.frames = {method: 0 for method in methods}

    def add(self, method: str, relpath: str, record: TusimpleOfficial) -> None:
        sums = self.sums[method]
        sums[0] += record.accuracy
        sums[1] += record.fp
        sums[2] += record.fn
        self.frames[method] += 1

    def table(self) -> pd.DataFrame:
        """method, accuracy, fp, fn and the F1 papers print (f1_ufld, f1_clrnet), as `score tusimple`."""
        rows = []
        for method, (accuracy, fp, fn) in self.sums.items():
            rows.append(dict(method=method, **mean_scores([(accuracy, fp, fn)], self.frames[method]).as_row()))
        return pd.DataFrame(rows, columns=["method", "accuracy", "fp", "fn", "f1_ufld", "f1_clrnet"])


BENCHMARK = TusimpleBenchmark()
