"""OpenCV 4.6's LINE_8 polyline with thickness (drawing.cpp), drawn into a canvas cropped to the lane."""

from __future__ import annotations

import math

import numpy as np

from ..._numba_cache import cached_njit
from .cxx import DBL_EPSILON, HALF, XY_ONE, XY_SHIFT, c_div, to_int32


# ---- rasterisation (OpenCV 4.6 drawing.cpp, LINE_8, integer input points) -------------------


@cached_njit(nogil=True)
def _span(canvas, x0, y0, width, height, y, left, right):
    """Set pixels left..right (inclusive) of image row y, clipped to the image.

    The canvas lies inside the image and holds every pixel a lane can reach; clipping to it
    as well only guards memory should that ever not hold.
    """
    row = y - y0
    if y < 0 or y >= height or row < 0 or row >= canvas.shape[0]:
        return
    left = max(left, 0, x0) - x0
    right = min(right, width - 1, x0 + canvas.shape[1] - 1) - x0
    if right < left:
        return
    line = canvas[row]
    for x in range(np.uint64(left), np.uint64(right + 1)):
        line[x] = 1


@cached_njit(nogil=True)
def _pixel(canvas, x0, y0, width, height, x, y):
    if 0 <= x < width and 0 <= y < height:
        row = y - y0
        column = x - x0
        if 0 <= row < canvas.shape[0] and 0 <= column < canvas.shape[1]:
            canvas[row, column] = 1


@cached_njit(nogil=True)
def _clip_line(width, height, x1, y1, x2, y2):
    """cv::clipLine on a (width, height) box with 64-bit ends; returns (inside, x1, y1, x2, y2)."""
    right = width - 1
    bottom = height - 1
    c1 = (x1 < 0) + (x1 > right) * 2 + (y1 < 0) * 4 + (y1 > bottom) * 8
    c2 = (x2 < 0) + (x2 > right) * 2 + (y2 < 0) * 4 + (y2 > bottom) * 8
    if (c1 & c2) == 0 and (c1 | c2) != 0:
        if c1 & 12:
            a = 0 if c1 < 8 else bottom
            x1 += np.int64(float(a - y1) * float(x2 - x1) / float(y2 - y1))
            y1 = a
            c1 = (x1 < 0) + (x1 > right) * 2
        if c2 & 12:
            a = 0 if c2 < 8 else bottom
            x2 += np.int64(float(a - y2) * float(x2 - x1) / float(y2 - y1))
            y2 = a
            c2 = (x2 < 0) + (x2 > right) * 2
        if (c1 & c2) == 0 and (c1 | c2) != 0:
            if c1:
                a = 0 if c1 == 1 else right
                y1 += np.int64(float(a - x1) * float(y2 - y1) / float(x2 - x1))
                x1 = a
                c1 = 0
            if c2:
                a = 0 if c2 == 1 else right
                y2 += np.int64(float(a - x2) * float(y2 - y1) / float(x2 - x1))
                x2 = a
                c2 = 0
    return (c1 | c2) == 0, x1, y1, x2, y2


@cached_njit(nogil=True)
def line2_pixels(x1, y1, x2, y2, width, height, xs, ys):
    """How many pixels OpenCV's Line2 sets, a 1-px line between 16-bit fixed-point ends (a
    quad's outline), written to xs[:count], ys[:count], the far end first as Line2 sets it;
    clipped to the (width, height) image as cv::clipLine does, so at most max(width, height) + 2
    (line_buffers' size: the caller allocates them once for a quad's outline and scanlines)."""
    inside, x1, y1, x2, y2 = _clip_line(np.int64(width) << XY_SHIFT, np.int64(height) << XY_SHIFT, x1, y1, x2, y2)
    if not inside:
        return 0
    dx = x2 - x1
    dy = y2 - y1
    steep = abs(dx) <= abs(dy)
    if not steep:
        if dx < 0:
            dy = -dy
            x1, x2 = x2, x1
            y1, y2 = y2, y1
        step = c_div(dy * XY_ONE, abs(dx) | 1)
        count = (x2 - x1) >> XY_SHIFT
    else:
        if dy < 0:
            dx = -dx
            x1, x2 = x2, x1
            y1, y2 = y2, y1
        step = c_div(dx * XY_ONE, abs(dy) | 1)
        count = (y2 - y1) >> XY_SHIFT
    xs[0] = (x2 + HALF) >> XY_SHIFT
    ys[0] = (y2 + HALF) >> XY_SHIFT
    if not steep:
        x = (x1 + HALF) >> XY_SHIFT
        y = y1 + HALF
    else:
        x = x1 + HALF
        y = (y1 + HALF) >> XY_SHIFT
    for k in range(1, count + 2):
        if not steep:
            xs[k] = x
            ys[k] = y >> XY_SHIFT
            x += 1
            y += step
        else:
            xs[k] = x >> XY_SHIFT
            ys[k] = y
            x += step
            y += 1
    return count + 2


