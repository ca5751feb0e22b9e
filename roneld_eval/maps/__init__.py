"""Loading stored probability maps into one form: (C, H, W) uint8, 0..255, lane channels only.

Maps mirror the dataset tree under a maps root: the maps of ``<rel>/00000.jpg`` are
``<maps-root>/<rel>/00000.npy`` (or ``.npz``, or SCNN's ``00000_<k>_avg.png`` +
``00000.exist.txt``). uint8 is the canonical scale because SCNN and ENet-SAD store 8-bit maps
and RONELD's thresholds are defined on 0..255; float maps in [0, 1] are rounded to it once.
"""

from __future__ import annotations

from pathlib import Path

from ..config import MapsConfig
from ..errors import InputError
from ..model import FrameMaps
from .npy import load_npy, load_npz
from .scnn_png import load_scnn_png, scnn_png_paths

FORMATS = ("npy", "npz", "scnn-png")


def map_stem(root: Path, relpath: str) -> Path:
    """`<root>/<relpath without extension>`: the common prefix of a frame's map files."""
    name = relpath.rsplit("/", 1)[-1]
    stem = relpath.rsplit(".", 1)[0] if "." in name else relpath
    return Path(root) / stem


def required_paths(root: Path, relpath: str, config: MapsConfig) -> list[Path]:
    """Files that must exist for a frame's maps to load (PNGs of absent lanes may be missing)."""
    stem = map_stem(root, relpath)
    if config.format == "npy":
        return [stem.with_name(stem.name + ".npy")]
    if config.format == "npz":
        return [stem.with_name(stem.name + ".npz")]
    return [scnn_png_paths(stem, config.lane_channels)[1]]


def load_maps(root: Path, relpath: str, config: MapsConfig) -> FrameMaps:
    """The maps of one frame in the canonical form, or an InputError naming the bad file."""
    stem = map_stem(root, relpath)
    if config.format == "npy":
        return load_npy(stem.with_name(stem.name + ".npy"), config)
    if config.format == "npz":
        return load_npz(stem.with_name(stem.name + ".npz"), config)
    if config.format == "scnn-png":
        return load_scnn_png(stem, config)
    raise InputError(None, f"unknown maps format {config.format!r}")


__all__ = ["load_maps", "required_paths", "map_stem", "FORMATS"]
