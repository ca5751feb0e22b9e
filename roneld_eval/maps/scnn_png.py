"""SCNN / ENet-SAD output as their test scripts write it.

``<frame>_<k>_avg.png`` (k = 1..C, 8-bit grey = probability * 255) and ``<frame>.exist.txt``
(``1 1 1 0``). A channel whose existence is 0 may lack its PNG: its map is all zero.
"""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np

from ..config import MapsConfig
from ..errors import InputError
from ..lanes_io import parse_number, read_text
from ..model import FrameMaps
from ._checks import canonical_existence


def scnn_png_paths(stem: Path, channels: int) -> tuple[list[Path], Path]:
    """([<stem>_1_avg.png, ...], <stem>.exist.txt)."""
    pngs = [stem.with_name(f"{stem.name}_{k}_avg.png") for k in range(1, channels + 1)]
    return pngs, stem.with_name(stem.name + ".exist.txt")


def read_existence(path: Path, config: MapsConfig) -> np.ndarray:
    text = read_text(path)
    tokens = text.split()
    values = [parse_number(token, path, 1) for token in tokens]
    return canonical_existence(values, path, config)


def _read_png(path: Path) -> np.ndarray:
    image = cv2.imread(str(path), cv2.IMREAD_UNCHANGED)
    if image is None:
        raise InputError(path, "not a readable image (truncated or not a PNG?)")
    if image.dtype != np.uint8:
        raise InputError(path, f"expected an 8-bit greyscale map, got {image.dtype}")
    if image.ndim == 3:
        channels = image.shape[2]
        if channels in (3, 4) and (image[..., 0] == image[..., 1]).all() and (image[..., 1] == image[..., 2]).all():
            return np.ascontiguousarray(image[..., 0])
        raise InputError(path, f"expected a greyscale map, got {channels} colour channels")
    return image


def load_scnn_png(stem: Path, config: MapsConfig) -> FrameMaps:
    """Stack the per-channel PNGs of one frame; missing PNGs of absent lanes are zeros."""
    pngs, exist_path = scnn_png_paths(stem, config.lane_channels)
    existence = read_existence(exist_path, config) if exist_path.exists() else None
    maps: list[np.ndarray | None] = []
    for channel, path in enumerate(pngs):
        if path.exists():
            maps.append(_read_png(path))
        elif existence is not None and existence[channel] <= 0:
            maps.append(None)
        else:
            reason = "missing" if existence is None else f"missing although {exist_path.name} says lane {channel + 1} exists"
            raise InputError(path, f"probability map {reason}")
    shapes = {m.shape for m in maps if m is not None}
    if len(shapes) > 1:
        raise InputError(stem.with_name(stem.name + "_*_avg.png"), f"channel maps differ in size: {sorted(shapes)}")
    shape = shapes.pop() if shapes else (config.height, config.width)
    stack = np.zeros((config.lane_channels,) + shape, np.uint8)
    for channel, image in enumerate(maps):
        if image is not None:
            stack[channel] = image
    return FrameMaps(probabilities=stack, existence=existence)
