"""LLAMAS (Behrendt & Soussan, ICCV 2019 workshops): recordings of continuous video whose labels
give four lanes l1, l0, r0, r1 (l0 and r0 the ego lanes), scored as its culane_metric/evaluate.py
scores lane files (F1 at IoU 0.5, with the 0.75 and mF1 papers print; `score llamas`:
score.py, which also gives the AP of probability maps). `run` reads one
split's labels folder (reader.py) and the maps a segmentation model wrote as
`<frame>.json_<c>.png` (maps format "llamas-png"), or a detector's `.lines.txt`; a recording is a clip."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any, Sequence

import numpy as np

from ...config import EvalConfig
from ...errors import ConfigError
from ...json_fields import json_number, read_count, read_float, read_list
from ...lanes_io import format_lines_txt
from ...maps.lanes import LinesPerFrame
from ...model import Clip, Dataset, Frame, Lane
from .. import LaneFile, declared_command, from_module

if TYPE_CHECKING:  # annotations only: `score` starts without pandas or the extractors
    import pandas as pd

    from ...extract.protocol import Prediction

THRESHOLDS = "0.50:0.95:0.05"  # as `score llamas` scores them: F1@0.5, F1@0.75, and the grid of mF1


@dataclass(frozen=True)
class LlamasPart:
    """One frame of one method over some lanes: lane counts and the IoUs of the pairs the
    assignment matched (a TP where IoU > the threshold)."""

    n_gt: int
    n_pred: int
    matched: tuple[float, ...]

    def to_json(self) -> list:
        return [self.n_gt, self.n_pred, [json_number(v) for v in self.matched]]


@dataclass(frozen=True)
class LlamasOfficial:
    """All lanes, and the two ego lanes of the ground truth against the method's two active lanes."""

    all_lanes: LlamasPart
    ego: LlamasPart

    def to_json(self) -> Any:
        return {"llamas": [self.all_lanes.to_json(), self.ego.to_json()]}


@dataclass(frozen=True, eq=False)
class _Truth:
    masks: list  # the labelled lanes drawn as evaluate.py draws them
    ego_rows: list[int]  # which of them are the ego lanes
    lane_width: int


def _prediction_name(relpath: str) -> str:
    """Where a frame's lanes lie under a prediction folder: its key (evaluate.py's naming)."""
    from .reader import frame_key

    return frame_key(relpath)


