"""CULane (Pan et al., AAAI 2018): scored by the official evaluator's protocol
(SCNN tools/lane_evaluation) over all lanes at full resolution, per category, and the same
protocol restricted to the two ego lanes ("ego" row); lanes written as mirrored .lines.txt."""

from __future__ import annotations

from array import array
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Mapping, Sequence

import numpy as np
import pandas as pd

from ..config import EvalConfig
from . import LaneFile
from ..datasets.culane import labels_path
from ..extract.protocol import Prediction
from ..json_fields import json_number, read_count, read_float, read_list
from ..lanes_io import format_culane_lines
from ..metrics.culane_official import CulaneFrameResult, ScoredFrames, matched_result, official_masks, sweep_rows
from ..metrics.paper import ego_lanes
from ..metrics.raster import MaskSet
from ..model import Clip, Dataset, Frame, Lane


@dataclass(frozen=True)
class CulaneOfficial:
    """One frame of one method: the official outcome over all lanes, and over the ego lanes
    alone (whose recall is the paper's accuracy measured the official way: full resolution,
    30 px, one-to-one matching)."""

    all_lanes: CulaneFrameResult
    ego: CulaneFrameResult

    def to_json(self) -> Any:
        # tolist(): Python floats at once, not a numpy scalar per value (the main process encodes every frame)
        return {"culane": [[part.n_gt, part.n_pred, [json_number(v) for v in part.matched_iou.tolist()]]
                           for part in (self.all_lanes, self.ego)]}


@dataclass(frozen=True, eq=False)
class _Truth:
    lanes: tuple[Lane, ...]
    masks: MaskSet  # official_masks of the lanes
    ego_rows: list[int]
    size: tuple[int, int, int]  # image width, height, official lane width


class CulaneBenchmark:
    name = "culane"
    kernel_groups = ("official",)
    missing_maps_hint = ""

    def label_paths(self, clip: Clip, data_root: Path | None, label_file: Path | None) -> list[Path]:
        if data_root is None:
            return []
        return [labels_path(data_root, frame.relpath) for frame in clip.frames]

    def prepare(self, frame: Frame, config: EvalConfig) -> _Truth:
        width, height = config.dataset.image_width, config.dataset.image_height
        size = (width, height, config.official.lane_width_px)
        ego = ego_lanes(frame.lanes, width, height, config.roneld.center_ratio)
        rows = [i for lane in ego if lane is not None for i, other in enumerate(frame.lanes) if other is lane]
        return _Truth(frame.lanes, official_masks(frame.lanes, *size), rows, size)

    def score(self, prepared: _Truth, prediction: Prediction, config: EvalConfig) -> CulaneOfficial:
        lanes = prediction.lanes
        # Every IoU at once; the ego lanes' outcome is matched on its rows and columns (the same
        # IoUs evaluate_culane_frame would compute again for those lanes alone).
        if prepared.lanes and lanes:
            similarity = prepared.masks.ious(official_masks(lanes, *prepared.size))
        else:
            similarity = np.zeros((len(prepared.lanes), len(lanes)))
        active = [i for lane in prediction.active if lane is not None for i, other in enumerate(lanes) if other is lane]
        return CulaneOfficial(matched_result(similarity), matched_result(similarity, prepared.ego_rows, active))

    def tally(self, methods: Sequence[str], dataset: Dataset, config: EvalConfig) -> "CulaneTally":
        return CulaneTally(tuple(methods), dataset.categories, config.official.iou_threshold)

    def decode(self, value: Any) -> CulaneOfficial:
        if not isinstance(value, dict) or set(value) != {"culane"}:
            raise TypeError("not a CULane official record")
        parts = []
        for n_gt, n_pred, matched in read_list(value["culane"]):
            ious = np.array([read_float(v) for v in read_list(matched)], np.float64)
            if ious.size != read_count(n_gt):
                raise ValueError("matched IoUs do not match the lane count")
            parts.append(CulaneFrameResult(read_count(n_gt), read_count(n_pred), ious))
        if len(parts) != 2:
            raise ValueError("a CULane record holds all lanes and ego lanes")
        return CulaneOfficial(*parts)

    def lane_file(self, method: str, frame: Frame, lanes: Sequence[Lane]) -> LaneFile:
        return LaneFile(f"{method}/{frame.stem}.lines.txt", format_culane_lines(lanes))


@dataclass
class _Columns:
    """One method's frame results as compact columns, in the order they were added."""

    frames: list[str] = field(default_factory=list)
    n_gt: array = field(default_factory=lambda: array("q"))
    n_pred: array = field(default_factory=lambda: array("q"))
    matched_iou: array = field(default_factory=lambda: array("d"))

    def add(self, relpath: str, result: CulaneFrameResult) -> None:
        self.frames.append(relpath)
        self.n_gt.append(result.n_gt)
        self.n_pred.append(result.n_pred)
        self.matched_iou.extend(np.asarray(result.matched_iou, np.float64).tolist())

    def scored(self) -> ScoredFrames:
        n_gt = np.array(self.n_gt, np.int64)
        return ScoredFrames(tuple(self.frames), n_gt, np.array(self.n_pred, np.int64).reshape(1, len(self.frames)),
                            np.array(self.matched_iou, np.float64).reshape(1, int(n_gt.sum())))


class CulaneTally:
    """The official table, gathered frame by frame as compact columns (some 100 bytes a frame
    and method instead of the records' objects), so a long run's main process stays small."""

    def __init__(self, methods: Sequence[str], categories: Mapping[str, frozenset[str]], threshold: float):
        self.categories = categories
        self.threshold = threshold
        self.columns = {method: (_Columns(), _Columns()) for method in methods}  # all lanes, ego lanes

    def add(self, method: str, relpath: str, record: CulaneOfficial) -> None:
        every, ego = self.columns[method]
        every.add(relpath, record.all_lanes)
        ego.add(relpath, record.ego)

    def table(self) -> pd.DataFrame:
        tables = []
        for method, (every, ego_only) in self.columns.items():
            table = self._rows(every, self.categories)
            ego = self._rows(ego_only, {})
            ego["category"] = "ego"
            table = pd.concat([table, ego], ignore_index=True)
            table.insert(0, "method", method)
            tables.append(table)
        return pd.concat(tables, ignore_index=True)

    def _rows(self, columns: _Columns, categories: Mapping[str, frozenset[str]]) -> pd.DataFrame:
        table = sweep_rows(columns.scored(), ["-"], categories, [self.threshold])
        return table.drop(columns=["method", "threshold"]).reset_index(drop=True)


BENCHMARK = CulaneBenchmark()
