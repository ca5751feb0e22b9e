"""Lanes to pixel masks: the single definition of line width, end caps, splines and scaling.

Two uses: the official CULane protocol (full image, float32 points as the C++ evaluator reads
them, its spline for 3+ points, thickness 30) and the RONELD paper's protocol (map
resolution, lanes scaled from image to map pixels, thickness from `PaperMetricParams`).
Both give exactly the pixels of the same rasteriser (`_kernels.rasterise`, a canvas), held as
runs per row (`_kernels.polyline_runs`, the canvas only where a lane needs it): IoUs then cost
a step per row. No thresholds here.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache
from itertools import accumulate
from typing import Callable, Sequence

import numpy as np

from .._numba_cache import compile_now
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
def _step_extras(thickness: int) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The runs kernels' tables of a thickness: step_extras(thickness, STEP_REACH) and clip_extras(thickness)."""
    return _kernels.step_extras(thickness, _kernels.STEP_REACH) + _kernels.clip_extras(thickness)


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


# ---- several lanes at once ---------------------------------------------------------------------
# Scoring a frame draws all its lanes in one kernel call and computes all their IoUs in another
# (a call per lane costs about what drawing a short lane costs). Pixels and IoUs are exactly
# those of the one-lane functions above.


@dataclass(frozen=True, eq=False)
class LaneRuns:
    """Several lanes' masks as runs per row in shared arrays (`_kernels.lane_set_runs`).

    meta[i] = (y0, first, rows, area, drawn, x0, x1): lane i covers image rows y0 .. y0 + rows - 1,
    rows first .. first + rows - 1 of lo and hi (unused run slots (1, 0)), in the box x0 .. x1 - 1;
    a lane that was None or of fewer than 2 points is not drawn (drawn 0): IoU 0 with anything.
    """

    meta: np.ndarray
    lo: np.ndarray
    hi: np.ndarray

    def __len__(self) -> int:
        return int(self.meta.shape[0])

    @classmethod
    def packed(cls, meta: np.ndarray, lo: np.ndarray, hi: np.ndarray, by_canvas: np.ndarray,
               draw: Callable[[int], tuple]) -> "LaneRuns":
        """lane_set_runs' (meta, lo, hi) with the lanes it left to the canvas (`by_canvas`) packed in
        as it packs the others: `draw(i)` gives lane i's runs, (x0, y0, x1, lo, hi, area), from the
        one-lane kernel whose runs fall back to the canvas (compiled where first needed)."""
        if not by_canvas.any():
            return cls(meta, lo, hi)
        meta = meta.copy()
        blocks = []
        total = 0
        for i in range(len(meta)):
            if by_canvas[i]:
                x0, y0, x1, lane_lo, lane_hi, area = draw(i)
                meta[i] = (y0, total, lane_lo.shape[0], area, 1, x0, x1)
            elif meta[i, 4]:
                first, rows = int(meta[i, 1]), int(meta[i, 2])
                lane_lo, lane_hi = lo[first:first + rows], hi[first:first + rows]
                meta[i, 1] = total
            else:
                continue
            blocks.append((lane_lo, lane_hi))
            total += lane_lo.shape[0]
        slots = max([lo.shape[1]] + [block_lo.shape[1] for block_lo, _ in blocks])
        packed_lo = np.full((total, slots), _kernels.EMPTY_LO, np.int64)
        packed_hi = np.full((total, slots), _kernels.EMPTY_HI, np.int64)
        first = 0
        for block_lo, block_hi in blocks:
            packed_lo[first:first + len(block_lo), :block_lo.shape[1]] = block_lo
            packed_hi[first:first + len(block_hi), :block_hi.shape[1]] = block_hi
            first += len(block_lo)
        return cls(meta, packed_lo, packed_hi)

    def drawn(self, i: int) -> bool:
        return bool(self.meta[i, 4])

    def mask(self, i: int) -> LaneMask | None:
        """Lane i as a LaneMask (None where not drawn)."""
        y0, first, rows, area, drawn, x0, x1 = (int(v) for v in self.meta[i])
        if not drawn:
            return None
        return LaneMask(x0, y0, None, area, x1, self.lo[first:first + rows], self.hi[first:first + rows])

    def ious(self, other: "MaskSet") -> np.ndarray:
        """(len(self), len(other)) IoUs: 0 where either lane is not drawn, NaN for two empty masks."""
        if isinstance(other, LaneRuns):
            return _kernels.lane_set_ious(self.meta, self.lo, self.hi, other.meta, other.lo, other.hi)
        from .iou import iou_matrix  # iou imports this module

        return iou_matrix([self.mask(i) for i in range(len(self))], other.masks)


