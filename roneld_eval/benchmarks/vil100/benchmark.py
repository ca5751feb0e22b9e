"""VIL-100 (Zhang et al., ICCV 2021): 20 test videos of 100 frames, each at its own size, scored
as MMA-Net's evaluator scores them (F1 at IoU 0.5 and 0.8, mIoU; `score vil100`:
benchmarks/vil100/score.py), with RVLD's temporal metrics over consecutive frames. `run` reads
a dataset root holding MMA-Net's anno_txt (reader.py, `run_sources`); a frame is drawn
and scored at its video's size, and its lanes are written as MMA-Net's pred_txt."""

from __future__ import annotations

import math
import posixpath
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any, Sequence

import numpy as np

from ...config import EvalConfig
from ...json_fields import json_number, read_count, read_float, read_list
from ...lanes_io import format_lines_txt
from ...maps.lanes import LinesPerFrame
from ...model import Clip, Dataset, Frame, Lane
from .. import LaneFile, declared_command, from_module

if TYPE_CHECKING:  # annotations only: `score` starts without pandas or the extractors
    import pandas as pd

    from ...extract.protocol import Prediction
    from ...metrics.lane_iou_f1 import FrameMatches

# evaluate_iou.py:23 ("Set iou to 0.5 or 0.8"): papers report both, whatever official.iou_threshold says
THRESHOLDS = "0.5,0.8"
TEMPORAL = ("pairs", "stable", "jump", "missing", "rs", "rj", "rm")


@dataclass(frozen=True)
class Vil100Part:
    """One frame of one method over some lanes: the CULane evaluator's matching at the frame's
    size (each ground-truth lane's matched IoU), and each ground-truth lane's IoU with the
    prediction RVLD's temporal script assigns it (its own drawing; lanes it drops are not there)."""

    matched: FrameMatches
    assigned: tuple[float, ...]

    def to_json(self) -> list:
        matched = self.matched
        return [matched.n_gt, matched.n_pred, [json_number(v) for v in matched.matched_iou.tolist()],
                [json_number(v) for v in self.assigned]]


@dataclass(frozen=True)
class Vil100Official:
    """One frame of one method: over all lanes, and over the two ego lanes of the ground truth
    against the method's two active lanes (the same protocol on the lanes RONELD tracks)."""

    all_lanes: Vil100Part
    ego: Vil100Part

    def to_json(self) -> Any:
        return {"vil100": [self.all_lanes.to_json(), self.ego.to_json()]}


@dataclass(frozen=True, eq=False)
class _Truth:
    lanes: tuple[Lane, ...]
    masks: Any  # official_masks of the lanes at the frame's size
    ego_rows: list[int]  # the ego lanes among them
    drawn: list  # the temporal script's masks of the lanes it keeps
    ego_drawn: list  # and of the ego lanes it keeps
    size: tuple[int, int, int]  # the frame's width, height and the official lane width


