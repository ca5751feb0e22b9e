"""SCNN / ENet-SAD output as their test scripts write it.

``<frame>_<k>_avg.png`` (k = 1..C, 8-bit grey = probability * 255) and ``<frame>.exist.txt``
(``1 1 1 0``). A channel whose existence is 0 may lack its PNG: its map is all zero.
"""

from __future__ import annotations

import zlib
from pathlib import Path

import cv2
import numpy as np

from ..config import MapsConfig
from ..errors import InputError
from ..lanes_io import decode_text, parse_number, read_bytes
from ..model import FrameMaps
from ._checks import canonical_existence


def scnn_png_paths(stem: Path, channels: int) -> tuple[list[Path], Path]:
    """([<stem>_1_avg.png, ...], <stem>.exist.txt)."""
    pngs = [stem.with_name(f"{stem.name}_{k}_avg.png") for k in range(1, channels + 1)]
    return pngs, stem.with_name(stem.name + ".exist.txt")


def read_existence(path: Path, config: MapsConfig, data: bytes | None = None) -> np.ndarray:
    if data is None:
        data = read_bytes(path)
    tokens = decode_text(data, path).split()
    values = [parse_number(token, path, 1) for token in tokens]
    return canonical_existence(values, path, config)


_PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"


def check_png(data: bytes, path: Path) -> None:
    """Refuse a truncated or corrupt PNG before libpng sees it (libpng prints its own line to
    stderr for those): the signature, every chunk inside the file with its CRC, and an IEND."""
    if not data.startswith(_PNG_SIGNATURE):
        raise InputError(path, "not a PNG file")
    view = memoryview(data)
    offset, size = len(_PNG_SIGNATURE), len(data)
    while True:
        if offset + 12 > size:
            raise InputError(path, "truncated PNG (it ends before its IEND chunk)")
        length = int.from_bytes(view[offset:offset + 4], "big")
        end = offset + 12 + length
        if end > size:
            raise InputError(path, "truncated PNG (a chunk runs past the end of the file)")
        kind = bytes(view[offset + 4:offset + 8])
        if zlib.crc32(view[offset + 4:end - 4]) != int.from_bytes(view[end - 4:end], "big"):
            raise InputError(path, f"corrupt PNG ({kind.decode('latin-1')!r} chunk fails its CRC check)")
        if kind == b"IEND":
            return
        offset = end


def _read_png(path: Path, data: bytes) -> np.ndarray:
    check_png(data, path)
    image = cv2.imdecode(np.frombuffer(data, np.uint8), cv2.IMREAD_UNCHANGED)
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
    exist_data = read_bytes(exist_path, missing_ok=True)
    existence = None if exist_data is None else read_existence(exist_path, config, exist_data)
    maps: list[np.ndarray | None] = []
    for channel, path in enumerate(pngs):
        data = read_bytes(path, missing_ok=True)
        if data is not None:
            maps.append(_read_png(path, data))
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
