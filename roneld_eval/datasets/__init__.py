"""Dataset readers: a benchmark's tree on disk into the common Clip/Frame form. Each benchmark
reads its own layout (roneld_eval.benchmarks); these are the calls the other stages make, with
the benchmark handed to them (roneld_eval.resolve looks it up where work enters)."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

from ..model import Clip, Dataset

if TYPE_CHECKING:
    from ..benchmarks import Benchmark


def read_dataset(benchmark: "Benchmark", root: str | Path, list_file: str | Path | None = None,
                 limit: int | None = None, errors: list | None = None, labels: bool = True) -> Dataset:
    """Read a benchmark's dataset; see the readers for `errors`.

    `labels=False` lets a benchmark defer reading labels to `load_labels` (one that keeps them
    in one file reads them at once). A root where no listed frame has its labels is refused
    (a wrong root, not a dataset without lanes).
    """
    return benchmark.read(Path(root), None if list_file is None else Path(list_file), limit, errors, labels)


def load_labels(benchmark: "Benchmark", dataset: Dataset, clip: Clip, errors: list | None = None) -> Clip:
    """The clip with its labels, reading them if the dataset was read without."""
    if dataset.labels_loaded:
        return clip
    return benchmark.with_labels(clip, Path(dataset.root), errors)


__all__ = ["read_dataset", "load_labels"]