class Vil100Benchmark:
    name = "vil100"
    display_name = "VIL-100"
    image_size = (1920, 1080)  # the largest of its sizes, to which presets refer; each video is scored at its own
    default_preset = "lanes-vil100"
    frames_per_clip = 100
    fixture: str | None = None
    kernel_groups = ("official",)
    missing_maps_hint = ""
    detector_lanes = LinesPerFrame()  # what run --save-lanes writes

    # loaded from this folder when first used (benchmarks.from_module): the command, its library
    # scorer (roneld_eval.score; a merge runs it on parts' arrays), the in-memory metric's core
    score_command = declared_command(".command")
    scorer = from_module(".score", "score_vil100")
    metric = from_module(".metric", "Vil100Metric", call=True)
    # `run --diagnose`: the lanes a run saved, scored with --diagnose over the frames it scored
    diagnose_run = from_module(".score", "diagnose_run", call=True)

    def read(self, root: Path, list_file: Path | None, limit: int | None, errors: list | None,
             labels: bool) -> Dataset:
        from .reader import read_vil100_run

        clips, source = read_vil100_run(root, list_file, limit, errors)
        width, height = self.image_size
        return Dataset(name=self.name, root=root, image_width=width, image_height=height,
                       clips=tuple(Clip(name, frames) for name, frames in clips), source_file=source)

    def with_labels(self, clip: Clip, root: Path, errors: list | None) -> Clip:
        return clip  # read with the list: a hundred small files a video

    def synthesize(self, out: Path, clips: int, frames: int, seed: int, maps_format: str, progress) -> Any:
        from .synth import synth_vil100

        return synth_vil100(out, clips, frames, seed, maps_format, progress=progress)

    def label_paths(self, clip: Clip, data_root: Path | None, label_file: Path | None) -> list[Path]:
        from .reader import LABELS_FOLDER, labels_path, size_files

        if data_root is None:
            return []
        labels = [labels_path(data_root / LABELS_FOLDER, frame.relpath) for frame in clip.frames]
        return labels + (size_files(data_root, clip.frames[0].relpath) if clip.frames else [])

    def prepare(self, frame: Frame, config: EvalConfig) -> _Truth:
        from ...metrics.lane_iou_f1 import official_masks
        from .temporal import lane_mask, usable

        width, height = frame.image_size or self.image_size
        size = (width, height, config.official.lane_width_px)
        ego = _ego(frame, config.roneld.center_ratio)
        rows = [i for lane in ego for i, other in enumerate(frame.lanes) if other is lane]
        return _Truth(frame.lanes, official_masks(frame.lanes, *size), rows,
                      [lane_mask(lane, width, height) for lane in usable(frame.lanes)],
                      [lane_mask(lane, width, height) for lane in usable(ego)], size)

    def score(self, prepared: _Truth, prediction: Prediction, config: EvalConfig) -> Vil100Official:
        from ...metrics.lane_iou_f1 import matched_result, official_masks
        from .temporal import assigned_ious, lane_mask, usable

        lanes = prediction.lanes
        width, height, _ = prepared.size
        # Every IoU at once, as CULane's scorer; the ego lanes' outcome on its rows and columns.
        if prepared.lanes and lanes:
            similarity = prepared.masks.ious(official_masks(lanes, *prepared.size))
        else:
            similarity = np.zeros((len(prepared.lanes), len(lanes)))
        active = [lane for lane in prediction.active if lane is not None]
        columns = [i for lane in active for i, other in enumerate(lanes) if other is lane]
        kept = usable(lanes)
        drawn = [lane_mask(lane, width, height) for lane in kept]
        active_drawn = [drawn[k] for lane in usable(active) for k, other in enumerate(kept) if other is lane][:2]
        return Vil100Official(
            Vil100Part(matched_result(similarity), tuple(assigned_ious(prepared.drawn, drawn).tolist())),
            Vil100Part(matched_result(similarity, prepared.ego_rows, columns),
                       tuple(assigned_ious(prepared.ego_drawn, active_drawn).tolist())))

    def tally(self, methods: Sequence[str], dataset: Dataset, config: EvalConfig) -> "Vil100Tally":
        return Vil100Tally(tuple(methods), dataset, config.roneld.center_ratio)

    def decode(self, value: Any) -> Vil100Official:
        from ...metrics.lane_iou_f1 import FrameMatches

        if not isinstance(value, dict) or set(value) != {"vil100"}:
            raise TypeError("not a VIL-100 official record")
        parts = []
        for part in read_list(value["vil100"]):
            n_gt, n_pred, matched, assigned = read_list(part)
            ious = np.array([read_float(v) for v in read_list(matched)], np.float64)
            if ious.size != read_count(n_gt):
                raise ValueError("matched IoUs do not match the lane count")
            parts.append(Vil100Part(FrameMatches(read_count(n_gt), read_count(n_pred), ious),
                                    tuple(read_float(v) for v in read_list(assigned))))
        if len(parts) != 2:
            raise ValueError("a VIL-100 record holds all lanes and the ego lanes")
        return Vil100Official(*parts)

    def lane_file(self, method: str, frame: Frame, lanes: Sequence[Lane]) -> LaneFile:
        return LaneFile(f"{method}/{frame.stem}.lines.txt", format_lines_txt(lanes))

    def official_protocol(self, protocol) -> str | None:
        if protocol is None:
            return None
        g = protocol.geometry
        return (f"all lanes drawn {g.official_lane_width_px} px wide at each video's own size "
                f"({g.sizes_text() or f'{g.image_width}x{g.image_height}'}), a match counts when IoU > 0.5 or 0.8")

    def official_note(self, protocol) -> str:
        text = self.official_protocol(protocol)
        return ("MMA-Net's VIL-100 evaluator (8f95908) per video, per scenario and over all: F1 at IoU 0.5 and 0.8, "
                "mIoU; RVLD's temporal metrics (4d90de1) Rs, Rj, Rm with each threshold as tau"
                + (f"; {text}." if text else "."))

    def category_panel(self, official, protocol):
        return None  # its datasets have no categories

    # official.csv as compare reads it back
    official_columns = {"method": "text", "category": "text", "threshold": "text", "tp": "count", "fp": "count",
                        "fn": "count", "f1": "optional number", "miou": "optional number"}
    official_optional = {"rs": "optional number", "rj": "optional number", "rm": "optional number"}
    official_key = ("method", "category", "threshold")

    def check_official(self, path: Path, table: pd.DataFrame) -> None:
        pass

    def official_comparison(self, groups) -> tuple[Any, str]:
        text = ("Official VIL-100 scores over all videos (MMA-Net's evaluator, 8f95908): F1 (%) at IoU 0.5 and 0.8 "
                "and mIoU (%); Rs, Rj, Rm (%): RVLD's temporal metrics (4d90de1) at tau 0.5. 'all': every lane; "
                "'ego': the two ego lanes of the ground truth against each method's two active lanes, where "
                "preceding-frame tracking acts.")
        return _official_grid(groups), text


