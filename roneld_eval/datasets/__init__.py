"""Dataset readers: a benchmark's tree on disk into the common Clip/Frame form. Each benchmark
reads its own layout (roneld_eval.benchmarks); these are the calls the other stages make."""

from __future__ import annotations

from pathlib import Path

from ..model import Clip, Dataset


def read_dataset(name: str, root: str | Path, list_file: str | Path | None = None, limit: int | None = None,
                 errors: list | None = None, labels: bool = True) -> Dataset:
    """Read a registered benchmark's dataset by name; see the readers for `errors`.

    `labels=False` lets a benchmark defer reading labels to `load_labels` (one that keeps them
    in one file reads them at once). A root where no listed frame has its labels is refused
    (a wrong root, not a dataset without lanes).
    """
    from ..benchmarks import benchmark_for

    return benchmark_for(name).read(Path(root), None if list_file is None else Path(list_file), limit, errors,
                                    labels)


def with_labels(name: str, clip: Clip, root: str | Path, errors: list | None = None) -> Clip:
    """The clip of dataset `name` under `root` with its labels read."""
    from ..benchmarks import benchmark_for

    return benchmark_for(name).with_labels(clip, Path(root), errors)


def load_labels(dataset: Dataset, clip: Clip, errors: list | None = None) -> Clip:
    """The clip with its labels, reading them if the dataset was read without."""
    if dataset.labels_loaded:
        return clip
    return with_labels(dataset.name, clip, dataset.root, errors)


__all__ = ["read_dataset", "load_labels", "with_labels"]
