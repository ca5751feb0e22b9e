"""CULane (Pan et al., AAAI 2018): scored by the official evaluator's protocol
(SCNN tools/lane_evaluation) over all lanes at full resolution, per category, and the same
protocol restricted to the two ego lanes ("ego" row); lanes written as mirrored .lines.txt."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any, Mapping, Sequence

import numpy as np
from ...config import EvalConfig
from .. import CategoryPanel, LaneFile, declared_command, from_module
from .reader import IMAGE_HEIGHT, IMAGE_WIDTH, labels_path, read_culane, with_labels
from ...json_fields import json_number, read_count, read_float, read_list
from ...lanes_io import format_lines_txt
from ...maps.lanes import LinesPerFrame
from ...metrics.lane_iou_f1 import (OFFICIAL_COLUMNS, FrameMatches, GroupCounts, ScoredFrames, matched_result,
                                    official_masks)
from ...metrics.paper import ego_lanes
from ...metrics.raster import MaskSet
from ...model import Clip, Dataset, Frame, Lane

if TYPE_CHECKING:  # annotations only: `score` starts without pandas or the extractors
    import pandas as pd

    from ...extract.protocol import Prediction


def _official_settings(protocol) -> str:
    """The official CULane protocol as the run drew it (`protocol`: report.tables.Protocol)."""
    g = protocol.geometry
    return (f"all lanes drawn {g.official_lane_width_px} px wide at {g.image_width}x{g.image_height}, "
            f"a match counts when IoU > {g.official_iou_threshold:g}")


@dataclass(frozen=True)
class CulaneOfficial:
    """One frame of one method: the official outcome over all lanes, and over the ego lanes
    alone (whose recall is the paper's accuracy measured the official way: full resolution,
    30 px, one-to-one matching)."""

    all_lanes: FrameMatches
    ego: FrameMatches

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
    display_name = "CULane"
    image_size = (IMAGE_WIDTH, IMAGE_HEIGHT)
    default_preset = "scnn-culane"
    frames_per_clip = 12
    fixture: str | None = "culane"
    kernel_groups = ("official",)
    missing_maps_hint = ""
    detector_lanes = LinesPerFrame()  # what run --save-lanes writes

    # loaded from this folder when first used (benchmarks.from_module): the command, its library
    # scorer (roneld_eval.score), its parts' merger, the in-memory metric's core
    score_command = declared_command(".command")
    scorer = from_module(".score", "score_culane")
    metric = from_module(".metric", "CulaneMetric", call=True)
    # `run --diagnose`: the lanes a run saved, scored with --diagnose over the frames it scored
    diagnose_run = from_module(".score", "diagnose_run", call=True)
    merge_parts = from_module(".score", "merge_culane_parts", call=True)

    def read(self, root: Path, list_file: Path | None, limit: int | None, errors: list | None,
             labels: bool) -> Dataset:
        return read_culane(root, list_file, limit, errors, labels, require_labels=True)

    def with_labels(self, clip: Clip, root: Path, errors: list | None) -> Clip:
        return with_labels(clip, root, errors)

    def synthesize(self, out: Path, clips: int, frames: int, seed: int, maps_format: str, progress) -> Any:
        from .synth import synth_culane

        return synth_culane(out, clips, frames, seed, maps_format, progress=progress)

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
        # IoUs match_frame would compute again for those lanes alone).
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
            parts.append(FrameMatches(read_count(n_gt), read_count(n_pred), ious))
        if len(parts) != 2:
            raise ValueError("a CULane record holds all lanes and ego lanes")
        return CulaneOfficial(*parts)

    def lane_file(self, method: str, frame: Frame, lanes: Sequence[Lane]) -> LaneFile:
        return LaneFile(f"{method}/{frame.stem}.lines.txt", format_lines_txt(lanes))

    def official_protocol(self, protocol) -> str | None:
        return _official_settings(protocol)

    def official_note(self, protocol) -> str:
        return ("SCNN's CULane evaluator per category, and 'ego': the two ego lanes only"
                + (f"; {_official_settings(protocol)}." if protocol is not None else "."))

    def category_panel(self, official: pd.DataFrame, protocol) -> CategoryPanel:
        return CategoryPanel(official[["method", "category", "f1"]].rename(columns={"f1": "score"}),
                             "Official CULane F1, all lanes", "F1",
                             None if protocol is None else _official_settings(protocol),
                             "F1 over all lanes counts the outer lanes as missed (compare on the 'ego' row of "
                             "official.csv)")

    # official.csv as compare reads it back: required and optional columns, and its key
    official_columns = {"method": "text", "category": "text", "tp": "count", "fp": "count", "fn": "count",
                        "f1": "optional number"}
    official_optional: dict[str, str] = {}
    official_key = ("method", "category")

    def check_official(self, path: Path, table: pd.DataFrame) -> None:
        pass

    def official_comparison(self, groups) -> tuple[Any, str]:
        """compare's official table of these run groups (one dataset), and the text above it."""
        settings = dict(groups[0].runs[0].protocol)
        text = (f"Official {self.display_name} F1 (%) per category (all lanes, "
                f"{settings.get('official.lane_width_px')} px wide, a match counts when IoU > "
                f"{settings.get('official.iou_threshold')}); for 'cross', which has no lanes, the number of false "
                f"positives. 'ego': the same protocol on the two ego lanes and each method's two active lanes.")
        return _official_grid(groups), text