def _official_grid(groups):
    """F1 at 0.5 and 0.8, mIoU, and Rs, Rj, Rm at tau 0.5 per model and method, over all videos:
    all lanes, then the ego lanes."""
    from ...thresholds import parse_thresholds
    from ..grids import lanes_grid

    low, high = parse_thresholds(THRESHOLDS).labels  # as official.csv writes them
    wanted = [(low, "f1"), (high, "f1"), (low, "miou"), (low, "rs"), (low, "rj"), (low, "rm")]
    return lanes_grid(groups, wanted, (f"F1@{low}", f"F1@{high}", "mIoU", "Rs", "Rj", "Rm"))


def _ego(frame: Frame, center_ratio: float) -> list[Lane]:
    """The frame's ground-truth ego lanes, left then right (the paper's: nearest each side of the
    image centre at the bottom row), those there are."""
    from ...metrics.paper import ego_lanes

    width, height = frame.image_size or Vil100Benchmark.image_size
    return [lane for lane in ego_lanes(frame.lanes, width, height, center_ratio) if lane is not None]


class Vil100Tally:
    """The official table gathered video by video: each frame's matched and assigned IoUs per
    method (a few numbers a lane), and at the end of a video the links of its ground truth
    across consecutive frames (what the temporal metrics pair), all lanes and ego lanes."""

    def __init__(self, methods: Sequence[str], dataset: Dataset, center_ratio: float):
        self.methods = tuple(methods)
        self.clips = {clip.clip_id: clip for clip in dataset.clips}
        self.center_ratio = center_ratio
        self.names: list[str] = []
        self.relpaths: list[list[str]] = []  # per video, the frames scored
        self.scored: dict[str, list] = {"all": [], "ego": []}  # ScoredSequence per video
        self.current: dict[str, list[tuple[str, Vil100Official]]] = {method: [] for method in self.methods}

    def add(self, method: str, relpath: str, record: Vil100Official) -> None:
        self.current[method].append((relpath, record))

    def end_clip(self, clip_id: str) -> None:
        first = self.current[self.methods[0]] if self.methods else []
        frames = {frame.relpath: frame for frame in self.clips[clip_id].frames}
        scored = [frames[relpath] for relpath, _ in first]
        self.names.append(posixpath.dirname(scored[0].relpath) if scored else clip_id)
        self.relpaths.append([frame.relpath for frame in scored])
        self.scored["all"].append(self._piece(scored, "all_lanes", lambda frame: frame.lanes))
        self.scored["ego"].append(self._piece(scored, "ego", lambda frame: _ego(frame, self.center_ratio)))
        self.current = {method: [] for method in self.methods}

    def _piece(self, frames: Sequence[Frame], part: str, lanes_of):
        from .official import frame_miou
        from .temporal import lane_mask, links, usable
        from .score import ScoredSequence

        parts = {method: [getattr(record, part) for _, record in self.current[method]] for method in self.methods}
        piece = ScoredSequence([[(p.matched, frame_miou(p.matched)) for p in parts[m]] for m in self.methods], [],
                               [[np.array(p.assigned) for p in parts[m]] for m in self.methods])
        previous: list | None = None
        for frame in frames:  # the frames scored, in video order: the ground truth linked as RVLD links it
            width, height = frame.image_size or Vil100Benchmark.image_size
            drawn = [lane_mask(lane, width, height) for lane in usable(lanes_of(frame))]
            piece.links.append([] if previous is None else links(drawn, previous))
            previous = drawn
        return piece

    def table(self) -> pd.DataFrame:
        """official.csv: score vil100's rows (per video, per scenario, all) with the temporal
        metrics beside them, then the same over the ego lanes ('ego', all videos pooled)."""
        import pandas as pd

        from ...thresholds import parse_thresholds
        from .score import COLUMNS, official_rows, sequence_totals, temporal_rows

        thresholds = parse_thresholds(THRESHOLDS)
        joined = []
        for part in ("all", "ego"):
            totals = [sequence_totals(piece, relpaths, thresholds, True, ())
                      for piece, relpaths in zip(self.scored[part], self.relpaths)]
            rows, _ = official_rows(self.names, self.methods, totals, thresholds)
            temporal, _ = temporal_rows(self.names, self.methods, totals, thresholds)
            by_key = {(r[0], r[1], r[2]): r[3:] for r in temporal}
            for row in rows:
                if part == "ego" and row[1] != "all":
                    continue
                extra = by_key.get((row[0], row[1], row[2]), (0, 0, 0, 0, math.nan, math.nan, math.nan))
                joined.append((row[0], "ego" if part == "ego" else row[1], *row[2:], *extra))
        order = {method: k for k, method in enumerate(self.methods)}
        joined.sort(key=lambda row: order[row[0]])  # stable: each method's rows together, ego after all
        return pd.DataFrame(joined, columns=[*COLUMNS, *TEMPORAL])


BENCHMARK = Vil100Benchmark()
