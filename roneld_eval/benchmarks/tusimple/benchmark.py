"""TuSimple (tusimple-benchmark): scored as its evaluate/lane.py does, lanes sampled at the
frame's h_samples; the labels are one file; lanes written as one JSON line per frame."""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any, Sequence

from ...config import EvalConfig
from ...errors import InputError
from .. import LaneFile, declared_command, from_module
from .reader import IMAGE_HEIGHT, IMAGE_WIDTH, read_tusimple
from ...json_fields import json_number, read_float, read_list
from ...lanes_io import sample_lane_at_rows
from .lane_format import format_tusimple_record, predicted_frames, tusimple_xs
from ...maps.lanes import JsonLinesFile
from ...metrics.point_accuracy import PIXEL_THRESHOLD, POINT_THRESHOLD
from .official import bench_frame, mean_scores
from ...model import Clip, Dataset, Frame, Lane

PREDICTIONS_FILE = "predictions.json"  # the official prediction file: a JSON line per frame

if TYPE_CHECKING:  # annotations only: `score` starts without pandas or the extractors
    import pandas as pd

    from ...extract.protocol import Prediction


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
    display_name = "TuSimple"
    image_size = (IMAGE_WIDTH, IMAGE_HEIGHT)
    default_preset = "scnn-tusimple"
    frames_per_clip = 20
    fixture: str | None = "tusimple"
    kernel_groups: tuple[str, ...] = ()
    missing_maps_hint = " (each TuSimple clip needs maps for all its 20 frames)"
    detector_lanes = JsonLinesFile(PREDICTIONS_FILE, predicted_frames)  # what run --save-lanes writes

    # loaded from this folder when first used (benchmarks.from_module): the command, its library
    # scorer (roneld_eval.score; a merge runs it on parts' arrays), the in-memory metric's core
    score_command = declared_command(".command")
    scorer = from_module(".score", "score_tusimple")
    metric = from_module(".metric", "TusimpleMetric", call=True)

    def read(self, root: Path, list_file: Path | None, limit: int | None, errors: list | None,
             labels: bool) -> Dataset:
        return read_tusimple(root, list_file, limit, errors)  # one label file: always read

    def with_labels(self, clip: Clip, root: Path, errors: list | None) -> Clip:
        return clip

    def synthesize(self, out: Path, clips: int, frames: int, seed: int, maps_format: str, progress) -> Any:
        from .synth import synth_tusimple

        return synth_tusimple(out, clips, frames, seed, maps_format, progress=progress)

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
        return LaneFile(f"{method}/{PREDICTIONS_FILE}", text, append=True)

    def official_protocol(self, protocol) -> str | None:
        return None  # lane.py's own: no settings of the run's

    def official_note(self, protocol) -> str:
        return (f"TuSimple's evaluate/lane.py: a point matches within {PIXEL_THRESHOLD} px (slope-corrected), "
                f"a lane when {POINT_THRESHOLD:.0%} of its points match.")

    def category_panel(self, official, protocol):
        return None  # its datasets have no categories

    official_columns = {"method": "text", "accuracy": "optional number", "fp": "optional number",
                        "fn": "optional number"}
    official_optional = {"f1_clrnet": "optional number"}
    official_key = ("method",)

    def check_official(self, path: Path, table: pd.DataFrame) -> None:
        _check_f1(path, table)

    def official_comparison(self, groups) -> tuple[Any, str]:
        text = ("Official TuSimple scores (evaluate/lane.py): accuracy, FP and FN rates; F1 as each run's "
                "official.csv gives it (f1_clrnet: CLRNet's tusimple_metric.py, tp = 1 - FP, precision = "
                "tp / (tp + FP), recall = tp / (tp + FN); n/a where that script divides by zero).")
        return _official_grid(groups), text


def _official_grid(groups):
    """TuSimple Accuracy (%), FP, FN and F1 (%) per model and method."""
    from ...comparison.groups import all_found, method_name, ordered_methods
    from ...comparison.tables import EMPTY, Cell, Column, Grid, Stat, Text

    rows: list[tuple[Cell, ...]] = []
    for group in groups:
        for method in ordered_methods(group.methods):
            hits = []
            for run in group.runs:
                hit = run.official[run.official["method"] == method]
                hits.append(None if hit.empty else hit.iloc[0])
            title = method_name(method, group.label) + ("" if group.n == 1 else f" (n = {group.n})")
            found = all_found(hits)
            if found is None:
                rows.append((Text(title), EMPTY, EMPTY, EMPTY, EMPTY))
                continue
            rows.append((Text(title),
                         Stat(tuple(float(f["accuracy"]) for f in found), decimals=2, scale=100),
                         Stat(tuple(float(f["fp"]) for f in found), decimals=4),
                         Stat(tuple(float(f["fn"]) for f in found), decimals=4),
                         Stat(tuple(_run_f1(f) for f in found), decimals=2, scale=100)))
    columns = (Column("Accuracy (%)", ("Acc. (%)",)), Column("FP", ("FP",)), Column("FN", ("FN",)),
               Column("F1 (%)", ("F1 (%)",)))
    return Grid((Column("Method", ("Method",)),), columns, tuple(rows))


def _run_f1(row: pd.Series) -> float:
    """The run's own f1_clrnet (n/a where its official.csv predates that column): never recomputed
    here, so the table cannot disagree with the run's."""
    return float(row["f1_clrnet"]) if "f1_clrnet" in row.index else math.nan


def _check_f1(path: Path, official: pd.DataFrame) -> None:
    """A TuSimple run's f1_clrnet is shown as it is, so it must be what CLRNet's formula gives
    for the row's FP and FN (to the 6 decimals official.csv holds): an edited one is refused."""
    if "f1_clrnet" not in official.columns:
        return
    from .official import f1_clrnet

    half = 0.5e-6  # official.csv holds 6 decimals; F1 falls as FP or FN grows, so the corners bound it
    for row, (fp, fn, f1) in enumerate(zip(official["fp"], official["fn"], official["f1_clrnet"])):
        finite = math.isfinite(fp) and math.isfinite(fn)
        values = [f1_clrnet(fp, fn)] + [f1_clrnet(fp + dx, fn + dy) for dx in (-half, half)
                                        for dy in (-half, half)] if finite else [math.nan]
        possible = [value for value in values if not math.isnan(value)]
        if math.isnan(f1):
            if len(possible) < len(values):  # where the script divides by zero, or may
                continue
        elif possible and min(possible) - 2 * half <= f1 <= max(possible) + 2 * half:
            continue
        expected = f"{f1_clrnet(fp, fn):.6f}" if math.isfinite(fp) and math.isfinite(fn) else "n/a"
        raise InputError(path, f"f1_clrnet {f1:g} is not CLRNet's F1 of fp {fp:g} and fn {fn:g} ({expected}): "
                               "not what `roneld-eval run` wrote", line=row + 2)


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

    def end_clip(self, clip_id: str) -> None:
        pass  # frame metrics only

    def table(self) -> pd.DataFrame:
        """method, accuracy, fp, fn and the F1 papers print (f1_ufld, f1_clrnet), as `score tusimple`."""
        rows = []
        for method, (accuracy, fp, fn) in self.sums.items():
            rows.append(dict(method=method, **mean_scores([(accuracy, fp, fn)], self.frames[method]).as_row()))
        import pandas as pd

        return pd.DataFrame(rows, columns=["method", "accuracy", "fp", "fn", "f1_ufld", "f1_clrnet"])


BENCHMARK = TusimpleBenchmark()