@cached_njit(nogil=True)
def quad_scanlines(qx, qy, width, height, lefts, rights):
    """(first, count): the scanlines of OpenCV's FillConvexPoly for 4 fixed-point vertices
    (shift 16, LINE_8), image row first + k from lefts[k] to rights[k] for k < count (not
    clipped in x; the arrays hold `height`); rows above the image and below it are left out.
    The quad's outline is line2_pixels'."""
    npts = 4
    imin = 0
    xmin = qx[0]
    xmax = qx[0]
    ymin = qy[0]
    ymax = qy[0]
    for i in range(npts):
        if qy[i] < ymin:
            ymin = qy[i]
            imin = i
        ymax = max(ymax, qy[i])
        xmax = max(xmax, qx[i])
        xmin = min(xmin, qx[i])
    xmin = (xmin + HALF) >> XY_SHIFT
    xmax = (xmax + HALF) >> XY_SHIFT
    ymin = (ymin + HALF) >> XY_SHIFT
    ymax = (ymax + HALF) >> XY_SHIFT
    # C++ compares these after a cast to int: far-away (e.g. NaN) points wrap and bail out here.
    if to_int32(xmax) < 0 or to_int32(ymax) < 0 or to_int32(xmin) >= width or to_int32(ymin) >= height:
        return np.int64(0), np.int64(0)
    ymax = min(ymax, height - 1)
    y = to_int32(ymin)
    last = to_int32(ymax)
    first = max(y, 0)
    found = 0
    index0 = imin
    index1 = imin
    edge_x0 = np.int64(-XY_ONE)
    edge_x1 = np.int64(-XY_ONE)
    step0 = np.int64(0)
    step1 = np.int64(0)
    end0 = y
    end1 = y
    edges = npts
    while True:
        for e in range(2):
            if y >= (end0 if e == 0 else end1):
                idx0 = index0 if e == 0 else index1
                di = 1 if e == 0 else npts - 1
                idx = idx0 + di
                if idx >= npts:
                    idx -= npts
                while True:
                    more = edges > 0
                    edges -= 1
                    if not more:
                        break
                    ty = to_int32((qy[idx] + HALF) >> XY_SHIFT)
                    if ty > y:
                        xs = qx[idx0]
                        xe = qx[idx]
                        step = c_div((xe - xs) * 2 + (ty - y), 2 * (ty - y))
                        if e == 0:
                            end0 = ty
                            step0 = step
                            edge_x0 = xs
                            index0 = idx
                        else:
                            end1 = ty
                            step1 = step
                            edge_x1 = xs
                            index1 = idx
                        break
                    idx0 = idx
                    idx += di
                    if idx >= npts:
                        idx -= npts
        if edges < 0:
            break
        if y >= 0:
            # Rows from `first` on come one by one: the jump below stops at row 0.
            left = min(edge_x0, edge_x1)
            right = max(edge_x0, edge_x1)
            lefts[found] = (left + HALF) >> XY_SHIFT
            rights[found] = (right + HALF) >> XY_SHIFT
            found += 1
            edge_x0 += step0
            edge_x1 += step1
            y += 1
        else:
            # Rows above the image draw nothing: jump to the next edge change or row 0 at once.
            jump = min(end0, end1, 0, last + 1) - y
            if jump <= 0:
                jump = 1
            edge_x0 += step0 * jump
            edge_x1 += step1 * jump
            y += jump
        if y > last:
            break
    return np.int64(first), np.int64(found)


@cached_njit(nogil=True)
def line_buffers(width, height):
    """Two arrays that hold line2_pixels' pixels and quad_scanlines' rows on such an image."""
    size = max(np.int64(width), np.int64(height)) + 2
    return np.empty(size, np.int64), np.empty(size, np.int64)


