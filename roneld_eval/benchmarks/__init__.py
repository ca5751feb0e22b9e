"""The benchmarks a run can score against, one module each: how a frame is scored the official
way, how the official table is built, where a clip's labels lie, and how lanes are written.

The runner asks `benchmark_for(dataset name)` and knows no benchmark by name; adding one
(VIL-100, LLAMAS, CurveLanes) means adding a module here and a reader in `datasets`.
"""

from __future__ import annotations

import importlib
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Protocol, Sequence

import pandas as pd

from ..config import EvalConfig
from ..extract.protocol import Prediction
from ..model import Clip, Dataset, Frame, Lane


class OfficialRecord(Protocol):
    """One frame's official score of one method, as its benchmark defines it."""

    def to_json(self) -> Any: ...


class OfficialTally(Protocol):
    """The official table gathered one frame record at a time, kept compact: what a run's main
    process holds instead of every record."""

    def add(self, method: str, relpath: str, record: Any) -> None: ...

    def table(self) -> pd.DataFrame:
        """The official table: one row per method (and category), methods in the given order."""


@dataclass(frozen=True)
class LaneFile:
    """Where one frame's lanes go: a file under lanes/METHOD/, its text, and whether the text
    is appended to a file shared by all frames (one line per frame) or is the whole file."""

    name: str
    text: str
    append: bool = False


class Benchmark(Protocol):
    """What the runner needs of a benchmark."""

    name: str
    # numba kernel groups its official scoring runs (compiled before the workers start)
    kernel_groups: tuple[str, ...]
    # said after "maps missing for N frames of K clips" (what a clip needs), or ""
    missing_maps_hint: str

    def label_paths(self, clip: Clip, data_root: Path | None, label_file: Path | None) -> list[Path]:
        """Every file holding this clip's labels (what resume must see unchanged)."""

    def prepare(self, frame: Frame, config: EvalConfig) -> Any:
        """Work shared by every method's scoring of one frame (the ground truth's masks)."""

    def score(self, prepared: Any, prediction: Prediction, config: EvalConfig) -> OfficialRecord:
        """One method's official record of one frame."""

    def tally(self, methods: Sequence[str], dataset: Dataset, config: EvalConfig) -> "OfficialTally":
        """An empty official table for these methods, to `add` records to frame by frame."""

    def decode(self, value: Any) -> OfficialRecord:
        """The inverse of `OfficialRecord.to_json` (TypeError/ValueError when malformed)."""

    def lane_file(self, method: str, frame: Frame, lanes: Sequence[Lane]) -> LaneFile:
        """One frame's lanes in the benchmark's official prediction format."""


# dataset name -> module of this package whose BENCHMARK it is (imported when first needed)
MODULES = {"culane": "culane", "tusimple": "tusimple"}


def benchmark_for(name: str) -> Benchmark:
    """The benchmark of a dataset name (as `DatasetConfig.name` gives it)."""
    if name not in MODULES:
        raise ValueError(f"no benchmark named {name!r}; known: {', '.join(MODULES)}")
    return importlib.import_module(f".{MODULES[name]}", __name__).BENCHMARK
