"""Numba kernels of the metrics: exact lane rasterisation and the official CULane spline.

The official CULane evaluator draws each lane with OpenCV's `cv::line` (8-connected,
thickness 30). Its pixels decide TP/FP/FN, and OpenCV's rasteriser changed between versions
(pip's OpenCV 5 differs from the 4.6 the evaluator links here on long segments), so we do
not call OpenCV: these kernels compute the same pixels as OpenCV 4.6's 16-bit fixed-point
algorithm (a filled quad per segment, its outline, a filled disc at each vertex), in our own
code, verified against masks the official tool's spline and OpenCV 4.6 drew
(tests/golden/). Masks are drawn into canvases cropped to the lane's bounding box.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from numba import types

from .._numba_cache import cached_njit

XY_SHIFT = 16
XY_ONE = 1 << XY_SHIFT
HALF = XY_ONE >> 1
INT_MIN = -(1 << 31)
DBL_EPSILON = 2.220446049250313e-16
SPLINE_SAMPLES = 50  # SCNN lane_evaluation: splineInterpTimes(lane, 50): samples per lane segment


# ---- numbers as C++ sees them -------------------------------------------------------------


@cached_njit(nogil=True)
def c_div(a, b):
    """C integer division (truncates toward zero; Python's // floors)."""
    q = abs(a) // abs(b)
    return q if (a >= 0) == (b >= 0) else -q


@cached_njit(nogil=True)
def to_int32(value):
    """A 64-bit integer cast to C's 32-bit int (two's complement wrap)."""
    return ((value + (1 << 31)) & 0xFFFFFFFF) - (1 << 31)


# ---- the official spline ----------------------------------------------------------------


@cached_njit(nogil=True, error_model="numpy")
def _spline_moments(xs, ys):
    """(h, mx, my): official_spline's chord lengths and second derivatives at the points."""
    n = xs.size
    h = np.empty(n - 1)
    for i in range(n - 1):
        h[i] = math.sqrt((xs[i + 1] - xs[i]) ** 2 + (ys[i + 1] - ys[i]) ** 2)
    a = np.empty(n - 2)
    b = np.empty(n - 2)
    c = np.empty(n - 2)
    dx = np.empty(n - 2)
    dy = np.empty(n - 2)
    for i in range(n - 2):
        a[i] = h[i]
        b[i] = 2 * (h[i] + h[i + 1])
        c[i] = h[i + 1]
        dx[i] = 6 * ((xs[i + 2] - xs[i + 1]) / h[i + 1] - (xs[i + 1] - xs[i]) / h[i])
        dy[i] = 6 * ((ys[i + 2] - ys[i + 1]) / h[i + 1] - (ys[i + 1] - ys[i]) / h[i])
    c[0] = c[0] / b[0]
    dx[0] = dx[0] / b[0]
    dy[0] = dy[0] / b[0]
    for i in range(1, n - 2):
        tmp = b[i] - a[i] * c[i - 1]
        c[i] = c[i] / tmp
        dx[i] = (dx[i] - a[i] * dx[i - 1]) / tmp
        dy[i] = (dy[i] - a[i] * dy[i - 1]) / tmp
    mx = np.empty(n)
    my = np.empty(n)
    mx[n - 2] = dx[n - 3]
    my[n - 2] = dy[n - 3]
    for i in range(n - 4, -1, -1):
        mx[i + 1] = dx[i] - c[i] * mx[i + 2]
        my[i + 1] = dy[i] - c[i] * my[i + 2]
    mx[0] = 0.0
    mx[n - 1] = 0.0
    my[0] = 0.0
    my[n - 1] = 0.0
    return h, mx, my


@cached_njit(nogil=True, error_model="numpy")
def _cubic(values, h, m, i):
    """(a, b, c, d) of segment i of a coordinate: a + b t + c t^2 + d t^3 for t in [0, h[i])."""
    hi = h[i]
    return (values[i], (values[i + 1] - values[i]) / hi - (2 * hi * m[i] + hi * m[i + 1]) / 6, m[i] / 2,
            (m[i + 1] - m[i]) / (6 * hi))


@cached_njit(nogil=True, error_model="numpy")
def official_spline(xs, ys, times):
    """SCNN lane_evaluation's Spline::splineInterpTimes for 3+ points, bit for bit.

    A natural cubic spline of x and y over chord length, `times` samples per segment, then
    the last input point. Inputs are the float32 values as doubles; operations keep the C++
    order (pow(t, 2) and pow(t, 3) included) so that the doubles match exactly. Repeated
    points divide by a zero chord: IEEE NaNs follow, as in C++ (error_model="numpy").
    """
    n = xs.size
    h, mx, my = _spline_moments(xs, ys)
    out_x = np.empty((n - 1) * times + 1)
    out_y = np.empty((n - 1) * times + 1)
    k_out = 0
    for i in range(n - 1):
        ax, bx, cx, ddx = _cubic(xs, h, mx, i)
        ay, by, cy, ddy = _cubic(ys, h, my, i)
        delta = h[i] / times
        for k in range(times):
            t = delta * k
            out_x[k_out] = ax + bx * t + cx * math.pow(t, 2.0) + ddx * math.pow(t, 3.0)
            out_y[k_out] = ay + by * t + cy * math.pow(t, 2.0) + ddy * math.pow(t, 3.0)
            k_out += 1
    out_x[k_out] = xs[n - 1]
    out_y[k_out] = ys[n - 1]
    return out_x, out_y


# 2^-48: well above what t * t * t instead of pow(t, 3) (and t * t instead of pow(t, 2)) can
# change in a + b t + c t^2 + d t^3, relative to the sizes of its terms and result (about
# 8 units of 2^-53 with pow within one unit in the last place, as any libm's is).
_SPLINE_SLACK = 2.0**-48


@cached_njit(nogil=True, error_model="numpy")
def official_spline_pixels(xs, ys, times):
    """(px, py): cvRound of float32 of each official_spline sample, as official_pixels needs
    them, computed with t * t * t where that cannot change the float32.

    pow(t, 3) is most of official_spline's time. t * t * t can differ from it in the last bit
    or two, which moves the sample by far less than _SPLINE_SLACK of its terms; a sample that
    far from where float32 rounds the other way lands on the same float32, hence the same
    pixel, either way. The size of the terms is bounded once per segment (t < h: |a| + |b| h +
    |c| h^2 + |d| h^3 bounds the terms and the sample, so twice it bounds their sum; a larger
    slack only sends more samples to pow). The others (one in millions, and NaN) are computed
    again with pow, afterwards: a pow call inside the first loop, even one never taken, slows
    it to pow's pace, as a branch in it keeps it from running several samples at once.
    """
    n = xs.size
    h, mx, my = _spline_moments(xs, ys)
    m = (n - 1) * times + 1
    px = np.empty(m, np.int64)
    py = np.empty(m, np.int64)
    unsure = np.zeros(m, np.bool_)  # samples to compute with pow
    for i in range(n - 1):
        ax, bx, cx, ddx = _cubic(xs, h, mx, i)
        ay, by, cy, ddy = _cubic(ys, h, my, i)
        delta = h[i] / times
        hi = h[i]
        slack_x = 2.0 * (abs(ax) + abs(bx) * hi + abs(cx) * hi * hi + abs(ddx) * hi * hi * hi) * _SPLINE_SLACK
        slack_y = 2.0 * (abs(ay) + abs(by) * hi + abs(cy) * hi * hi + abs(ddy) * hi * hi * hi) * _SPLINE_SLACK
        first = i * times
        for k in range(times):
            t = delta * k
            t2 = t * t
            t3 = t2 * t
            x = ax + bx * t + cx * t2 + ddx * t3
            y = ay + by * t + cy * t2 + ddy * t3
            unsure[first + k] = ((np.float32(x - slack_x) != np.float32(x + slack_x))
                                 | (np.float32(y - slack_y) != np.float32(y + slack_y)))
            # _round_float32, without branches
            fx = np.float64(np.float32(x))
            fy = np.float64(np.float32(y))
            px[first + k] = np.int64(np.rint(fx)) if (fx < 2.0**31) & (fx >= -(2.0**31)) else INT_MIN
            py[first + k] = np.int64(np.rint(fy)) if (fy < 2.0**31) & (fy >= -(2.0**31)) else INT_MIN
    for k_out in range(m - 1):
        if not unsure[k_out]:
            continue
        i = k_out // times
        ax, bx, cx, ddx = _cubic(xs, h, mx, i)
        ay, by, cy, ddy = _cubic(ys, h, my, i)
        t = (h[i] / times) * (k_out - i * times)  # official_spline's delta * k
        x = ax + bx * t + cx * math.pow(t, 2.0) + ddx * math.pow(t, 3.0)
        y = ay + by * t + cy * math.pow(t, 2.0) + ddy * math.pow(t, 3.0)
        px[k_out] = _round_float32(np.float64(np.float32(x)))
        py[k_out] = _round_float32(np.float64(np.float32(y)))
    px[m - 1] = _round_float32(np.float64(np.float32(xs[n - 1])))
    py[m - 1] = _round_float32(np.float64(np.float32(ys[n - 1])))
    return px, py


@cached_njit(nogil=True)
def _round_float32(value):
    """cvRound of a float32 (given as a float64 holding it): half to even, INT_MIN when out of range."""
    if not np.isfinite(value) or value >= 2.0**31 or value < -(2.0**31):
        return INT_MIN
    return np.int64(np.rint(value))


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
def _fixed_line(canvas, x0, y0, width, height, x1, y1, x2, y2):
    """OpenCV's Line2: a 1-px line between 16-bit fixed-point ends (the quad's outline)."""
    inside, x1, y1, x2, y2 = _clip_line(np.int64(width) << XY_SHIFT, np.int64(height) << XY_SHIFT, x1, y1, x2, y2)
    if not inside:
        return
    dx = x2 - x1
    dy = y2 - y1
    ax = abs(dx)
    ay = abs(dy)
    if ax > ay:
        if dx < 0:
            dy = -dy
            x1, x2 = x2, x1
            y1, y2 = y2, y1
        y_step = c_div(dy * XY_ONE, ax | 1)
        count = (x2 - x1) >> XY_SHIFT
        _pixel(canvas, x0, y0, width, height, (x2 + HALF) >> XY_SHIFT, (y2 + HALF) >> XY_SHIFT)
        x = (x1 + HALF) >> XY_SHIFT
        y = y1 + HALF
        while count >= 0:
            _pixel(canvas, x0, y0, width, height, x, y >> XY_SHIFT)
            x += 1
            y += y_step
            count -= 1
    else:
        if dy < 0:
            dx = -dx
            x1, x2 = x2, x1
            y1, y2 = y2, y1
        x_step = c_div(dx * XY_ONE, ay | 1)
        count = (y2 - y1) >> XY_SHIFT
        _pixel(canvas, x0, y0, width, height, (x2 + HALF) >> XY_SHIFT, (y2 + HALF) >> XY_SHIFT)
        x = x1 + HALF
        y = (y1 + HALF) >> XY_SHIFT
        while count >= 0:
            _pixel(canvas, x0, y0, width, height, x >> XY_SHIFT, y)
            x += x_step
            y += 1
            count -= 1


@cached_njit(nogil=True)
def _fill_quad(canvas, x0, y0, width, height, ax, ay, bx, by, cx, cy, dx, dy):
    """OpenCV's FillConvexPoly for 4 fixed-point vertices (shift 16, LINE_8): outline, then scanlines."""
    qx = (ax, bx, cx, dx)
    qy = (ay, by, cy, dy)
    npts = 4
    imin = 0
    xmin = qx[0]
    xmax = qx[0]
    ymin = qy[0]
    ymax = qy[0]
    px = qx[npts - 1]
    py = qy[npts - 1]
    for i in range(npts):
        if qy[i] < ymin:
            ymin = qy[i]
            imin = i
        ymax = max(ymax, qy[i])
        xmax = max(xmax, qx[i])
        xmin = min(xmin, qx[i])
        _fixed_line(canvas, x0, y0, width, height, px, py, qx[i], qy[i])
        px = qx[i]
        py = qy[i]
    xmin = (xmin + HALF) >> XY_SHIFT
    xmax = (xmax + HALF) >> XY_SHIFT
    ymin = (ymin + HALF) >> XY_SHIFT
    ymax = (ymax + HALF) >> XY_SHIFT
    # C++ compares these after a cast to int: far-away (e.g. NaN) points wrap and bail out here.
    if to_int32(xmax) < 0 or to_int32(ymax) < 0 or to_int32(xmin) >= width or to_int32(ymin) >= height:
        return
    ymax = min(ymax, height - 1)
    y = to_int32(ymin)
    last = to_int32(ymax)
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
            if edge_x0 > edge_x1:
                _span(canvas, x0, y0, width, height, y, (edge_x1 + HALF) >> XY_SHIFT, (edge_x0 + HALF) >> XY_SHIFT)
            else:
                _span(canvas, x0, y0, width, height, y, (edge_x0 + HALF) >> XY_SHIFT, (edge_x1 + HALF) >> XY_SHIFT)
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
    """The filled quad ThickLine draws between two integer points (nothing for a point)."""
    p0x = np.int64(ax) << XY_SHIFT
    p0y = np.int64(ay) << XY_SHIFT
    p1x = np.int64(bx) << XY_SHIFT
    p1y = np.int64(by) << XY_SHIFT
    dx = (p0x - p1x) / XY_ONE
    dy = (p1y - p0y) / XY_ONE
    r = dx * dx + dy * dy
    if abs(r) > DBL_EPSILON:
        odd = thickness & 1
        half_thickness = np.int64(thickness) << (XY_SHIFT - 1)
        r = (half_thickness + odd * XY_ONE * 0.5) / math.sqrt(r)
        dpx = np.int64(np.rint(dy * r))
        dpy = np.int64(np.rint(dx * r))
        _fill_quad(
            canvas, x0, y0, width, height,
            p0x + dpx, p0y + dpy, p0x - dpx, p0y - dpy, p1x - dpx, p1y - dpy, p1x + dpx, p1y + dpy,
        )


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


# ---- per-row runs: the same pixels without a canvas ----------------------------------------
# A lane's mask is, row by row, one run of pixels (a few at most), so a mask can be held as
# each row's runs: IoU then costs a step per row instead of one per pixel, and the hundreds of
# discs along a sampled lane cost an interval per disc row instead of their pixels. The runs
# are rasterise()'s pixels exactly: every piece below is the canvas code's own arithmetic, with
# "set pixels left..right of row y" adding an interval instead.
#
# Runs are added into (rows, _RUN_SLOTS) arrays lo, hi and counts (rows,): the runs of a row
# are disjoint and do not touch; a piece joins every run it overlaps or touches. Callers test
# the usual case (a row with one run that the piece overlaps or touches) inline: a call that
# passes arrays costs more than the work itself.

_RUN_SLOTS = 8  # runs a row may hold while pieces are added; more sends the lane to the canvas
_EMPTY_LO = 1  # an unused run slot in a finished mask is (1, 0): it overlaps nothing
_EMPTY_HI = 0


@cached_njit(nogil=True)
def _merge_run(lo, hi, counts, row, left, right):
    """Add pixels left..right to row `row` (an index into the arrays, which it must be);
    False when the row would need more than _RUN_SLOTS runs.

    The hot loops that add runs (_add_quad, _add_chain, _add_listed, polyline_runs) write its
    usual cases out in place (a run that extends the row's only one, or a row's first run): with
    them behind a shared helper kernel, inlined or not, official masks took 30% longer
    (0.152 -> 0.198 ms a frame of 3,000 CULane label files)."""
    kept = 0
    for i in range(counts[row]):
        if lo[row, i] > right + 1 or hi[row, i] < left - 1:
            lo[row, kept] = lo[row, i]
            hi[row, kept] = hi[row, i]
            kept += 1
        else:
            left = min(left, lo[row, i])
            right = max(right, hi[row, i])
    if kept == lo.shape[1]:
        return False
    lo[row, kept] = left
    hi[row, kept] = right
    counts[row] = kept + 1
    return True


@cached_njit(nogil=True)
def _add_span(lo, hi, counts, x0, y0, x1, y1, width, height, y, left, right):
    """_span for runs: pixels left..right of image row y, clipped to the image and to the box
    (x0, y0)..(x1, y1) the arrays' rows cover. False when the row has no slot left."""
    if y < 0 or y >= height or y < y0 or y >= y1:
        return True
    left = max(left, 0, x0)
    right = min(right, width - 1, x1 - 1)
    if right < left:
        return True
    row = y - y0
    if counts[row] == 1 and left <= hi[row, 0] + 1 and right >= lo[row, 0] - 1:
        lo[row, 0] = min(lo[row, 0], left)
        hi[row, 0] = max(hi[row, 0], right)
        return True
    return _merge_run(lo, hi, counts, row, left, right)


@cached_njit(nogil=True)
def _add_fixed_line(lo, hi, counts, x0, y0, x1, y1, width, height, ax, ay, bx, by):
    """_fixed_line for runs (the same pixels: OpenCV's Line2 between 16-bit fixed-point ends)."""
    inside, ax, ay, bx, by = _clip_line(np.int64(width) << XY_SHIFT, np.int64(height) << XY_SHIFT, ax, ay, bx, by)
    if not inside:
        return True
    dx = bx - ax
    dy = by - ay
    steep = abs(dx) <= abs(dy)
    if not steep:
        if dx < 0:
            dy = -dy
            ax, bx = bx, ax
            ay, by = by, ay
        step = c_div(dy * XY_ONE, abs(dx) | 1)
        count = (bx - ax) >> XY_SHIFT
    else:
        if dy < 0:
            dx = -dx
            ax, bx = bx, ax
            ay, by = by, ay
        step = c_div(dx * XY_ONE, abs(dy) | 1)
        count = (by - ay) >> XY_SHIFT
    # The far end first, as Line2 draws it (the order changes nothing in a union).
    end_x = (bx + HALF) >> XY_SHIFT
    end_y = (by + HALF) >> XY_SHIFT
    if not _add_span(lo, hi, counts, x0, y0, x1, y1, width, height, end_y, end_x, end_x):
        return False
    if not steep:
        x = (ax + HALF) >> XY_SHIFT
        y = ay + HALF
    else:
        x = ax + HALF
        y = (ay + HALF) >> XY_SHIFT
    while count >= 0:
        if not steep:
            px = x
            py = y >> XY_SHIFT
        else:
            px = x >> XY_SHIFT
            py = y
        if 0 <= px < width and 0 <= py < height and x0 <= px < x1 and y0 <= py < y1:
            row = py - y0
            if counts[row] == 1 and lo[row, 0] - 1 <= px <= hi[row, 0] + 1:
                lo[row, 0] = min(lo[row, 0], px)
                hi[row, 0] = max(hi[row, 0], px)
            elif not _merge_run(lo, hi, counts, row, px, px):
                return False
        if not steep:
            x += 1
            y += step
        else:
            x += step
            y += 1
        count -= 1
    return True


@cached_njit(nogil=True)
def _add_quad(lo, hi, counts, x0, y0, x1, y1, width, height, ax, ay, bx, by, thickness):
    """_segment_quad for runs: the filled quad ThickLine draws between two integer points
    (_fill_quad's scanlines, then its outline: the same pixels in another order)."""
    p0x = np.int64(ax) << XY_SHIFT
    p0y = np.int64(ay) << XY_SHIFT
    p1x = np.int64(bx) << XY_SHIFT
    p1y = np.int64(by) << XY_SHIFT
    ddx = (p0x - p1x) / XY_ONE
    ddy = (p1y - p0y) / XY_ONE
    r = ddx * ddx + ddy * ddy
    if not abs(r) > DBL_EPSILON:
        return True
    odd = thickness & 1
    half_thickness = np.int64(thickness) << (XY_SHIFT - 1)
    r = (half_thickness + odd * XY_ONE * 0.5) / math.sqrt(r)
    dpx = np.int64(np.rint(ddy * r))
    dpy = np.int64(np.rint(ddx * r))
    qx = (p0x + dpx, p0x - dpx, p1x - dpx, p1x + dpx)
    qy = (p0y + dpy, p0y - dpy, p1y - dpy, p1y + dpy)
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
    filled = not (to_int32(xmax) < 0 or to_int32(ymax) < 0 or to_int32(xmin) >= width or to_int32(ymin) >= height)
    if filled:
        top = max(y0, 0)
        bottom = min(y1, height)
        leftmost = max(x0, 0)
        rightmost = min(x1, width) - 1
        ymax = min(ymax, height - 1)
        y = to_int32(ymin)
        last = to_int32(ymax)
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
                if edge_x0 > edge_x1:
                    left = (edge_x1 + HALF) >> XY_SHIFT
                    right = (edge_x0 + HALF) >> XY_SHIFT
                else:
                    left = (edge_x0 + HALF) >> XY_SHIFT
                    right = (edge_x1 + HALF) >> XY_SHIFT
                # _add_span, its usual case inline
                left = max(left, leftmost)
                right = min(right, rightmost)
                if top <= y < bottom and left <= right:
                    row = y - y0
                    if counts[row] == 1 and left <= hi[row, 0] + 1 and right >= lo[row, 0] - 1:
                        lo[row, 0] = min(lo[row, 0], left)
                        hi[row, 0] = max(hi[row, 0], right)
                    elif counts[row] == 0:
                        lo[row, 0] = left
                        hi[row, 0] = right
                        counts[row] = 1
                    elif not _merge_run(lo, hi, counts, row, left, right):
                        return False
                edge_x0 += step0
                edge_x1 += step1
                y += 1
            else:
                jump = min(end0, end1, 0, last + 1) - y
                if jump <= 0:
                    jump = 1
                edge_x0 += step0 * jump
                edge_x1 += step1 * jump
                y += jump
            if y > last:
                break
    px = qx[npts - 1]
    py = qy[npts - 1]
    for i in range(npts):
        if not _add_fixed_line(lo, hi, counts, x0, y0, x1, y1, width, height, px, py, qx[i], qy[i]):
            return False
        px = qx[i]
        py = qy[i]
    return True


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
            length = math.sqrt(float(dx * dx + dy * dy))  # as _segment_quad computes its corners
            r = ((np.int64(thickness) << (XY_SHIFT - 1)) + (thickness & 1) * XY_ONE * 0.5) / length
            info[direction, 1] = abs(np.int64(np.rint(dy * r)))
            info[direction, 2] = abs(np.int64(np.rint(-dx * r)))
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


_NO_PIXEL = np.int64(1 << 40)  # chain_lo of a row no disc has reached; chain_hi is -_NO_PIXEL


@cached_njit(nogil=True)
def _add_chain(lo, hi, counts, x0, y0, x1, y1, width, height, chain_lo, chain_hi, pad, first_row, last_row):
    """Add a chain's rows (chain_lo/chain_hi, index = image row - y0 + pad) as _add_span would,
    and empty them again."""
    top = max(y0, 0)
    bottom = min(y1, height)
    leftmost = max(x0, 0)
    rightmost = min(x1, width) - 1
    for y in range(first_row, last_row + 1):
        i = y - y0 + pad
        left = max(chain_lo[i], leftmost)
        right = min(chain_hi[i], rightmost)
        chain_lo[i] = _NO_PIXEL
        chain_hi[i] = -_NO_PIXEL
        if y < top or y >= bottom or right < left:
            continue
        row = y - y0
        if counts[row] == 1 and left <= hi[row, 0] + 1 and right >= lo[row, 0] - 1:
            lo[row, 0] = min(lo[row, 0], left)
            hi[row, 0] = max(hi[row, 0], right)
        elif counts[row] == 0:
            lo[row, 0] = left
            hi[row, 0] = right
            counts[row] = 1
        elif not _merge_run(lo, hi, counts, row, left, right):
            return False
    return True



@cached_njit(nogil=True)
def _add_listed(lo, hi, counts, x0, y0, x1, y1, width, height, ax, ay, listed, count):
    """Add `count` runs (y, left, right) listed as offsets from (ax, ay), kept to the image and
    the box as _pixel keeps them. False when a row has no slot left."""
    leftmost = max(x0, 0)
    rightmost = min(x1, width) - 1
    top = max(y0, 0)
    bottom = min(y1, height)
    for k in range(count):
        y = ay + listed[k, 0]
        left = max(ax + listed[k, 1], leftmost)
        right = min(ax + listed[k, 2], rightmost)
        if y < top or y >= bottom or right < left:
            continue
        row = y - y0
        if counts[row] == 1 and left <= hi[row, 0] + 1 and right >= lo[row, 0] - 1:
            lo[row, 0] = min(lo[row, 0], left)
            hi[row, 0] = max(hi[row, 0], right)
        elif counts[row] == 0:
            lo[row, 0] = left
            hi[row, 0] = right
            counts[row] = 1
        elif not _merge_run(lo, hi, counts, row, left, right):
            return False
    return True

@cached_njit(nogil=True)
def polyline_runs(xs, ys, thickness, width, height, step_runs, step_counts, step_info, clip_runs, clip_counts):
    """(ok, x0, y0, x1, lo, hi, area): rasterise()'s pixels as runs per row, without a canvas.

    (x0, y0, x1) and the rows are rasterise()'s canvas box; lo[r, k]..hi[r, k] (image x) are
    the runs of image row y0 + r, unused slots (1, 0). ok is False (the rest meaningless) for
    fewer than 2 points, far points, an empty box, or a row of more than _RUN_SLOTS runs.
    `step_runs` .. `step_info`: step_extras(thickness, STEP_REACH); `clip_runs`, `clip_counts`:
    clip_extras(thickness).

    The pixels are draw_polyline's: a disc at each vertex and a quad per segment. A quad that
    step_extras lists and that lies whole inside the image (_quad_unclipped) adds the pixels
    listed; any other is drawn whole (_add_quad). Discs go by chains: consecutive vertices
    with y never turning back, each step either to an 8-neighbour (the two discs overlap or
    touch on every row both reach) or a listed, whole and `bridged` one (its quad fills any
    gap there). The discs of a chain that reach an image row belong to consecutive vertices,
    so on that row the chain's discs and quads are one interval, from the leftmost disc end to
    the rightmost (min and max), plus its quads' pixels outside the discs. Clipping the discs
    to the image keeps that true. An 8-neighbour step's quad that one edge clips adds the pixels
    clip_extras lists for it.
    """
    n = xs.size
    none = np.empty((0, 1), np.int64)
    if n < 2:
        return False, 0, 0, 0, none, none, 0
    clip_reach = (clip_runs.shape[2] - 1) // 2
    x_low, x_high = _low_high(xs)
    y_low, y_high = _low_high(ys)
    if (x_low < -(1 << 20)) or (y_low < -(1 << 20)) or (x_high > (1 << 20)) or (y_high > (1 << 20)):
        return False, 0, 0, 0, none, none, 0
    x0, y0, x1, y1 = polyline_box(xs, ys, thickness, width, height)
    if x1 <= x0 or y1 <= y0:
        return False, 0, 0, 0, none, none, 0
    rows = y1 - y0
    radius = ((np.int64(thickness) << (XY_SHIFT - 1)) + HALF) >> XY_SHIFT
    half = disc_half_widths(radius)
    lo = np.empty((rows, _RUN_SLOTS), np.int64)
    hi = np.empty((rows, _RUN_SLOTS), np.int64)
    counts = np.zeros(rows, np.int64)
    # A chain's rows, padded so that the disc of any vertex drawn (up to `radius` outside the
    # image) fits, whatever the box.
    pad = 2 * radius + 1
    chain_lo = np.full(rows + 2 * pad, _NO_PIXEL)
    chain_hi = np.full(rows + 2 * pad, -_NO_PIXEL)
    span = np.uint64(2 * radius + 1)
    side = 2 * STEP_REACH + 1
    # 1. Discs, chain by chain; within a chain, a run of vertices on one row at a time (as the
    # chain's steps leave no gap, the run's discs make one interval per row from its leftmost
    # to its rightmost vertex). i == n ends the last chain. Quads that are not in step_extras'
    # table are added whole as their step comes, after the chain they end: each piece then
    # meets those before it, and rows keep few runs while they grow.
    chain_open = False
    chain_dy = 0  # the chain's direction in y once it has one
    first_row = np.int64(0)
    last_row = np.int64(-1)
    run_y = np.int64(0)
    run_left = np.int64(0)
    run_right = np.int64(-1)  # no run while right < left
    previous = False  # whether a vertex came before (prev_x, prev_y)
    prev_x = np.int64(0)
    prev_y = np.int64(0)
    for i in range(n + 1):
        cx = np.int64(0)
        cy = np.int64(0)
        drawn = False
        if i < n:
            if i > 0 and xs[i] == xs[i - 1] and ys[i] == ys[i - 1]:
                continue
            cx = xs[i]
            cy = ys[i]
            drawn = not (cx < -radius or cx >= width + radius or cy < -radius or cy >= height + radius)
        dx = cx - prev_x
        dy = cy - prev_y
        tabled = False  # the step's quad is step_extras' pixels (and discs): short and whole
        if abs(dx) <= STEP_REACH and abs(dy) <= STEP_REACH:
            step = (dx + STEP_REACH) * side + (dy + STEP_REACH)
            tabled = _quad_unclipped(prev_x, prev_y, cx, cy, step_info[step, 1], step_info[step, 2], width, height)
        joins = False
        if drawn and chain_open:  # the previous vertex is the chain's last
            if abs(dx) <= 1 and abs(dy) <= 1:
                joins = True
            elif tabled:
                joins = step_info[(dx + STEP_REACH) * side + (dy + STEP_REACH), 0] != 0
            direction = 1 if dy > 0 else (-1 if dy < 0 else 0)
            joins = joins and (direction == 0 or chain_dy == 0 or direction == chain_dy)
            if joins and direction != 0:
                chain_dy = direction
        if joins and cy == run_y:
            run_left = min(run_left, cx)
            run_right = max(run_right, cx)
        else:
            if run_right >= run_left:  # the run ends: its discs join the chain
                disc_top = np.uint64(run_y - radius - y0 + pad)
                for k in range(span):
                    chain_lo[disc_top + k] = min(chain_lo[disc_top + k], run_left - half[k])
                    chain_hi[disc_top + k] = max(chain_hi[disc_top + k], run_right + half[k])
                first_row = min(first_row, run_y - radius)
                last_row = max(last_row, run_y + radius)
                run_right = run_left - 1
            if not joins and chain_open:  # the chain ends: its rows join the mask
                if not _add_chain(lo, hi, counts, x0, y0, x1, y1, width, height, chain_lo, chain_hi, pad,
                                  first_row, last_row):
                    return False, 0, 0, 0, none, none, 0
                chain_open = False
            if drawn:
                if not chain_open:
                    chain_open = True
                    chain_dy = 0
                    first_row = cy - radius
                    last_row = cy + radius
                run_y = cy
                run_left = cx
                run_right = cx
        if i < n:
            if previous and not tabled:
                edge = -1
                offset = 0
                if abs(dx) <= 1 and abs(dy) <= 1:
                    step = (dx + STEP_REACH) * side + (dy + STEP_REACH)
                    edge, offset = _clipped_edge(prev_x, prev_y, cx, cy, step_info[step, 1], step_info[step, 2],
                                                 width, height)
                neighbour = (dx + 1) * 3 + (dy + 1)
                if edge >= 0 and abs(offset) <= clip_reach and clip_counts[edge, neighbour, offset + clip_reach] >= 0:
                    if not _add_listed(lo, hi, counts, x0, y0, x1, y1, width, height, prev_x, prev_y,
                                       clip_runs[edge, neighbour, offset + clip_reach],
                                       clip_counts[edge, neighbour, offset + clip_reach]):
                        return False, 0, 0, 0, none, none, 0
                elif not _add_quad(lo, hi, counts, x0, y0, x1, y1, width, height, prev_x, prev_y, cx, cy, thickness):
                    return False, 0, 0, 0, none, none, 0
            previous = True
            prev_x = cx
            prev_y = cy
    # 2. The quads of steps in step_extras' table: the pixels it lists, kept to the image and
    # the box as _pixel keeps them.
    leftmost = max(x0, 0)
    rightmost = min(x1, width) - 1
    top = max(y0, 0)
    bottom = min(y1, height)
    for i in range(n - 1):
        ax, ay, bx, by = xs[i], ys[i], xs[i + 1], ys[i + 1]
        if ax == bx and ay == by:
            continue
        dx = bx - ax
        dy = by - ay
        if abs(dx) > STEP_REACH or abs(dy) > STEP_REACH:
            continue  # drawn whole above
        direction = (dx + STEP_REACH) * side + (dy + STEP_REACH)
        if not _quad_unclipped(ax, ay, bx, by, step_info[direction, 1], step_info[direction, 2], width, height):
            continue  # drawn whole above
        for k in range(step_counts[direction]):
            y = ay + step_runs[direction, k, 0]
            left = max(ax + step_runs[direction, k, 1], leftmost)
            right = min(ax + step_runs[direction, k, 2], rightmost)
            if y < top or y >= bottom or right < left:
                continue
            row = y - y0
            if counts[row] == 1 and left <= hi[row, 0] + 1 and right >= lo[row, 0] - 1:
                lo[row, 0] = min(lo[row, 0], left)
                hi[row, 0] = max(hi[row, 0], right)
            elif counts[row] == 0:
                lo[row, 0] = left
                hi[row, 0] = right
                counts[row] = 1
            elif not _merge_run(lo, hi, counts, row, left, right):
                return False, 0, 0, 0, none, none, 0
    first, last, area = _finish_runs(lo, hi, counts)
    return True, x0, y0, x1, first, last, area


@cached_njit(nogil=True)
def _finish_runs(lo, hi, counts):
    """(lo, hi, area): the used slots only (as many columns as the fullest row needs, unused
    ones (1, 0)), and the number of pixels."""
    most = 1
    for r in range(counts.size):
        most = max(most, counts[r])
    first = np.full((counts.size, most), _EMPTY_LO, np.int64)
    last = np.full((counts.size, most), _EMPTY_HI, np.int64)
    area = np.int64(0)
    for r in range(counts.size):
        for k in range(counts[r]):
            first[r, k] = lo[r, k]
            last[r, k] = hi[r, k]
            area += hi[r, k] - lo[r, k] + 1
    return first, last, area


@cached_njit(nogil=True)
def canvas_runs(canvas):
    """(lo, hi, area) of a canvas's pixels, runs per row as polyline_runs gives them (columns
    from 0: add the canvas's x0)."""
    rows, columns = canvas.shape
    most = 1
    for r in range(rows):
        found = 0
        previous = 0
        for c in range(columns):
            if canvas[r, c] and not previous:
                found += 1
            previous = canvas[r, c]
        most = max(most, found)
    lo = np.full((rows, most), _EMPTY_LO, np.int64)
    hi = np.full((rows, most), _EMPTY_HI, np.int64)
    area = np.int64(0)
    for r in range(rows):
        k = 0
        c = 0
        while c < columns:
            if canvas[r, c] == 0:
                c += 1
                continue
            start = c
            while c < columns and canvas[r, c] != 0:
                c += 1
            lo[r, k] = start
            hi[r, k] = c - 1
            area += c - start
            k += 1
    return lo, hi, area


@cached_njit(nogil=True)
def rasterise_runs(xs, ys, thickness, width, height, extras, extra_counts, crescents, crescent_counts, step_runs,
                   step_counts, step_info, clip_runs, clip_counts):
    """rasterise_with_area()'s mask as runs, (x0, y0, x1, lo, hi, area): polyline_runs where it
    can, else the canvas read row by row (far points, or a row of too many runs).

    `extras` .. `crescent_counts`: short_quad_extras(thickness); `step_runs` .. `step_info`:
    step_extras(thickness, STEP_REACH); `clip_runs`, `clip_counts`: clip_extras(thickness).
    """
    ok, x0, y0, x1, lo, hi, area = polyline_runs(xs, ys, thickness, width, height, step_runs, step_counts,
                                                 step_info, clip_runs, clip_counts)
    if ok:
        return x0, y0, x1, lo, hi, area
    x0, y0, canvas, area = rasterise_with_area(xs, ys, thickness, width, height, extras, extra_counts, crescents,
                                               crescent_counts)
    lo, hi, area = canvas_runs(canvas)
    for r in range(lo.shape[0]):
        for k in range(lo.shape[1]):
            if hi[r, k] >= lo[r, k]:
                lo[r, k] += x0
                hi[r, k] += x0
    return x0, y0, x0 + canvas.shape[1], lo, hi, area


@cached_njit(nogil=True)
def run_overlap(ay0, a_lo, a_hi, by0, b_lo, b_hi):
    """Pixels set in both of two masks held as runs per row (rows from ay0 and by0)."""
    top = max(ay0, by0)
    bottom = min(ay0 + a_lo.shape[0], by0 + b_lo.shape[0])
    total = np.int64(0)
    if a_lo.shape[1] == 1 and b_lo.shape[1] == 1:
        for y in range(top, bottom):
            count = min(a_hi[y - ay0, 0], b_hi[y - by0, 0]) - max(a_lo[y - ay0, 0], b_lo[y - by0, 0]) + 1
            total += max(count, 0)
        return total
    for y in range(top, bottom):
        i = y - ay0
        j = y - by0
        for p in range(a_lo.shape[1]):
            for q in range(b_lo.shape[1]):
                count = min(a_hi[i, p], b_hi[j, q]) - max(a_lo[i, p], b_lo[j, q]) + 1
                total += max(count, 0)
    return total


@cached_njit(nogil=True, error_model="numpy")
def official_pixels(points):
    """(px, py): the integer vertices the official CULane evaluator draws a lane through.

    `points` (N, 2) float64, N >= 2. Points become float32 (cv::Point2f), 3+ points go through
    the official spline, samples become float32 again, then cv::Point (cvRound).
    """
    n = points.shape[0]
    xs = np.empty(n)
    ys = np.empty(n)
    for i in range(n):
        xs[i] = np.float32(points[i, 0])
        ys[i] = np.float32(points[i, 1])
    if n >= 3:
        return official_spline_pixels(xs, ys, SPLINE_SAMPLES)
    px = np.empty(n, np.int64)
    py = np.empty(n, np.int64)
    for i in range(n):
        px[i] = _round_float32(xs[i])
        py[i] = _round_float32(ys[i])
    return px, py


@cached_njit(nogil=True, error_model="numpy")
def official_pixels_by_pow(points):
    """official_pixels from official_spline's samples (pow throughout): its reference."""
    n = points.shape[0]
    xs = np.empty(n)
    ys = np.empty(n)
    for i in range(n):
        xs[i] = np.float32(points[i, 0])
        ys[i] = np.float32(points[i, 1])
    if n >= 3:
        xs, ys = official_spline(xs, ys, SPLINE_SAMPLES)
    m = xs.size
    px = np.empty(m, np.int64)
    py = np.empty(m, np.int64)
    for i in range(m):
        px[i] = _round_float32(np.float64(np.float32(xs[i])))
        py[i] = _round_float32(np.float64(np.float32(ys[i])))
    return px, py


@cached_njit(nogil=True, error_model="numpy")
def official_lane(points, width, height, thickness, extras, extra_counts, crescents, crescent_counts):
    """(x0, y0, canvas, area) of a lane as the official CULane evaluator draws it
    (official_pixels_by_pow, then rasterise): every pixel drawn, pow in every spline sample,
    as before runs per row; the reference for `official_lane_runs`."""
    px, py = official_pixels_by_pow(points)
    return rasterise_with_area(px, py, thickness, width, height, extras, extra_counts, crescents, crescent_counts)


@cached_njit(nogil=True, error_model="numpy")
def official_lane_runs(points, width, height, thickness, extras, extra_counts, crescents, crescent_counts, step_runs,
                       step_counts, step_info, clip_runs, clip_counts):
    """official_lane's mask as runs per row: (x0, y0, x1, lo, hi, area) (rasterise_runs)."""
    px, py = official_pixels(points)
    return rasterise_runs(px, py, thickness, width, height, extras, extra_counts, crescents, crescent_counts,
                          step_runs, step_counts, step_info, clip_runs, clip_counts)


@cached_njit(nogil=True, error_model="numpy")
def map_pixels(points, spline, scale_x, scale_y, offset_y, truncate):
    """(px, py): the map pixels a lane is drawn through at map resolution (the paper's protocol).

    Image points (optionally through the official spline, non-finite samples dropped) map to
    x / scale_x, (y - offset_y) / scale_y, then snap to pixels: half to even, or C's int()
    with `truncate`.
    """
    n = points.shape[0]
    if spline and n >= 3:
        xs, ys = official_spline(points[:, 0].copy(), points[:, 1].copy(), SPLINE_SAMPLES)
    else:
        xs = points[:, 0].copy()
        ys = points[:, 1].copy()
    return _snapped(xs, ys, scale_x, scale_y, offset_y, truncate)


@cached_njit(nogil=True, error_model="numpy")
def _snap(value, offset, scale, truncate):
    """A coordinate in map pixels, snapped: (value - offset) / scale, then rint or trunc."""
    mapped = (value - offset) / scale
    return np.trunc(mapped) if truncate else np.rint(mapped)


@cached_njit(nogil=True, error_model="numpy")
def _snapped(xs, ys, scale_x, scale_y, offset_y, truncate):
    """map_pixels' (px, py) of image samples (xs, ys): non-finite ones dropped, the rest snapped."""
    px = np.empty(xs.size, np.int64)
    py = np.empty(xs.size, np.int64)
    count = 0
    limit = float(1 << 30)
    for i in range(xs.size):
        if not (np.isfinite(xs[i]) and np.isfinite(ys[i])):
            continue
        x = xs[i] / scale_x
        y = (ys[i] - offset_y) / scale_y
        x = np.trunc(x) if truncate else np.rint(x)
        y = np.trunc(y) if truncate else np.rint(y)
        px[count] = np.int64(min(max(x, -limit), limit))
        py[count] = np.int64(min(max(y, -limit), limit))
        count += 1
    return px[:count].copy(), py[:count].copy()


@cached_njit(nogil=True, error_model="numpy")
def map_spline_pixels(points, spline, scale_x, scale_y, offset_y, truncate):
    """map_pixels, its spline samples computed with t * t * t where that cannot change a pixel.

    As official_spline_pixels: a sample within _SPLINE_SLACK of its terms' size snaps to the
    same pixel as the pow spline's whenever everything that close snaps alike (_snap is
    monotone: a quotient and rint or trunc); the others, non-finite ones included, are computed
    again with pow, afterwards.
    """
    n = points.shape[0]
    if not (spline and n >= 3):  # map_pixels without a spline (not calling it: that compiles its pow spline in)
        return _snapped(points[:, 0].copy(), points[:, 1].copy(), scale_x, scale_y, offset_y, truncate)
    xs = points[:, 0].copy()
    ys = points[:, 1].copy()
    h, mx, my = _spline_moments(xs, ys)
    times = SPLINE_SAMPLES
    m = (n - 1) * times + 1
    sample_x = np.empty(m)
    sample_y = np.empty(m)
    again = np.empty(m, np.int64)  # samples to compute with pow
    n_again = 0
    k_out = 0
    for i in range(n - 1):
        ax, bx, cx, ddx = _cubic(xs, h, mx, i)
        ay, by, cy, ddy = _cubic(ys, h, my, i)
        delta = h[i] / times
        for k in range(times):
            t = delta * k
            t2 = t * t
            t3 = t2 * t
            x = ax + bx * t + cx * t2 + ddx * t3
            y = ay + by * t + cy * t2 + ddy * t3
            slack_x = (abs(ax) + abs(bx * t) + abs(cx * t2) + abs(ddx * t3) + abs(x)) * _SPLINE_SLACK
            slack_y = (abs(ay) + abs(by * t) + abs(cy * t2) + abs(ddy * t3) + abs(y)) * _SPLINE_SLACK
            if not (_snap(x - slack_x, 0.0, scale_x, truncate) == _snap(x + slack_x, 0.0, scale_x, truncate)
                    and _snap(y - slack_y, offset_y, scale_y, truncate) == _snap(y + slack_y, offset_y, scale_y,
                                                                                  truncate)):
                again[n_again] = k_out
                n_again += 1
            sample_x[k_out] = x
            sample_y[k_out] = y
            k_out += 1
    sample_x[k_out] = xs[n - 1]
    sample_y[k_out] = ys[n - 1]
    for j in range(n_again):
        k_out = again[j]
        i = k_out // times
        ax, bx, cx, ddx = _cubic(xs, h, mx, i)
        ay, by, cy, ddy = _cubic(ys, h, my, i)
        t = (h[i] / times) * (k_out - i * times)  # official_spline's delta * k
        sample_x[k_out] = ax + bx * t + cx * math.pow(t, 2.0) + ddx * math.pow(t, 3.0)
        sample_y[k_out] = ay + by * t + cy * math.pow(t, 2.0) + ddy * math.pow(t, 3.0)
    return _snapped(sample_x, sample_y, scale_x, scale_y, offset_y, truncate)


@cached_njit(nogil=True, error_model="numpy")
def map_lane(points, spline, scale_x, scale_y, offset_y, truncate, thickness, width, height, extras, extra_counts,
             crescents, crescent_counts):
    """(x0, y0, canvas, area) of a lane drawn at map resolution (map_pixels, then rasterise).
    Drawing every pixel: the reference for `map_lane_runs`."""
    px, py = map_pixels(points, spline, scale_x, scale_y, offset_y, truncate)
    return rasterise_with_area(px, py, thickness, width, height, extras, extra_counts, crescents, crescent_counts)


@cached_njit(nogil=True, error_model="numpy")
def map_lane_runs(points, spline, scale_x, scale_y, offset_y, truncate, thickness, width, height, extras,
                  extra_counts, crescents, crescent_counts, step_runs, step_counts, step_info, clip_runs, clip_counts):
    """map_lane's mask as runs per row: (x0, y0, x1, lo, hi, area) (map_spline_pixels, rasterise_runs)."""
    px, py = map_spline_pixels(points, spline, scale_x, scale_y, offset_y, truncate)
    return rasterise_runs(px, py, thickness, width, height, extras, extra_counts, crescents, crescent_counts,
                          step_runs, step_counts, step_info, clip_runs, clip_counts)


# ---- several lanes at once: what scoring a frame calls ----------------------------------------
# One call draws all of a frame's lanes (or computes all IoUs of two sets of them): a kernel call
# from Python costs microseconds in argument checks, about what drawing a short lane costs.

_SET_Y0, _SET_FIRST, _SET_ROWS, _SET_AREA, _SET_DRAWN, _SET_X0, _SET_X1 = range(7)  # columns of a set's `meta`


@cached_njit(nogil=True, error_model="numpy")
def lane_set_runs(points, starts, official, spline, scale_x, scale_y, offset_y, truncate, thickness, width, height,
                  extras, extra_counts, crescents, crescent_counts, step_runs, step_counts, step_info, clip_runs,
                  clip_counts):
    """(meta, lo, hi): the masks of lanes points[starts[i]:starts[i + 1]], as runs per row, packed.

    Each lane of 2+ points is official_lane_runs' mask (`official`) or map_lane_runs' (with
    spline .. truncate); a lane of fewer points is not drawn. meta[i] = (y0, first, rows, area,
    drawn, x0, x1): the lane's rows y0 .. y0 + rows - 1 are rows first .. first + rows - 1 of lo
    and hi, whose columns are as many as the fullest row of any lane needs (unused slots (1, 0));
    x0, x1 are the one-lane kernel's box.
    """
    n = starts.size - 1
    meta = np.zeros((n, 7), np.int64)
    none = np.empty((0, 1), np.int64)
    los = [none for _ in range(n)]
    his = [none for _ in range(n)]
    total = 0
    slots = 1
    for i in range(n):
        lane = points[starts[i]:starts[i + 1]]
        if lane.shape[0] < 2:
            continue
        if official:
            px, py = official_pixels(lane)
        else:
            px, py = map_spline_pixels(lane, spline, scale_x, scale_y, offset_y, truncate)
        x0, y0, x1, lo, hi, area = rasterise_runs(px, py, thickness, width, height, extras, extra_counts, crescents,
                                                  crescent_counts, step_runs, step_counts, step_info, clip_runs,
                                                  clip_counts)
        los[i] = lo
        his[i] = hi
        meta[i, _SET_Y0] = y0
        meta[i, _SET_FIRST] = total
        meta[i, _SET_ROWS] = lo.shape[0]
        meta[i, _SET_AREA] = area
        meta[i, _SET_DRAWN] = 1
        meta[i, _SET_X0] = x0
        meta[i, _SET_X1] = x1
        total += lo.shape[0]
        slots = max(slots, lo.shape[1])
    lo_all = np.full((total, slots), _EMPTY_LO, np.int64)
    hi_all = np.full((total, slots), _EMPTY_HI, np.int64)
    for i in range(n):
        first = meta[i, _SET_FIRST]
        lo = los[i]
        hi = his[i]
        for r in range(lo.shape[0]):
            for k in range(lo.shape[1]):
                lo_all[first + r, k] = lo[r, k]
                hi_all[first + r, k] = hi[r, k]
    return meta, lo_all, hi_all


@cached_njit(nogil=True)
def lane_set_ious(a_meta, a_lo, a_hi, b_meta, b_lo, b_hi):
    """(len(a), len(b)) IoUs of two lane_set_runs sets: 0 where either lane is not drawn, NaN
    where both masks are empty (0/0), else intersection / union (as iou.iou_matrix)."""
    out = np.zeros((a_meta.shape[0], b_meta.shape[0]))
    single = a_lo.shape[1] == 1 and b_lo.shape[1] == 1
    for i in range(a_meta.shape[0]):
        if a_meta[i, _SET_DRAWN] == 0:
            continue
        ay0 = a_meta[i, _SET_Y0]
        a_first = a_meta[i, _SET_FIRST]
        a_area = a_meta[i, _SET_AREA]
        for j in range(b_meta.shape[0]):
            if b_meta[j, _SET_DRAWN] == 0:
                continue
            by0 = b_meta[j, _SET_Y0]
            b_first = b_meta[j, _SET_FIRST]
            b_area = b_meta[j, _SET_AREA]
            inter = np.int64(0)
            if a_area != 0 and b_area != 0:
                top = max(ay0, by0)
                bottom = min(ay0 + a_meta[i, _SET_ROWS], by0 + b_meta[j, _SET_ROWS])
                for y in range(top, bottom):
                    ra = a_first + y - ay0
                    rb = b_first + y - by0
                    if single:
                        count = min(a_hi[ra, 0], b_hi[rb, 0]) - max(a_lo[ra, 0], b_lo[rb, 0]) + 1
                        inter += max(count, 0)
                        continue
                    for p in range(a_lo.shape[1]):
                        for q in range(b_lo.shape[1]):
                            count = min(a_hi[ra, p], b_hi[rb, q]) - max(a_lo[ra, p], b_lo[rb, q]) + 1
                            inter += max(count, 0)
            union = a_area + b_area - inter
            out[i, j] = inter / union if union != 0 else np.nan
    return out


# ---- the official matching -----------------------------------------------------------------


@cached_njit(nogil=True)
def _augment(u, matrix, left_weight, right_weight, left_used, right_used, left_match, right_match, tolerance):
    """iou.match_lanes' augment(u): a depth-first search for an augmenting path on tight edges."""
    left_used[u] = True
    for v in range(matrix.shape[1]):
        if not right_used[v] and abs(left_weight[u] + right_weight[v] - matrix[u, v]) < tolerance:
            right_used[v] = True
            if right_match[v] == -1 or _augment(right_match[v], matrix, left_weight, right_weight, left_used,
                                                right_used, left_match, right_match, tolerance):
                right_match[v] = u
                left_match[u] = v
                return True
    return False


@cached_njit(nogil=True)
def matched_ious(similarity, rows, columns, tolerance):
    """Each row's matched IoU (-inf where unmatched) under the official Kuhn-Munkres matching of
    similarity[rows][:, columns] (ground truth x predictions): iou.match_lanes step for step."""
    n_rows = rows.size
    n_columns = columns.size
    out = np.full(n_rows, -np.inf)
    if n_rows == 0 or n_columns == 0:
        return out
    swapped = n_rows > n_columns
    n_left = n_columns if swapped else n_rows
    n_right = n_rows if swapped else n_columns
    matrix = np.empty((n_left, n_right))
    for i in range(n_rows):
        for j in range(n_columns):
            if swapped:
                matrix[j, i] = similarity[rows[i], columns[j]]
            else:
                matrix[i, j] = similarity[rows[i], columns[j]]
    left_match = np.full(n_left, -1, np.int64)
    right_match = np.full(n_right, -1, np.int64)
    right_weight = np.zeros(n_right)
    left_weight = np.empty(n_left)
    for i in range(n_left):
        best = -1e5
        for j in range(n_right):
            if best < matrix[i, j]:
                best = matrix[i, j]
        left_weight[i] = best
    left_used = np.zeros(n_left, np.bool_)
    right_used = np.zeros(n_right, np.bool_)
    finished = True
    for u in range(n_left):
        while True:
            left_used[:] = False
            right_used[:] = False
            if _augment(u, matrix, left_weight, right_weight, left_used, right_used, left_match, right_match,
                        tolerance):
                break
            d = 1e10
            for i in range(n_left):
                if left_used[i]:
                    for j in range(n_right):
                        if not right_used[j]:
                            slack = left_weight[i] + right_weight[j] - matrix[i, j]
                            if slack < d:
                                d = slack
            if d == 1e10:
                finished = False
                break
            for i in range(n_left):
                if left_used[i]:
                    left_weight[i] -= d
            for j in range(n_right):
                if right_used[j]:
                    right_weight[j] += d
        if not finished:
            break
    match = right_match if swapped else left_match
    for i in range(n_rows):
        if match[i] >= 0:
            out[i] = similarity[rows[i], columns[match[i]]]
    return out


# ---- the argument types raster.py calls the kernels above with ------------------------------
# Compiled ahead of a run by roneld_eval.kernels (numba compiles one specialisation per tuple
# of argument types); raster.py passes exactly these (lane points read-only, as Lane holds them).
_POINTS = types.Array(types.float64, 2, "C", readonly=True)
_TABLE = types.Array(types.int64, 3, "C")
_COUNTS = types.Array(types.int64, 1, "C")
_MASK = types.Array(types.uint8, 2, "C")
_RUNS = types.Array(types.int64, 2, "C")  # LaneMask.lo, .hi
_I, _F, _B = types.int64, types.float64, types.boolean
_TABLES = (_TABLE, _COUNTS, _TABLE, _COUNTS)  # short_quad_extras(thickness)
# step_extras(thickness, STEP_REACH) and clip_extras(thickness) (raster._step_extras)
_STEPS = (_TABLE, _COUNTS, types.Array(types.int64, 2, "C"), types.Array(types.int64, 5, "C"), _TABLE)
# raster.official_mask_set and map_mask_set (the lanes' points end to end, and where each starts)
_LANE_SET = (types.Array(types.float64, 2, "C"), _COUNTS, _B, _B, _F, _F, _F, _B, _I, _I, _I) + _TABLES + _STEPS
_SET_IOUS = (_RUNS, _RUNS, _RUNS, _RUNS, _RUNS, _RUNS)  # LaneRuns.ious: (meta, lo, hi) of each set

ENTRY_SIGNATURES: dict[str, list[tuple[Any, tuple]]] = {
    # raster's tables (_quad_extras, _step_extras) and LaneMask.intersection: every protocol needs them
    "tables": [(short_quad_extras, (_I,)), (step_extras, (_I, _I)), (clip_extras, (_I,)),
               (overlap, (_I, _I, _MASK, _I, _I, _MASK)), (run_overlap, (_I, _RUNS, _RUNS, _I, _RUNS, _RUNS))],
    # culane_official.official_masks (raster.official_mask_set) and LaneRuns.ious
    "official": [(lane_set_runs, _LANE_SET), (lane_set_ious, _SET_IOUS),
                 (matched_ious, (types.Array(types.float64, 2, "C"), _COUNTS, _COUNTS, _F))],
    # paper.ego_masks and side_ious (raster.map_mask_set): the same kernels
    "paper": [(lane_set_runs, _LANE_SET), (lane_set_ious, _SET_IOUS)],
}
# The pixel-by-pixel references the runs are tested and benchmarked against (metrics.reference),
# and one lane at a time (raster.official_mask, map_mask: tests and benchmarks): compiled only
# where they are used, so that a first run of the tool does not pay for them.
REFERENCE_SIGNATURES: list[tuple[Any, tuple]] = [
    (official_lane, (_POINTS, _I, _I, _I) + _TABLES),
    (map_lane, (_POINTS, _B, _F, _F, _F, _B, _I, _I, _I) + _TABLES),
]