@cached_njit(nogil=True)
def quad_corners(ax, ay, bx, by, thickness):
    """(drawn, qx, qy): the corners, in 16-bit fixed point, of the quad ThickLine draws between two
    integer points; drawn is False for a point (no quad)."""
    p0x = np.int64(ax) << XY_SHIFT
    p0y = np.int64(ay) << XY_SHIFT
    p1x = np.int64(bx) << XY_SHIFT
    p1y = np.int64(by) << XY_SHIFT
    dx = (p0x - p1x) / XY_ONE
    dy = (p1y - p0y) / XY_ONE
    r = dx * dx + dy * dy
    if not abs(r) > DBL_EPSILON:
        return False, (p0x, p0x, p0x, p0x), (p0y, p0y, p0y, p0y)
    odd = thickness & 1
    half_thickness = np.int64(thickness) << (XY_SHIFT - 1)
    r = (half_thickness + odd * XY_ONE * 0.5) / math.sqrt(r)
    dpx = np.int64(np.rint(dy * r))
    dpy = np.int64(np.rint(dx * r))
    return True, (p0x + dpx, p0x - dpx, p1x - dpx, p1x + dpx), (p0y + dpy, p0y - dpy, p1y - dpy, p1y + dpy)


@cached_njit(nogil=True)
def disc_half_widths(radius):
    """Half-width per row offset -radius..radius of OpenCV's filled Circle (midpoint algorithm)."""
    half = np.empty(2 * radius + 1, np.int64)
    for k in range(half.size):
        half[k] = -1
    err = 0
    dx = radius
    dy = 0
    plus = 1
    minus = (radius << 1) - 1
    while dx >= dy:
        half[radius - dy] = max(half[radius - dy], dx)
        half[radius + dy] = max(half[radius + dy], dx)
        half[radius - dx] = max(half[radius - dx], dy)
        half[radius + dx] = max(half[radius + dx], dy)
        dy += 1
        err += plus
        plus += 2
        if err > 0:
            err -= minus
            dx -= 1
            minus -= 2
    return half


@cached_njit(nogil=True)
def _segment_quad(canvas, x0, y0, width, height, ax, ay, bx, by, thickness):
    """The filled quad ThickLine draws between two integer points (nothing for a point):
    FillConvexPoly's outline, then its scanlines."""
    drawn, qx, qy = quad_corners(ax, ay, bx, by, thickness)
    if not drawn:
        return
    xs, ys = line_buffers(width, height)
    px = qx[3]
    py = qy[3]
    for i in range(4):
        for k in range(line2_pixels(px, py, qx[i], qy[i], width, height, xs, ys)):
            _pixel(canvas, x0, y0, width, height, xs[k], ys[k])
        px = qx[i]
        py = qy[i]
    first, count = quad_scanlines(qx, qy, width, height, xs, ys)
    for k in range(count):
        _span(canvas, x0, y0, width, height, first + k, xs[k], ys[k])


