"""What a run passes between its stages: one frame's outcome, one clip's result (what a worker
sends back), what a worker needs besides the clip, the finished run, and the per-frame rows."""

from __future__ import annotations

from array import array
from dataclasses import dataclass, field, replace
from functools import cached_property
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from .. import kernels
from ..benchmarks import Benchmark, OfficialRecord
from ..config import EvalConfig
from ..extract.registry import Method, methods_of
from ..geometry import EffectiveGeometry
from ..maps import load_maps
from ..model import Dataset, Frame, FrameMaps, Lane

if TYPE_CHECKING:  # annotations only: a run forks its workers before pandas is imported
    import pandas as pd


@dataclass(frozen=True)
class FrameOutcome:
    """One scored frame of one method: ego-lane IoUs per side, official record, lanes."""

    relpath: str
    method: str
    ious: dict[str, float]
    official: OfficialRecord  # as the dataset's benchmark scores a frame
    lanes: tuple[Lane, ...]
    active: tuple[Lane | None, Lane | None] = (None, None)  # the scored left and right lanes

    def without_lanes(self) -> "FrameOutcome":
        """The scores alone: what the main process keeps once lanes are written (or not wanted)."""
        return replace(self, lanes=(), active=(None, None))


@dataclass
class ClipResult:
    """What a worker sends back for one clip (plain data, cheap to pickle)."""

    clip_id: str
    outcomes: list[FrameOutcome] = field(default_factory=list)
    extract_ms: dict[str, list[float]] = field(default_factory=dict)
    load_ms: list[float] = field(default_factory=list)
    n_frames: int = 0  # frames evaluated (skipped ones not counted)
    n_scored: int = 0
    n_gt_lanes: int = 0
    skipped: list[str] = field(default_factory=list)
    map_size: tuple[int, int] | None = None  # (width, height) of the clip's maps as found
    # Source files of the plug-ins as loaded when the clip finished: path -> SHA-256 (resume).
    plugin_code: dict[str, str] = field(default_factory=dict)


def lane_files_of(config: EvalConfig, benchmark: Benchmark):
    """The format `--maps-format lanes` reads (maps.lanes.LaneFileFormat): the benchmark's
    declared `detector_lanes`; None for maps in another format."""
    if config.maps.format != "lanes":
        return None
    return benchmark.detector_lanes


@dataclass(frozen=True)
class RunContext:
    """Everything a worker needs besides the clip."""

    config: EvalConfig
    benchmark: Benchmark
    maps_root: Path
    labels_root: Path | None = None  # dataset root when clips come without their labels
    data_root: Path | None = None  # where the labels lie (CULane: a .lines.txt per frame)
    label_file: Path | None = None  # one file holding every label (TuSimple)

    @cached_property
    def methods(self) -> tuple[Method, ...]:
        return methods_of(self.config)

    @cached_property
    def lane_files(self):
        """The benchmark's format of a detector's lane files, what `--maps-format lanes` reads."""
        return lane_files_of(self.config, self.benchmark)

    def load(self, frame: Frame) -> FrameMaps:
        """One frame's maps (lane files are drawn into maps with the configured geometry)."""
        config = self.config
        return load_maps(self.maps_root, frame.relpath, config.maps, config.geometry_of(frame),
                         config.roneld.center_ratio, self.lane_files)

    def kernel_groups(self) -> tuple[str, ...]:
        """The numba kernel groups this run executes (see roneld_eval.kernels)."""
        return kernels.groups_for(self.methods, self.benchmark, self.config.maps.format)


@dataclass
class RunResult:
    """A finished evaluation: the tables of every report, and where they came from."""

    config: EvalConfig
    benchmark: Benchmark  # the dataset's: what reads it, scores it the official way, shows its tables
    dataset: Dataset
    per_frame: pd.DataFrame
    accuracy: pd.DataFrame
    official: pd.DataFrame
    runtime: pd.DataFrame
    counts: dict
    wall_time_s: float
    skipped: list[str]
    versions: dict
    fixture: str | None = None  # the bundled fixture's dataset when that is what ran
    # What was really drawn (map size as found, thicknesses); None when no clip was evaluated.
    geometry: EffectiveGeometry | None = None
    # Each method's accuracy gain over RONELD and over the baseline, with bootstrap intervals.
    gains: pd.DataFrame | None = None
    # What a reader should know that left nothing out (maps of several sizes, each rescaled)
    notes: list[str] = field(default_factory=list)
    # Whether the report shows what the clock measured (runtime per frame, wall time); without it
    # the same run writes the same bytes (`run --no-timings`, how results/ is written).
    timed: bool = True
    # `run --diagnose`: its lanes' error types, frames and gallery (report.diagnosis.Diagnosed)
    diagnosed: Any = None



class PerFrameRows:
    """The rows of `RunResult.per_frame` (frame, side, method, IoU) gathered outcome by outcome
    as compact columns: a frame's rows share one string, sides and methods are small codes."""

    COLUMNS = ["frame", "side", "method", "iou"]

    def __init__(self) -> None:
        self._empty()

    def _empty(self) -> None:
        self.frames: list[str] = []
        self.sides, self.methods = array("B"), array("B")
        self.ious = array("d")
        self.names: dict[str, int] = {}  # side and method names, coded

    def add(self, relpath: str, outcome: FrameOutcome) -> None:
        """Add an outcome's rows under `relpath` (one string shared by the frame's rows)."""
        method = self._code(outcome.method)
        for side, iou in outcome.ious.items():
            self.frames.append(relpath)
            self.sides.append(self._code(side))
            self.methods.append(method)
            self.ious.append(iou)

    def _code(self, name: str) -> int:
        return self.names.setdefault(name, len(self.names))

    def take_table(self) -> pd.DataFrame:
        """The rows as a DataFrame, handed over: the gatherer is empty afterwards, as new (so that
        its lists are freed as the table is built, at a run's largest size)."""
        import pandas as pd

        frames, sides, methods, ious, names = self.frames, self.sides, self.methods, self.ious, list(self.names)
        self._empty()
        if not frames:
            return pd.DataFrame([], columns=self.COLUMNS)
        column = np.array(frames, dtype=object)
        del frames  # the strings stay, shared with the dataset's frames
        coded = np.array(names, dtype=object)
        # Arrays, not lists, and not copied again.
        return pd.DataFrame({
            "frame": column,
            "side": coded[np.frombuffer(sides, np.uint8)],
            "method": coded[np.frombuffer(methods, np.uint8)],
            "iou": np.frombuffer(ious, np.float64).copy(),
        }, columns=self.COLUMNS, copy=False)
