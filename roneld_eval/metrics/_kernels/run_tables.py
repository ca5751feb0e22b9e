"""Precomputed runs of the short and the image-clipped steps, so that runs.py draws most steps by lookup."""

from __future__ import annotations

import numpy as np

from ..._numba_cache import cached_njit
from .canvas import _segment_quad, disc_half_widths, quad_corners
from .cxx import HALF, XY_SHIFT


STEP_REACH = 8  # steps up to this many pixels (in x and in y) have their quads in step_extras' table


@cached_njit(nogil=True)
def step_extras(thickness, reach):
    """For each step (dx, dy) of at most `reach` pixels each way, the pixels its quad holds
    outside the discs at both ends, as runs, and facts about the quad: (runs, counts, info),
    runs[d, k] = (y, left, right) offsets from the step's first point, d = (dx + reach) *
    (2 * reach + 1) + (dy + reach); info[d] = (bridged, |dpx|, |dpy|): bridged is 1 when on
    every row both discs reach, discs and quad together are one run; (dpx, dpy) is how far
    the quad's corners lie from the step's ends (16-bit fixed point, as _segment_quad).

    short_quad_extras' pixels for longer steps, grouped in runs: drawn once each, away from
    any border. Where nothing of it is clipped (_quad_unclipped), a quad is the same shape
    wherever it lies (its arithmetic only ever adds whole pixels to the ends), so the step
    adds just these to its discs.
    """
    radius = ((np.int64(thickness) << (XY_SHIFT - 1)) + HALF) >> XY_SHIFT
    size = 2 * radius + 2 * reach + 16
    centre = size // 2
    zero = np.int64(0)  # a literal 0 would compile the drawing kernels a second time
    half = disc_half_widths(radius)
    side = 2 * reach + 1
    limit = 4 * size
    runs = np.zeros((side * side, limit, 3), np.int64)
    counts = np.zeros(side * side, np.int64)
    info = np.zeros((side * side, 3), np.int64)
    for dx in range(-reach, reach + 1):
        for dy in range(-reach, reach + 1):
            if dx == 0 and dy == 0:
                continue
            direction = (dx + reach) * side + (dy + reach)
            quad = np.zeros((size, size), np.uint8)
            _segment_quad(quad, zero, zero, size, size, centre, centre, centre + dx, centre + dy, thickness)
            _, qx, qy = quad_corners(centre, centre, centre + dx, centre + dy, thickness)
            info[direction, 1] = abs(qx[0] - (np.int64(centre) << XY_SHIFT))
            info[direction, 2] = abs(qy[0] - (np.int64(centre) << XY_SHIFT))
            # Bridged: on the rows both discs reach, disc, quad and disc leave no gap.
            info[direction, 0] = 1
            for y in range(max(centre, centre + dy) - radius, min(centre, centre + dy) + radius + 1):
                k_first = y - (centre - radius)
                k_second = y - (centre + dy - radius)
                left = min(centre - half[k_first], centre + dx - half[k_second])
                right = max(centre + half[k_first], centre + dx + half[k_second])
                for x in range(left, right + 1):
                    in_first = abs(x - centre) <= half[k_first]
                    in_second = abs(x - centre - dx) <= half[k_second]
                    if not (in_first or in_second or quad[y, x]):
                        info[direction, 0] = 0
            for cx, cy in ((centre, centre), (centre + dx, centre + dy)):
                for k in range(2 * radius + 1):
                    line = quad[cy - radius + k]
                    for x in range(cx - half[k], cx + half[k] + 1):
                        line[x] = 0
            for y in range(size):
                x = 0
                while x < size:
                    if quad[y, x] == 0:
                        x += 1
                        continue
                    start = x
                    while x < size and quad[y, x] != 0:
                        x += 1
                    runs[direction, counts[direction], 0] = y - centre
                    runs[direction, counts[direction], 1] = start - centre
                    runs[direction, counts[direction], 2] = x - 1 - centre
                    counts[direction] += 1
    most = 1
    for direction in range(side * side):
        most = max(most, counts[direction])
    return runs[:, :most].copy(), counts, info


@cached_njit(nogil=True)
def _quad_unclipped(ax, ay, bx, by, dpx, dpy, width, height):
    """Whether the quad of a step with corner offsets (dpx, dpy) lies inside the image whole:
    its corners (16-bit fixed point) round to pixels of the image and are not negative, so
    that no line of it is clipped and no pixel of it falls outside."""
    last_x = (np.int64(width) << XY_SHIFT) - HALF - 1
    last_y = (np.int64(height) << XY_SHIFT) - HALF - 1
    return ((min(ax, bx) << XY_SHIFT) - dpx >= 0 and (max(ax, bx) << XY_SHIFT) + dpx <= last_x
            and (min(ay, by) << XY_SHIFT) - dpy >= 0 and (max(ay, by) << XY_SHIFT) + dpy <= last_y)


