"""Dataset readers: CULane and TuSimple trees into the common Clip/Frame form."""

from __future__ import annotations

from pathlib import Path

from ..errors import ConfigError
from ..model import Clip, Dataset
from . import culane
from .culane import read_culane
from .tusimple import read_tusimple

READERS = {"culane": read_culane, "tusimple": read_tusimple}
# Readers that can leave labels for later, clip by clip (the others always read them).
LABEL_READERS = {"culane": culane.with_labels}


def read_dataset(name: str, root: str | Path, list_file: str | Path | None = None, limit: int | None = None,
                 errors: list | None = None, labels: bool = True) -> Dataset:
    """Read a benchmark by name ('culane' or 'tusimple'); see the readers for `errors`.

    `labels=False` lets CULane defer reading labels to `load_labels` (TuSimple's labels are one
    file and are always read). A CULane root where no listed frame has its `.lines.txt` is
    refused (a wrong root, not a dataset without lanes).
    """
    if name not in READERS:
        raise ConfigError(f"unknown dataset {name!r}; choose from {', '.join(READERS)}")
    if name == "culane":
        return read_culane(root, list_file, limit, errors, labels, require_labels=True)
    return read_tusimple(root, list_file, limit, errors)


def with_labels(name: str, clip: Clip, root: str | Path, errors: list | None = None) -> Clip:
    """The clip of dataset `name` under `root` with its labels read."""
    return LABEL_READERS[name](clip, root, errors)


def load_labels(dataset: Dataset, clip: Clip, errors: list | None = None) -> Clip:
    """The clip with its labels, reading them if the dataset was read without."""
    if dataset.labels_loaded:
        return clip
    return with_labels(dataset.name, clip, dataset.root, errors)


__all__ = ["read_dataset", "load_labels", "with_labels", "read_culane", "read_tusimple", "READERS"]