@cached_njit(nogil=True)
def draw_polyline(canvas, x0, y0, width, height, xs, ys, thickness, extras, extra_counts, crescents, crescent_counts):
    """Draw a thick polyline of integer points into a canvas whose (0, 0) is image (x0, y0).

    Same pixels as cv::line(img, p[i], p[i+1], 1, thickness) for every segment on a
    (width, height) image: a quad per segment and a disc of radius round(thickness/2) at every
    vertex (the union is the same whichever segment draws a shared disc). One point or none
    draws nothing, as a loop over segments would.

    Most segments of a sampled lane join 8-neighbour pixels. Far enough from the image border
    that nothing is clipped, such a quad is the same shape wherever it lies, so only the few
    pixels it adds to the discs at its ends need drawing: `extras` (from `short_quad_extras`)
    lists them per direction, and drawing them instead of the quad changes no pixel. Likewise
    the union of discs along such steps is the first disc plus, per step, the `crescents` of
    the new disc outside the previous one.
    """
    n = xs.size
    if n < 2:
        return
    radius = ((np.int64(thickness) << (XY_SHIFT - 1)) + HALF) >> XY_SHIFT
    half = disc_half_widths(radius)
    margin = radius + 3
    for i in range(n - 1):
        ax, ay, bx, by = xs[i], ys[i], xs[i + 1], ys[i + 1]
        if ax == bx and ay == by:
            continue
        if (
            abs(bx - ax) <= 1 and abs(by - ay) <= 1
            and min(ax, bx) >= margin and max(ax, bx) < width - margin
            and min(ay, by) >= margin and max(ay, by) < height - margin
        ):
            direction = (bx - ax + 1) * 3 + (by - ay + 1)
            for k in range(extra_counts[direction]):
                _pixel(canvas, x0, y0, width, height, ax + extras[direction, k, 0], ay + extras[direction, k, 1])
            continue
        _segment_quad(canvas, x0, y0, width, height, ax, ay, bx, by, thickness)
    previous = -1
    for i in range(n):
        if i > 0 and xs[i] == xs[i - 1] and ys[i] == ys[i - 1]:
            continue
        cx = xs[i]
        cy = ys[i]
        if cx < -radius or cx >= width + radius or cy < -radius or cy >= height + radius:
            previous = -1
            continue
        inside = margin <= cx < width - margin and margin <= cy < height - margin
        if previous >= 0 and inside:
            step_x = cx - xs[previous]
            step_y = cy - ys[previous]
            if abs(step_x) <= 1 and abs(step_y) <= 1:
                # The disc before is drawn: only this disc's crescent beyond it is new.
                direction = (step_x + 1) * 3 + (step_y + 1)
                # Inside the margin the crescent lies in the image and the canvas: no checks.
                base_x = np.uint64(cx - x0)
                base_y = np.uint64(cy - y0)
                for k in range(crescent_counts[direction]):
                    canvas[base_y + np.uint64(crescents[direction, k, 1] + radius) - np.uint64(radius),
                           base_x + np.uint64(crescents[direction, k, 0] + radius) - np.uint64(radius)] = 1
                previous = i
                continue
        for k in range(2 * radius + 1):
            _span(canvas, x0, y0, width, height, cy - radius + k, cx - half[k], cx + half[k])
        previous = i if inside else -1


@cached_njit(nogil=True)
def short_quad_extras(thickness):
    """For each 8-neighbour step (dx, dy), the pixels its quad holds outside the discs at both ends.

    Returns (extras, counts, crescents, crescent_counts): extras[d, k] = (x, y) offsets from
    the segment's first point, d = (dx + 1) * 3 + (dy + 1); crescents[d, k] offsets from the
    new vertex of the pixels of its disc outside the disc of the vertex one step back. Found by
    drawing each case once, away from any border.
    """
    radius = ((np.int64(thickness) << (XY_SHIFT - 1)) + HALF) >> XY_SHIFT
    size = 2 * radius + 16
    centre = size // 2
    zero = np.int64(0)  # a literal 0 would compile every drawing kernel a second time
    half = disc_half_widths(radius)
    extras = np.zeros((9, size * size, 2), np.int64)
    counts = np.zeros(9, np.int64)
    for dx in range(-1, 2):
        for dy in range(-1, 2):
            if dx == 0 and dy == 0:
                continue
            direction = (dx + 1) * 3 + (dy + 1)
            quad = np.zeros((size, size), np.uint8)
            _segment_quad(quad, zero, zero, size, size, centre, centre, centre + dx, centre + dy, thickness)
            discs = np.zeros((size, size), np.uint8)
            for cx, cy in ((centre, centre), (centre + dx, centre + dy)):
                for k in range(2 * radius + 1):
                    _span(discs, zero, zero, size, size, cy - radius + k, cx - half[k], cx + half[k])
            for y in range(size):
                for x in range(size):
                    if quad[y, x] and not discs[y, x]:
                        extras[direction, counts[direction], 0] = x - centre
                        extras[direction, counts[direction], 1] = y - centre
                        counts[direction] += 1
    # Crescents: pixels of the disc at the origin outside the disc one step (dx, dy) back.
    crescents = np.zeros((9, size * size, 2), np.int64)
    crescent_counts = np.zeros(9, np.int64)
    disc = np.zeros((size, size), np.uint8)
    for k in range(2 * radius + 1):
        _span(disc, zero, zero, size, size, centre - radius + k, centre - half[k], centre + half[k])
    for dx in range(-1, 2):
        for dy in range(-1, 2):
            if dx == 0 and dy == 0:
                continue
            direction = (dx + 1) * 3 + (dy + 1)
            for y in range(size):
                for x in range(size):
                    back_x, back_y = x + dx, y + dy  # the same pixel seen from the previous centre
                    outside = not (0 <= back_x < size and 0 <= back_y < size and disc[back_y, back_x])
                    if disc[y, x] and outside:
                        crescents[direction, crescent_counts[direction], 0] = x - centre
                        crescents[direction, crescent_counts[direction], 1] = y - centre
                        crescent_counts[direction] += 1
    most = 1
    widest = 1
    for direction in range(9):
        most = max(most, counts[direction])
        widest = max(widest, crescent_counts[direction])
    return extras[:, :most].copy(), counts, crescents[:, :widest].copy(), crescent_counts


