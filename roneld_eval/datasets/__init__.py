"""Dataset readers: CULane and TuSimple trees into the common Clip/Frame form."""

from __future__ import annotations

from pathlib import Path

from ..errors import ConfigError
from ..model import Clip, Dataset
from .culane import read_culane, with_labels
from .tusimple import read_tusimple

READERS = {"culane": read_culane, "tusimple": read_tusimple}


def read_dataset(name: str, root: str | Path, list_file: str | Path | None = None, limit: int | None = None,
                 errors: list | None = None, labels: bool = True) -> Dataset:
    """Read a benchmark by name ('culane' or 'tusimple'); see the readers for `errors`.

    `labels=False` lets CULane defer reading labels to `load_labels` (TuSimple's labels are one
    file and are always read). A CULane root where no listed frame has its `.lines.txt` is
    refused (a wrong root, not a dataset without lanes).
    """
    try:
        reader = READERS[name]
    except KeyError:
        raise ConfigError(f"unknown dataset {name!r}; choose from {', '.join(READERS)}") from None
    if name == "culane":
        return reader(root, list_file, limit, errors, labels, require_labels=True)
    return reader(root, list_file, limit, errors)


def load_labels(dataset: Dataset, clip: Clip, errors: list | None = None) -> Clip:
    """The clip with its labels, reading them if the dataset was read without."""
    if dataset.labels_loaded:
        return clip
    return with_labels(clip, dataset.root, errors)


__all__ = ["read_dataset", "load_labels", "read_culane", "read_tusimple", "READERS"]