class LlamasBenchmark:
    name = "llamas"
    display_name = "LLAMAS"
    image_size = (1276, 717)
    default_preset = "segmentation-llamas"
    frames_per_clip = 10  # what `synth` writes a clip
    synth_maps_format = "lanes"  # a detector's lane files, for `score llamas`; llamas-png: maps for `run`
    fixture: str | None = None
    kernel_groups: tuple[str, ...] = ()  # its official scoring is OpenCV's drawing and scipy's
    missing_maps_hint = ""
    detector_lanes = LinesPerFrame(name_of=_prediction_name)  # what run --save-lanes writes

    # loaded from this folder when first used (benchmarks.from_module): the command, its library
    # scorer (roneld_eval.score; a merge runs it on parts' arrays), the in-memory metric's core
    score_command = declared_command(".command")
    scorer = from_module(".score", "score_llamas")
    metric = from_module(".metric", "LlamasMetric", call=True)
    # `run --diagnose`: the lanes a run saved, scored with --diagnose over the frames it scored
    diagnose_run = from_module(".score", "diagnose_run", call=True)

    def read(self, root: Path, list_file: Path | None, limit: int | None, errors: list | None,
             labels: bool) -> Dataset:
        from .reader import read_llamas_run

        if list_file is not None:
            raise ConfigError("LLAMAS has no list file: every label below the labels folder is scored "
                              "(give one split's folder, labels/valid)")
        width, height = self.image_size
        clips = tuple(Clip(name, frames) for name, frames in read_llamas_run(root, limit))
        dataset = Dataset(name=self.name, root=root, image_width=width, image_height=height, clips=clips,
                          labels_loaded=False)
        if labels:
            clips = tuple(self.with_labels(clip, root, errors) for clip in clips)
            dataset = Dataset(name=self.name, root=root, image_width=width, image_height=height, clips=clips)
        return dataset

    def with_labels(self, clip: Clip, root: Path, errors: list | None) -> Clip:
        from .reader import with_labels

        return with_labels(clip, root, errors)

    def synthesize(self, out: Path, clips: int, frames: int, seed: int, maps_format: str, progress) -> Any:
        from .synth import synth_llamas

        return synth_llamas(out, clips, frames, seed, maps_format, progress=progress)

    def label_paths(self, clip: Clip, data_root: Path | None, label_file: Path | None) -> list[Path]:
        from ...datasets._paths import under_root

        if data_root is None:
            return []
        return [under_root(data_root, frame.relpath) for frame in clip.frames]

    def prepare(self, frame: Frame, config: EvalConfig) -> _Truth:
        from .official import lane_mask
        from ...metrics.paper import ego_lanes

        width, height = self.image_size
        thickness = config.official.lane_width_px
        ego = ego_lanes(frame.lanes, width, height, config.roneld.center_ratio)
        rows = [i for lane in ego if lane is not None for i, other in enumerate(frame.lanes) if other is lane]
        return _Truth([lane_mask(lane.points, width, height, thickness) for lane in frame.lanes], rows, thickness)

    def score(self, prepared: _Truth, prediction: Prediction, config: EvalConfig) -> LlamasOfficial:
        from .official import interpolated, iou_matrix, lane_mask, matched_ious

        width, height = self.image_size
        # load_prediction keeps lanes of two points or more; interpolate_lane's splprep may refuse one
        # (the script stops; here it is left out, as `score llamas` leaves it out)
        kept, masks = [], []
        for lane in prediction.lanes:
            samples = interpolated(lane) if len(lane.points) >= 2 else None
            if samples is not None:
                kept.append(lane)
                masks.append(lane_mask(samples, width, height, prepared.lane_width))
        ious = iou_matrix(masks, prepared.masks)
        active = [k for lane in prediction.active if lane is not None for k, other in enumerate(kept) if other is lane]
        ego_ious = ious[np.ix_(np.array(active, np.intp), np.array(prepared.ego_rows, np.intp))]
        return LlamasOfficial(
            LlamasPart(len(prepared.masks), len(masks), tuple(matched_ious(ious).tolist())),
            LlamasPart(len(prepared.ego_rows), len(active), tuple(matched_ious(ego_ious).tolist())))

    def tally(self, methods: Sequence[str], dataset: Dataset, config: EvalConfig) -> "LlamasTally":
        return LlamasTally(tuple(methods))

    def decode(self, value: Any) -> LlamasOfficial:
        if not isinstance(value, dict) or set(value) != {"llamas"}:
            raise TypeError("not a LLAMAS official record")
        parts = []
        for part in read_list(value["llamas"]):
            n_gt, n_pred, matched = read_list(part)
            ious = tuple(read_float(v) for v in read_list(matched))
            n_gt, n_pred = read_count(n_gt), read_count(n_pred)
            if len(ious) != min(n_gt, n_pred):
                raise ValueError("matched IoUs do not match the lane counts")
            parts.append(LlamasPart(n_gt, n_pred, ious))
        if len(parts) != 2:
            raise ValueError("a LLAMAS record holds all lanes and the ego lanes")
        return LlamasOfficial(*parts)

    def lane_file(self, method: str, frame: Frame, lanes: Sequence[Lane]) -> LaneFile:
        # where `score llamas --pred-root lanes/METHOD` looks: <recording>/<frame>.lines.txt
        return LaneFile(f"{method}/{_prediction_name(frame.relpath)}.lines.txt", format_lines_txt(lanes))

    def official_protocol(self, protocol) -> str | None:
        if protocol is None:
            return None
        g = protocol.geometry
        return (f"lanes through splprep (50 samples) drawn {g.official_lane_width_px} px wide at "
                f"{g.image_width}x{g.image_height}, a match counts when IoU > the threshold")

    def official_note(self, protocol) -> str:
        text = self.official_protocol(protocol)
        return ("unsupervised_llamas culane_metric/evaluate.py (9b99f46): F1 at IoU 0.5 (its own) and 0.75, mF1 "
                "as CLRNet computes it; 'ego': the two ego lanes against each method's two active lanes"
                + (f"; {text}." if text else "."))

    def category_panel(self, official, protocol):
        return None  # its datasets have no categories

    # official.csv as compare reads it back
    official_columns = {"method": "text", "category": "text", "threshold": "text", "tp": "count", "fp": "count",
                        "fn": "count", "f1": "optional number", "mf1": "optional number"}
    official_optional: dict[str, str] = {}
    official_key = ("method", "category", "threshold")

    def check_official(self, path: Path, table: pd.DataFrame) -> None:
        pass

    def official_comparison(self, groups) -> tuple[Any, str]:
        text = ("Official LLAMAS scores (unsupervised_llamas culane_metric/evaluate.py, 9b99f46): F1 (%) at IoU 0.5 "
                "and 0.75, and mF1 (%) as CLRNet computes it. 'all': every lane; 'ego': the two ego lanes of the "
                "ground truth against each method's two active lanes, where preceding-frame tracking acts.")
        return _official_grid(groups), text


