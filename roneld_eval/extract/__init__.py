"""Lane extractors: the models' own baseline and RONELD (with and without PFT)."""

import numpy as np

from .._numba_cache import compile_now
from ..config import BaselineParams, RoneldParams
from ..geometry import MapGeometry
from ..model import FrameMaps, read_only
from . import _kernels
from .baseline import baseline_lanes, sample_rows
from .roneld import CONSTANTS, ActiveLanes, RoneldState, RoneldTracker, roneld_step

__all__ = ["baseline_lanes", "sample_rows", "ActiveLanes", "RoneldState", "RoneldTracker", "roneld_step",
           "warm_up"]


def warm_up(groups=("roneld", "baseline")) -> None:
    """Compile (or load from numba's cache) the extraction kernels, and run every code path once.

    `groups`: keys of `_kernels.ENTRY_SIGNATURES` ("roneld", "baseline"). After this, extracting
    lanes compiles nothing: RONELD runs with and without PFT over a short synthetic clip of
    curving lanes, on writable and read-only maps. The clip ends before curve mode could switch
    on (two curved lanes a frame at most), so no spline is drawn: scipy's import waits for a
    real curve and is left out of its frame's time (roneld._interp_spline).
    roneld_eval.kernels.warm_up does this and the scoring kernels.
    """
    for group in groups:
        for kernel, signature in _kernels.ENTRY_SIGNATURES[group]:
            compile_now(kernel, signature)
    clip = curving_clip(frames=(CONSTANTS.curve_on - 1) // 2)
    if "roneld" in groups:
        tracker = RoneldTracker(RoneldParams())
        for maps in clip[:-1]:  # the curve test holds on every frame
            tracker(maps)
        tracker(read_only(clip[-1]))
        RoneldTracker(RoneldParams(), pft=False)(clip[0])
    if "baseline" in groups:
        height, width = clip[0].shape[1:]
        geometry = MapGeometry(1640, 590, width, height)  # any frame size compiles the kernels
        for maps in (clip[0], read_only(clip[0])):
            baseline_lanes(FrameMaps(maps), BaselineParams(), geometry)


def curving_clip(frames: int = 12, height: int = 100, width: int = 160) -> list[np.ndarray]:
    """(C, H, W) uint8 maps of two ego lanes that curve (RONELD's curve test holds every frame)."""
    rows = np.arange(height)
    distance = (height - 1 - rows).astype(np.float64)  # rows above the bottom
    columns = np.arange(width)
    clip = []
    for frame in range(frames):
        maps = np.zeros((4, height, width), np.uint8)
        centre = width / 2 + frame * 0.5
        for channel, side in ((1, -1.0), (2, 1.0)):
            # Straight towards the horizon at the bottom, bending right near the top.
            xs = centre + side * (width * 0.2 - 0.4 * distance) + 0.004 * distance**2
            ridge = 230.0 * np.exp(-((columns[None, :] - xs[:, None]) ** 2) / 4.0)
            maps[channel, height // 5:] = np.rint(ridge[height // 5:]).astype(np.uint8)
        clip.append(maps)
    return clip
