"""The official CULane evaluator's cubic spline (SCNN lane_evaluation, spline.cpp), sampled as it samples it."""

from __future__ import annotations

import math

import numpy as np

from ..._numba_cache import cached_njit
from .cxx import INT_MIN


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