def _official_grid(groups):
    """F1 at 0.5 and 0.75 and mF1 per model and method: all lanes, then the ego lanes."""
    from ..grids import lanes_grid

    return lanes_grid(groups, [("0.50", "f1"), ("0.75", "f1"), ("0.50", "mf1")], ("F1@0.5", "F1@0.75", "mF1"))


class LlamasTally:
    """The official table counted frame by frame: TP, FP, FN per method, lanes and threshold."""

    def __init__(self, methods: Sequence[str]):
        from ...thresholds import parse_thresholds
        from .score import MF1_THRESHOLDS

        self.methods = tuple(methods)
        self.thresholds = parse_thresholds(THRESHOLDS)
        self.scored_at = tuple(self.thresholds.values) + MF1_THRESHOLDS
        self.counts = {method: {part: np.zeros((len(self.scored_at), 3), np.int64) for part in ("all", "ego")}
                       for method in self.methods}

    def add(self, method: str, relpath: str, record: LlamasOfficial) -> None:
        from .official import counts_at

        for part, result in (("all", record.all_lanes), ("ego", record.ego)):
            self.counts[method][part] += counts_at(np.array(result.matched, np.float64), result.n_pred,
                                                   result.n_gt, self.scored_at)

    def end_clip(self, clip_id: str) -> None:
        pass  # frame metrics only

    def table(self) -> pd.DataFrame:
        """official.csv: per method, all lanes then ego lanes, a row per threshold with the mF1 beside."""
        import pandas as pd

        from .official import f1_of
        from .score import MF1_THRESHOLDS

        rows = []
        n = len(self.thresholds.values)
        for method in self.methods:
            for part in ("all", "ego"):
                counts = self.counts[method][part]
                mf1 = 0.0
                for t in range(n, len(self.scored_at)):  # llamas_metric.py: mean_f1 += f1 / 10
                    mf1 += f1_of(*(int(v) for v in counts[t]))[2] / len(MF1_THRESHOLDS)
                for t, label in enumerate(self.thresholds.labels):
                    tp, fp, fn = (int(v) for v in counts[t])
                    rows.append((method, part, label, tp, fp, fn, *f1_of(tp, fp, fn), mf1))
        return pd.DataFrame(rows, columns=["method", "category", "threshold", "tp", "fp", "fn", "precision",
                                           "recall", "f1", "mf1"])


BENCHMARK = LlamasBenchmark()
