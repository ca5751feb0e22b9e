"""CULane (Pan et al., AAAI 2018): scored by the official evaluator's protocol
(SCNN tools/lane_evaluation) over all lanes at full resolution, per category, and the same
protocol restricted to the two ego lanes ("ego" row); lanes written as mirrored .lines.txt."""

from __future__ import annotations

from dataclasses import dataclass
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
from ..metrics.culane_official import CulaneFrameResult, category_table, evaluate_culane_frame, official_masks
from ..metrics.paper import ego_lanes
from ..model import Clip, Dataset, Frame, Lane


@dataclass(frozen=True)
class CulaneOfficial:
    """One frame of one method: the official outcome over all lanes, and over the ego lanes
    alone (whose recall is the paper's accuracy measured the official way: full resolution,
    30 px, one-to-one matching)."""

    all_lanes: CulaneFrameResult
    ego: CulaneFrameResult

    def to_json(self) -> Any:
        return {"culane": [[part.n_gt, part.n_pred, [json_number(v) for v in part.matched_iou]]
                           for part in (self.all_lanes, self.ego)]}


@dataclass(frozen=True, eq=False)
class _Truth:
    lanes: tuple[Lane, ...]
    masks: list
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
        lanes, size, gt_masks = list(prediction.lanes), prepared.size, prepared.masks
        pred_masks = official_masks(lanes, *size)
        every = evaluate_culane_frame(prepared.lanes, lanes, *size, gt_masks=gt_masks, pred_masks=pred_masks)
        active = [i for lane in prediction.active if lane is not None for i, other in enumerate(lanes) if other is lane]
        ego = evaluate_culane_frame(
            [prepared.lanes[i] for i in prepared.ego_rows], [lanes[i] for i in active], *size,
            gt_masks=[gt_masks[i] for i in prepared.ego_rows], pred_masks=[pred_masks[i] for i in active],
        )
        return CulaneOfficial(every, ego)

    def table(self, records: Mapping[str, Sequence[tuple[str, CulaneOfficial]]], dataset: Dataset,
              config: EvalConfig) -> pd.DataFrame:
        threshold = config.official.iou_threshold
        tables = []
        for method, frames in records.items():
            table = category_table({relpath: record.all_lanes for relpath, record in frames}, dataset.categories,
                                   threshold)
            ego = category_table({relpath: record.ego for relpath, record in frames}, {}, threshold)
            ego["category"] = "ego"
            table = pd.concat([table, ego], ignore_index=True)
            table.insert(0, "method", method)
            tables.append(table)
        return pd.concat(tables, ignore_index=True)

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


BENCHMARK = CulaneBenchmark()