def _official_grid(groups):
    """Official CULane F1 (%) per category (rows) for every model and method (columns); 'cross' as FP."""
    from ...comparison.groups import method_header, method_name, ordered_methods
    from ...comparison.tables import Column, Grid, Text

    categories = list(dict.fromkeys(c for g in groups for r in g.runs for c in r.official["category"]))
    categories = [c for c in categories if c not in ("all", "ego")] + [c for c in ("all", "ego") if c in categories]
    columns, makers = [], []
    for group in groups:
        for method in ordered_methods(group.methods):
            columns.append(Column(method_name(method, group.label) + ("" if group.n == 1 else f" (n = {group.n})"),
                                  method_header(method, group.label), group.title()))
            makers.append((group, method))
    rows = []
    for category in categories:
        cells = [_official_cell(group, method, category) for group, method in makers]
        rows.append((Text("cross (FP)" if category == "cross" else category), *cells))
    return Grid((Column("Category", ("Category",)),), tuple(columns), tuple(rows))


def _official_cell(group, method: str, category: str):
    """A model's official F1 (%) of one method and category over its runs; 'cross' as its FP
    (no lanes to find: the field reports its false positives); empty where a run lacks the row."""
    from ...comparison.groups import all_found
    from ...comparison.tables import EMPTY, Stat

    hits = []
    for run in group.runs:
        table = run.official
        hit = table[(table["method"] == method) & (table["category"] == category)]
        hits.append(None if hit.empty else hit.iloc[0])
    found = all_found(hits)
    if found is None:
        return EMPTY
    if category == "cross":
        return Stat(tuple(float(f["fp"]) for f in found), decimals=0)
    return Stat(tuple(float(f["f1"]) for f in found), decimals=1, scale=100)


class CulaneTally:
    """The official table counted clip by clip by `score culane`'s own per-category sum
    (metrics.lane_iou_f1.GroupCounts) at the run's one threshold, one sum per method (each
    method's records stand alone): a few integers per method and category, and one clip's frame
    records, so the main process stays the same size however many frames."""

    def __init__(self, methods: Sequence[str], categories: Mapping[str, frozenset[str]], threshold: float):
        self.categories = categories
        # all lanes per category (its lists, then every frame), and the ego lanes alone (one "ego" row)
        self.every = {method: GroupCounts.zeros(1, len(categories) + 1, [threshold]) for method in methods}
        self.ego = {method: GroupCounts.zeros(1, 1, [threshold]) for method in methods}
        self.held: dict[str, dict[str, CulaneOfficial]] = {method: {} for method in methods}

    def add(self, method: str, relpath: str, record: CulaneOfficial) -> None:
        self.held[method][relpath] = record

    def end_clip(self, clip_id: str) -> None:
        """The clip's frames added to the sums in one go (frame metrics only)."""
        self._add_frames_held()

    def _add_frames_held(self) -> None:
        for method, records in self.held.items():
            if records:
                self.every[method].add(ScoredFrames.from_results([{f: r.all_lanes for f, r in records.items()}]),
                                       self.categories)
                self.ego[method].add(ScoredFrames.from_results([{f: r.ego for f, r in records.items()}]), {})
                self.held[method] = {}

    def table(self) -> pd.DataFrame:
        self._add_frames_held()  # frames added since the last end_clip count too
        at = OFFICIAL_COLUMNS.index("threshold")
        rows = []
        for method in self.every:
            rows += self.every[method].records([method], list(self.categories))
            ego = self.ego[method].records([method], [])[0]
            rows.append(ego[:1] + ("ego",) + ego[2:])
        import pandas as pd

        return pd.DataFrame([row[:at] + row[at + 1:] for row in rows],
                            columns=[column for column in OFFICIAL_COLUMNS if column != "threshold"])


BENCHMARK = CulaneBenchmark()
