"""Lanes drawn as the Python lane scripts draw them (RVLD's evaluate_temporal.py, LLAMAS's
culane_metric/evaluate.py, both LaneATT's): integer points joined by `cv2.line` segments of one
thickness on a full (height, width) canvas; kept as the pixels within their bounding box.

The drawing is done on the part of the canvas the lane can reach: cv2.line's thick lines are
integer polygons and discs that a whole-pixel shift moves unchanged and that are clipped pixel by
pixel, so the pixels are the same (`full_canvas_mask` is the scripts' way, kept as the reference
and for coordinates so large that OpenCV's 16-bit fixed point would overflow differently once
shifted). One polyline: OpenCV draws it as the same thick segments, each with the disc at its
end (the disc at its start is the one before's end), in one call instead of hundreds.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True, eq=False)
class LaneMask:
    """A lane's pixels within their bounding box."""

    top: int
    left: int
    pixels: np.ndarray  # bool, the box
    area: int


# Beyond this, a shift could move a coordinate across OpenCV's fixed-point range (x << 16 in int32).
SAFE_COORDINATE = 1 << 14


def drawn_mask(points: np.ndarray, width: int, height: int, thickness: int) -> LaneMask:
    """The pixels of int32 `points` joined by cv2.line segments `thickness` px wide, on a
    (height, width) canvas."""
    import cv2

    if np.abs(points).max() > SAFE_COORDINATE:
        return full_canvas_mask(points, width, height, thickness)
    reach = thickness // 2 + 2
    left, top = max(int(points[:, 0].min()) - reach, 0), max(int(points[:, 1].min()) - reach, 0)
    right = min(int(points[:, 0].max()) + reach + 1, width)
    bottom = min(int(points[:, 1].max()) + reach + 1, height)
    if right <= left or bottom <= top:
        return LaneMask(0, 0, np.zeros((0, 0), bool), 0)
    canvas = np.zeros((bottom - top, right - left), np.uint8)
    shifted = np.ascontiguousarray(points - np.array([left, top], np.int32))
    cv2.polylines(canvas, [shifted.reshape(-1, 1, 2)], False, color=255, thickness=thickness)
    return _boxed(canvas, left, top)


def full_canvas_mask(points: np.ndarray, width: int, height: int, thickness: int) -> LaneMask:
    """As the scripts draw a lane: every segment of its int32 points on a (height, width) canvas."""
    import cv2

    canvas = np.zeros((height, width), np.uint8)
    for p1, p2 in zip(points[:-1], points[1:]):
        cv2.line(canvas, (int(p1[0]), int(p1[1])), (int(p2[0]), int(p2[1])), color=255, thickness=thickness)
    return _boxed(canvas, 0, 0)


def _boxed(canvas: np.ndarray, left: int, top: int) -> LaneMask:
    import cv2

    x, y, box_width, box_height = cv2.boundingRect(canvas)  # of its nonzero pixels, in C
    if box_width == 0 or box_height == 0:
        return LaneMask(0, 0, np.zeros((0, 0), bool), 0)
    box = canvas[y:y + box_height, x:x + box_width] > 0
    return LaneMask(top + y, left + x, box, int(np.count_nonzero(box)))


def intersection(a: LaneMask, b: LaneMask) -> int:
    """The pixels two masks share."""
    top, left = max(a.top, b.top), max(a.left, b.left)
    bottom = min(a.top + a.pixels.shape[0], b.top + b.pixels.shape[0])
    right = min(a.left + a.pixels.shape[1], b.left + b.pixels.shape[1])
    if bottom <= top or right <= left:
        return 0
    part_a = a.pixels[top - a.top:bottom - a.top, left - a.left:right - a.left]
    part_b = b.pixels[top - b.top:bottom - b.top, left - b.left:right - b.left]
    return int(np.count_nonzero(part_a & part_b))
