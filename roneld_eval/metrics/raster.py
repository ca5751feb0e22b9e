"""Lanes to pixel masks: the single definition of line width, end caps, splines and scaling.

Two uses: the official CULane protocol (full image, float32 points as the C++ evaluator reads
them, its spline for 3+ points, thickness 30) and the RONELD paper's protocol (map
resolution, lanes scaled from image to map pixels, thickness from `PaperMetricParams`).
Both give exactly the pixels of the same rasteriser (`_kernels.rasterise`, a canvas), held as
runs per row (`_kernels.rasterise_runs`): IoUs then cost a step per row. No thresholds here.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache

import numpy as np

from .._numba_cache import compile_now
from ..config import IMAGE_SIZES
from ..geometry import MapGeometry
from ..model import Lane
from . import _kernels

SPLINE_SAMPLES = _kernels.SPLINE_SAMPLES  # one place: the kernels use it as a compile-time constant


@dataclass(frozen=True, eq=False)
class LaneMask:
    """A lane's pixels on an image, inside the box whose top-left is (x0, y0).

    Held as runs per row where drawn that way (official_mask, map_mask): `lo[r, k]`..`hi[r, k]` (image
    x, inclusive) are the runs of image row y0 + r (an unused slot is (1, 0)), the box
    ends before column x1, and `bitmap` is None. Otherwise `bitmap` (uint8 0/1) is the box and
    lo, hi are None. `pixels` is the box as a bitmap either way.
    """

    x0: int
    y0: int
    bitmap: np.ndarray | None
    area: int
    x1: int = 0
    lo: np.ndarray | None = None
    hi: np.ndarray | None = None

    @classmethod
    def empty(cls) -> "LaneMask":
        return cls(0, 0, np.zeros((0, 0), np.uint8), 0)

    @property
    def pixels(self) -> np.ndarray:
        """The box (uint8 0/1) whose top-left is (x0, y0)."""
        if self.bitmap is not None:
            return self.bitmap
        assert self.lo is not None and self.hi is not None
        columns = np.arange(self.x0, self.x1)[None, None, :]
        inside = (columns >= self.lo[:, :, None]) & (columns <= self.hi[:, :, None])
        return np.asarray(inside.any(axis=1), np.uint8)

    def intersection(self, other: "LaneMask") -> int:
        if self.area == 0 or other.area == 0:
            return 0
        if self.lo is not None and other.lo is not None:
            return int(_kernels.run_overlap(self.y0, self.lo, self.hi, other.y0, other.lo, other.hi))
        return int(_kernels.overlap(self.x0, self.y0, self.pixels, other.x0, other.y0, other.pixels))

    def full(self, width: int, height: int) -> np.ndarray:
        """The mask on a whole (height, width) image."""
        image = np.zeros((height, width), np.uint8)
        pixels = self.pixels
        h, w = pixels.shape
        image[self.y0:self.y0 + h, self.x0:self.x0 + w] = pixels
        return image


@lru_cache(maxsize=None)
def _quad_extras(thickness: int) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    return _kernels.short_quad_extras(thickness)


@lru_cache(maxsize=None)
def _step_extras(thickness: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    return _kernels.step_extras(thickness, _kernels.STEP_REACH)


def _points(lane: Lane) -> np.ndarray:
    """A lane's (N, 2) float64 points, C-contiguous and read-only: the one array type the
    kernels are compiled for (_kernels.ENTRY_SIGNATURES), whoever built the lane."""
    points = np.ascontiguousarray(lane.points, dtype=np.float64)
    if points.flags.writeable:
        points = points.view()
        points.flags.writeable = False
    return points


def mask_from_pixels(xs: np.ndarray, ys: np.ndarray, thickness: int, width: int, height: int) -> LaneMask:
    """Rasterise integer polyline vertices."""
    thickness = int(thickness)
    x0, y0, pixels, area = _kernels.rasterise_with_area(
        np.array(xs, np.int64), np.array(ys, np.int64), thickness, int(width), int(height),
        *_quad_extras(thickness),
    )
    return LaneMask(int(x0), int(y0), pixels, int(area))


def official_mask(lane: Lane, width: int, height: int, thickness: int) -> LaneMask | None:
    """A lane as the official CULane evaluator draws it, or None for fewer than 2 points.

    Points go through float32 (cv::Point2f) before the spline, the spline samples through
    float32 again, and cv::Point conversion rounds half to even (all in one kernel call).
    The mask comes as runs per row: the pixels of `official_mask_by_canvas`, not drawn.
    """
    if len(lane) < 2:
        return None
    thickness = int(thickness)
    x0, y0, x1, lo, hi, area = _kernels.official_lane_runs(
        _points(lane), int(width), int(height), thickness, *_quad_extras(thickness), *_step_extras(thickness)
    )
    return LaneMask(int(x0), int(y0), None, int(area), int(x1), lo, hi)


def official_mask_by_canvas(lane: Lane, width: int, height: int, thickness: int) -> LaneMask | None:
    """official_mask drawn pixel by pixel into a canvas over the lane's box: the reference
    official_mask is tested and benchmarked against (slower, same pixels)."""
    if len(lane) < 2:
        return None
    x0, y0, pixels, area = _kernels.official_lane(
        _points(lane), int(width), int(height), int(thickness), *_quad_extras(int(thickness))
    )
    return LaneMask(int(x0), int(y0), pixels, int(area))


def map_mask(lane: Lane | None, geometry: MapGeometry, thickness: int, spline: bool = False,
             rounding: str = "nearest") -> LaneMask:
    """A lane drawn at map resolution (the paper's protocol); None draws nothing.

    With `spline`, the points first go through the official cubic spline in image pixels
    (how the baseline's sparse points become a lane). Map coordinates snap to pixels by
    `rounding`: "nearest" (half to even) or "truncate" (C's int(), as the RONELD code draws).
    The mask comes as runs per row: the pixels of `map_mask_by_canvas`, not drawn.
    """
    if lane is None or len(lane) < 2:
        return LaneMask.empty()
    if rounding not in ("nearest", "truncate"):
        raise ValueError(f"rounding must be 'nearest' or 'truncate', got {rounding!r}")
    thickness = int(thickness)
    x0, y0, x1, lo, hi, area = _kernels.map_lane_runs(
        _points(lane), bool(spline), float(geometry.scale_x), float(geometry.scale_y),
        float(geometry.crop_top_px), rounding == "truncate", thickness,
        int(geometry.map_width), int(geometry.map_height), *_quad_extras(thickness), *_step_extras(thickness),
    )
    return LaneMask(int(x0), int(y0), None, int(area), int(x1), lo, hi)


def map_mask_by_canvas(lane: Lane | None, geometry: MapGeometry, thickness: int, spline: bool = False,
                       rounding: str = "nearest") -> LaneMask:
    """map_mask drawn pixel by pixel into a canvas over the lane's box: the reference map_mask
    is tested and benchmarked against (slower, same pixels)."""
    if lane is None or len(lane) < 2:
        return LaneMask.empty()
    if rounding not in ("nearest", "truncate"):
        raise ValueError(f"rounding must be 'nearest' or 'truncate', got {rounding!r}")
    x0, y0, pixels, area = _kernels.map_lane(
        _points(lane), bool(spline), float(geometry.scale_x), float(geometry.scale_y),
        float(geometry.crop_top_px), rounding == "truncate", int(thickness),
        int(geometry.map_width), int(geometry.map_height), *_quad_extras(int(thickness)),
    )
    return LaneMask(int(x0), int(y0), pixels, int(area))


def warm_up(groups=("tables", "official", "paper")) -> None:
    """Compile (or load from numba's cache) the drawing kernels of these groups of
    `_kernels.ENTRY_SIGNATURES`, and draw a lane each way once."""
    for group in groups:
        for kernel, signature in _kernels.ENTRY_SIGNATURES[group]:
            compile_now(kernel, signature)
    lane = Lane(np.array([[700.0, 589.0], [760.0, 450.0], [800.0, 330.0], [815.0, 260.0]]))
    masks: list = []
    if "official" in groups:
        masks.append(official_mask(lane, *IMAGE_SIZES["culane"], 30))
    if "paper" in groups:
        geometry = MapGeometry(*IMAGE_SIZES["culane"], 800, 288)
        masks += [map_mask(lane, geometry, 16, spline, rounding) for spline in (False, True)
                  for rounding in ("nearest", "truncate")]
    if masks:
        masks[0].intersection(masks[-1])
