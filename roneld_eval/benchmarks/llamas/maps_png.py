"""Probability maps as LLAMAS's segmentation evaluation reads them: one grey PNG per class,
``<frame>.json_<c>.png`` beside the label's name (c = 1..4: lanes l1, l0, r0, r1, outer left to
outer right; 0, the background, is not read), 0..255 = probability * 255, no existence file."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ...config import MapsConfig
from ...errors import InputError
from ...model import FrameMaps
from ...maps.formats import MapFormat
from ...maps.scnn_png import read_grey_png

SUFFIX = ".json_1.png"  # the file by which a frame's maps are recognised


def llamas_png_paths(stem: Path, channels: int) -> list[Path]:
    """[<stem>.json_1.png, ..., <stem>.json_<channels>.png]."""
    return [stem.with_name(f"{stem.name}.json_{c}.png") for c in range(1, channels + 1)]


def load_llamas_png(stem: Path, config: MapsConfig) -> FrameMaps:
    """The class maps of one frame stacked, every one required (the evaluation stops without one)."""
    maps = [read_grey_png(path) for path in llamas_png_paths(stem, config.lane_channels)]
    shapes = {m.shape for m in maps}
    if len(shapes) > 1:
        raise InputError(stem.with_name(stem.name + ".json_*.png"), f"class maps differ in size: {sorted(shapes)}")
    return FrameMaps(probabilities=np.stack(maps))


# registered in pyproject.toml under roneld_eval.map_formats
FORMAT = MapFormat("llamas-png", SUFFIX, load_llamas_png, images=llamas_png_paths, files=llamas_png_paths,
                   kernel_groups=("maps",))