# Offsets from an image edge (in pixels, of the step's first point) that clip_extras tabulates
# beyond the disc radius: an 8-neighbour step's quad reaches at most radius + 2 from its ends.
CLIP_REACH = 4
_LEFT, _RIGHT, _TOP, _BOTTOM = range(4)  # the edges of clip_extras' tables


@cached_njit(nogil=True)
def clip_extras(thickness):
    """For each 8-neighbour step whose quad one image edge clips, the pixels it holds inside the
    image and outside the discs at both ends, as runs: (runs, counts).

    runs[e, d, o + m, k] = (y, left, right) offsets from the step's first point, for edge e
    (_LEFT, _RIGHT, _TOP, _BOTTOM), direction d = (dx + 1) * 3 + (dy + 1), and o the first
    point's x (left), x - width (right), y (top) or y - height (bottom), |o| <= m = radius +
    CLIP_REACH; counts -1 where not tabulated. Drawn once each, with no other edge near: where
    the other three edges clip nothing (_clipped_edge), the quad's arithmetic (cv::clipLine's
    included) is the same shifted by whole pixels along the edge, so these are its pixels there.
    """
    radius = ((np.int64(thickness) << (XY_SHIFT - 1)) + HALF) >> XY_SHIFT
    reach = radius + CLIP_REACH
    size = 2 * reach + 2 * radius + 16  # an image wide enough that only the one edge comes near
    middle = size // 2
    zero = np.int64(0)  # a literal 0 would compile the drawing kernels a second time
    half = disc_half_widths(radius)
    offsets = 2 * reach + 1
    limit = 2 * size
    runs = np.zeros((4, 9, offsets, limit, 3), np.int64)
    counts = np.full((4, 9, offsets), -1, np.int64)
    quad = np.zeros((size, size), np.uint8)
    for edge in range(4):
        for dx in range(-1, 2):
            for dy in range(-1, 2):
                if dx == 0 and dy == 0:
                    continue
                direction = (dx + 1) * 3 + (dy + 1)
                for o in range(-reach, reach + 1):
                    ax = o if edge == _LEFT else (size + o if edge == _RIGHT else middle)
                    ay = o if edge == _TOP else (size + o if edge == _BOTTOM else middle)
                    quad[:] = 0
                    _segment_quad(quad, zero, zero, size, size, ax, ay, ax + dx, ay + dy, thickness)
                    for cx, cy in ((ax, ay), (ax + dx, ay + dy)):
                        for k in range(2 * radius + 1):
                            y = cy - radius + k
                            if 0 <= y < size:
                                for x in range(max(cx - half[k], 0), min(cx + half[k], size - 1) + 1):
                                    quad[y, x] = 0
                    found = 0
                    for row in range(size):
                        x = 0
                        while x < size:
                            if quad[row, x] == 0:
                                x += 1
                                continue
                            start = x
                            while x < size and quad[row, x] != 0:
                                x += 1
                            if found < limit:
                                runs[edge, direction, o + reach, found, 0] = row - ay
                                runs[edge, direction, o + reach, found, 1] = start - ax
                                runs[edge, direction, o + reach, found, 2] = x - 1 - ax
                            found += 1
                    if found <= limit:
                        counts[edge, direction, o + reach] = found
    most = 1
    for edge in range(4):
        for direction in range(9):
            for o in range(offsets):
                most = max(most, counts[edge, direction, o])
    return runs[:, :, :, :most].copy(), counts


@cached_njit(nogil=True)
def _clipped_edge(ax, ay, bx, by, dpx, dpy, width, height):
    """(edge, offset) when exactly one image edge clips the quad of a step with corner offsets
    (dpx, dpy) (see _quad_unclipped), else (-1, 0)."""
    last_x = (np.int64(width) << XY_SHIFT) - HALF - 1
    last_y = (np.int64(height) << XY_SHIFT) - HALF - 1
    left = (min(ax, bx) << XY_SHIFT) - dpx < 0
    right = (max(ax, bx) << XY_SHIFT) + dpx > last_x
    top = (min(ay, by) << XY_SHIFT) - dpy < 0
    bottom = (max(ay, by) << XY_SHIFT) + dpy > last_y
    if int(left) + int(right) + int(top) + int(bottom) != 1:  # int(): numpy's bools add as "or"
        return -1, 0
    if left:
        return _LEFT, ax
    if right:
        return _RIGHT, ax - width
    if top:
        return _TOP, ay
    return _BOTTOM, ay - height