@cached_njit(nogil=True)
def _low_high(values):
    """(min, max) of a non-empty int64 array (a loop: ndarray.min/max cost seconds to compile)."""
    low = values[0]
    high = values[0]
    for i in range(1, values.size):
        low = min(low, values[i])
        high = max(high, values[i])
    return low, high


@cached_njit(nogil=True)
def polyline_box(xs, ys, thickness, width, height):
    """(x0, y0, x1, y1): the image box (exclusive ends) that can hold a polyline's pixels."""
    margin = thickness // 2 + 3
    if xs.size == 0:
        return 0, 0, 0, 0
    x_low, x_high = _low_high(xs)
    y_low, y_high = _low_high(ys)
    x0 = max(x_low - margin, 0)
    y0 = max(y_low - margin, 0)
    x1 = min(x_high + margin + 1, width)
    y1 = min(y_high + margin + 1, height)
    if x1 <= x0 or y1 <= y0:
        return 0, 0, 0, 0
    return x0, y0, x1, y1


@cached_njit(nogil=True)
def rasterise(xs, ys, thickness, width, height, extras, extra_counts, crescents, crescent_counts):
    """(x0, y0, canvas): a thick polyline's pixels on a width x height image, cropped.

    `extras` .. `crescent_counts`: short_quad_extras(thickness).

    Points far outside the image (NaN converted to INT_MIN by cvRound) may still draw
    1-px outlines across it, as OpenCV does: the canvas then spans the whole image.
    """
    if xs.size < 2:
        return 0, 0, np.zeros((0, 0), np.uint8)
    x_low, x_high = _low_high(xs)
    y_low, y_high = _low_high(ys)
    far = (x_low < -(1 << 20)) or (y_low < -(1 << 20)) or (x_high > (1 << 20)) or (y_high > (1 << 20))
    if far:
        x0, y0, x1, y1 = 0, 0, width, height
    else:
        x0, y0, x1, y1 = polyline_box(xs, ys, thickness, width, height)
    canvas = np.zeros((y1 - y0, x1 - x0), np.uint8)
    if canvas.size:
        draw_polyline(canvas, x0, y0, width, height, xs, ys, thickness, extras, extra_counts, crescents,
                      crescent_counts)
    return x0, y0, canvas


@cached_njit(nogil=True)
def overlap(ax0, ay0, a, bx0, by0, b):
    """Pixels set in both of two cropped masks."""
    left = max(ax0, bx0)
    top = max(ay0, by0)
    right = min(ax0 + a.shape[1], bx0 + b.shape[1])
    bottom = min(ay0 + a.shape[0], by0 + b.shape[0])
    total = 0
    if right <= left:
        return total
    span = np.uint64(right - left)
    offset_a = np.uint64(left - ax0)
    offset_b = np.uint64(left - bx0)
    for y in range(top, bottom):
        row_a = a[y - ay0]
        row_b = b[y - by0]
        count = np.uint64(0)
        for k in range(span):
            count += row_a[offset_a + k] & row_b[offset_b + k]
        total += int(count)
    return total


@cached_njit(nogil=True)
def rasterise_with_area(xs, ys, thickness, width, height, extras, extra_counts, crescents, crescent_counts):
    """rasterise(), plus the number of pixels set: (x0, y0, canvas, area)."""
    x0, y0, canvas = rasterise(xs, ys, thickness, width, height, extras, extra_counts, crescents, crescent_counts)
    area = 0
    for y in range(canvas.shape[0]):
        for x in range(canvas.shape[1]):
            area += canvas[y, x]
    return x0, y0, canvas, area
