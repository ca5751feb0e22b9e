"""Dataset readers: CULane and TuSimple trees into the common Clip/Frame form."""

from __future__ import annotations

from pathlib import Path

from ..errors import ConfigError
from ..model import Dataset
from .culane import read_culane
from .tusimple import read_tusimple

READERS = {"culane": read_culane, "tusimple": read_tusimple}


def read_dataset(name: str, root: str | Path, list_file: str | Path | None = None, limit: int | None = None,
                 errors: list | None = None) -> Dataset:
    """Read a benchmark by name ('culane' or 'tusimple'); see the readers for `errors`."""
    try:
        reader = READERS[name]
    except KeyError:
        raise ConfigError(f"unknown dataset {name!r}; choose from {', '.join(READERS)}") from None
    return reader(root, list_file, limit, errors)


__all__ = ["read_dataset", "read_culane", "read_tusimple", "READERS"]