@dataclass(frozen=True, eq=False)
class MaskList:
    """Several lanes' masks one by one (None: not drawn), as the pixel-by-pixel references give them."""

    masks: tuple[LaneMask | None, ...]

    def __len__(self) -> int:
        return len(self.masks)

    def drawn(self, i: int) -> bool:
        return self.masks[i] is not None

    def mask(self, i: int) -> LaneMask | None:
        return self.masks[i]

    def ious(self, other: "MaskSet") -> np.ndarray:
        """(len(self), len(other)) IoUs: 0 where either lane is not drawn, NaN for two empty masks."""
        from .iou import iou_matrix  # iou imports this module

        return iou_matrix(self.masks, [other.mask(j) for j in range(len(other))])


MaskSet = LaneRuns | MaskList


def _lane_set(lanes: Sequence[Lane | None]) -> tuple[np.ndarray, np.ndarray]:
    """(points, starts): the lanes' points end to end (a None lane as no points)."""
    arrays = [_NO_POINTS if lane is None else lane.points for lane in lanes]
    starts = np.array([0, *accumulate(len(points) for points in arrays)], np.int64)
    points = np.concatenate(arrays) if arrays else _NO_POINTS
    return np.ascontiguousarray(points, np.float64), starts


_NO_POINTS = np.zeros((0, 2), np.float64)


def official_mask_set(lanes: Sequence[Lane], width: int, height: int, thickness: int) -> MaskSet:
    """official_mask of every lane, in one kernel call (a lane of < 2 points: not drawn)."""
    thickness, width, height = int(thickness), int(width), int(height)
    points, starts = _lane_set(lanes)
    meta, lo, hi, by_canvas = _kernels.lane_set_runs(points, starts, True, False, 1.0, 1.0, 0.0, False, thickness,
                                                     width, height, *_step_extras(thickness))
    return LaneRuns.packed(meta, lo, hi, by_canvas, lambda i: _kernels.official_lane_runs(
        points[starts[i]:starts[i + 1]], width, height, thickness, *_quad_extras(thickness), *_step_extras(thickness)))


def map_mask_set(lanes: Sequence[Lane | None], geometry: MapGeometry, thickness: int, spline: bool = False,
                 rounding: str = "nearest") -> MaskSet:
    """map_mask of every lane, in one kernel call (None or < 2 points: not drawn)."""
    if rounding not in ("nearest", "truncate"):
        raise ValueError(f"rounding must be 'nearest' or 'truncate', got {rounding!r}")
    thickness = int(thickness)
    points, starts = _lane_set(lanes)
    drawing = (bool(spline), float(geometry.scale_x), float(geometry.scale_y), float(geometry.crop_top_px),
               rounding == "truncate", thickness, int(geometry.map_width), int(geometry.map_height))
    meta, lo, hi, by_canvas = _kernels.lane_set_runs(points, starts, False, *drawing, *_step_extras(thickness))
    return LaneRuns.packed(meta, lo, hi, by_canvas, lambda i: _kernels.map_lane_runs(
        points[starts[i]:starts[i + 1]], *drawing, *_quad_extras(thickness), *_step_extras(thickness)))


def official_mask_set_by_canvas(lanes: Sequence[Lane], width: int, height: int, thickness: int) -> MaskList:
    """official_mask_set drawn pixel by pixel, lane by lane (official_mask_by_canvas): its reference."""
    return MaskList(tuple(official_mask_by_canvas(lane, width, height, thickness) for lane in lanes))


def map_mask_set_by_canvas(lanes: Sequence[Lane | None], geometry: MapGeometry, thickness: int,
                           spline: bool = False, rounding: str = "nearest") -> MaskList:
    """map_mask_set drawn pixel by pixel, lane by lane (map_mask_by_canvas): its reference."""
    return MaskList(tuple(None if lane is None or len(lane) < 2 else
                          map_mask_by_canvas(lane, geometry, thickness, spline, rounding) for lane in lanes))


def warm_up(groups=("tables", "official", "paper")) -> None:
    """Compile (or load from numba's cache) the drawing kernels of these groups of
    `_kernels.ENTRY_SIGNATURES`, and draw lanes each way once (as scoring draws them: in sets)."""
    for group in groups:
        for kernel, signature in _kernels.ENTRY_SIGNATURES[group]:
            compile_now(kernel, signature)
    # Any frame size compiles the kernels; a CULane-sized one draws them as scoring does.
    width, height = 1640, 590
    lane = Lane(np.array([[700.0, 589.0], [760.0, 450.0], [800.0, 330.0], [815.0, 260.0]]))
    line = Lane(np.array([[650.0, 589.0], [790.0, 270.0]]))
    sets: list = []
    if "official" in groups:
        sets.append(official_mask_set([lane, line], width, height, 30))
    if "paper" in groups:
        geometry = MapGeometry(width, height, 800, 288)
        sets += [map_mask_set([lane, None], geometry, 16, spline, rounding) for spline in (False, True)
                 for rounding in ("nearest", "truncate")]
    if sets:
        sets[0].ious(sets[-1])
