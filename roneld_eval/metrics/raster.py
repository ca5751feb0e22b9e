"""Lanes to pixel masks: the single definition of line width, end caps, splines and scaling.

Two uses: the official CULane protocol (full image, float32 points as the C++ evaluator reads
them, its spline for 3+ points, thickness 30) and the RONELD paper's protocol (map
resolution, lanes scaled from image to map pixels, thickness from `PaperMetricParams`).
Both draw with the same exact rasteriser (`_kernels.rasterise`). No thresholds here.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache

import numpy as np

from .._numba_cache import compile_now
from ..geometry import MapGeometry
from ..model import Lane
from . import _kernels

SPLINE_SAMPLES = 50  # SCNN lane_evaluation: splineInterpTimes(lane, 50)


@dataclass(frozen=True, eq=False)
class LaneMask:
    """A lane's pixels on an image: `pixels` (uint8 0/1) is the crop whose top-left is (x0, y0)."""

    x0: int
    y0: int
    pixels: np.ndarray
    area: int

    @classmethod
    def empty(cls) -> "LaneMask":
        return cls(0, 0, np.zeros((0, 0), np.uint8), 0)

    def intersection(self, other: "LaneMask") -> int:
        if self.area == 0 or other.area == 0:
            return 0
        return int(_kernels.overlap(self.x0, self.y0, self.pixels, other.x0, other.y0, other.pixels))

    def full(self, width: int, height: int) -> np.ndarray:
        """The mask on a whole (height, width) image."""
        image = np.zeros((height, width), np.uint8)
        h, w = self.pixels.shape
        image[self.y0:self.y0 + h, self.x0:self.x0 + w] = self.pixels
        return image


@lru_cache(maxsize=None)
def _quad_extras(thickness: int) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    return _kernels.short_quad_extras(thickness)


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
    """
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
    """
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
    masks = []
    if "official" in groups:
        masks.append(official_mask(lane, 1640, 590, 30))
    if "paper" in groups:
        geometry = MapGeometry(1640, 590, 800, 288)
        masks += [map_mask(lane, geometry, 16, spline, rounding) for spline in (False, True)
                  for rounding in ("nearest", "truncate")]
    if masks:
        masks[0].intersection(masks[-1])
