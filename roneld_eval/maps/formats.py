"""How maps are stored: one `MapFormat` entry per format, this package's own and those a benchmark
adds (LLAMAS's `llamas-png`), registered under the entry-point group `roneld_eval.map_formats`
(name = module:object) so that their names are known from the metadata without importing them:
a configuration checks a format's name, `--help` lists them, and only a run that reads maps of a
format imports its loader. "lanes" (another detector's lane files) is no map format: the
benchmark's `detector_lanes` reads them (maps.lanes)."""

from __future__ import annotations

import functools
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Callable

if TYPE_CHECKING:
    import importlib.metadata

    from ..config import MapsConfig
    from ..model import FrameMaps

ENTRY_POINT_GROUP = "roneld_eval.map_formats"
LANE_FILES = "lanes"  # not a map format: a detector's lane files drawn into maps


@dataclass(frozen=True)
class MapFormat:
    """A frame's maps as files beside `<maps-root>/<relpath without extension>` (its stem).

    `suffix`: the file that must exist for a frame's maps (<stem> + suffix), what a dataset walk
    and a folder of one clip's maps look for; `load(stem, config)`: the frame's maps, canonical
    (maps/_checks.py), or an InputError naming the bad file; `images(stem, channels)`: the image
    files holding the channels, whose headers give the maps' size without decoding them, and the
    first of which is named when a frame's maps are wrong (None: the `suffix` file is the maps);
    `files(stem, channels)`: every file by which its maps are recognised (any one suffices; None:
    the `suffix` file); `kernel_groups`: the numba groups decoding it, compiled before a run's
    workers start."""

    name: str
    suffix: str
    load: Callable[[Path, "MapsConfig"], "FrameMaps"]
    images: Callable[[Path, int], list[Path]] | None = None
    files: Callable[[Path, int], list[Path]] | None = None
    kernel_groups: tuple[str, ...] = ()

    def required(self, stem: Path) -> Path:
        return stem.with_name(stem.name + self.suffix)

    def recognised_by(self, stem: Path, channels: int) -> list[Path]:
        return self.files(stem, channels) if self.files is not None else [self.required(stem)]


# This package's own formats, in the order `--help` lists them (then the registered ones).
BUILT_IN = ("npy", "npz", "scnn-png")


@functools.cache
def _entry_points() -> dict[str, importlib.metadata.EntryPoint]:
    found: dict[str, importlib.metadata.EntryPoint] = {}
    from ..entry_points import in_group

    for point in in_group(ENTRY_POINT_GROUP):
        if point.name not in BUILT_IN:  # a package cannot replace one of this package's own
            found.setdefault(point.name, point)
    return found


def names() -> tuple[str, ...]:
    """Every map format's name, without importing any loader."""
    return BUILT_IN + tuple(sorted(_entry_points()))


@functools.cache
def map_format(name: str) -> MapFormat:
    """The format registered under `name` (a ValueError for one that is not)."""
    if name in BUILT_IN:
        from . import npy, scnn_png

        return {"npy": npy.NPY, "npz": npy.NPZ, "scnn-png": scnn_png.SCNN_PNG}[name]
    point = _entry_points().get(name)
    if point is None:
        raise ValueError(f"unknown maps format {name!r}; choose from {', '.join(names())}")
    entry = point.load()
    if not isinstance(entry, MapFormat) or entry.name != name:
        raise ValueError(f"maps format {name!r} ({point.value}) is not a MapFormat named {name!r}")
    return entry
