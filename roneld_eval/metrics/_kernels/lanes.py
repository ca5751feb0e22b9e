"""Lanes as the official tool and the maps give them, and several lanes of a frame at once: what scoring calls."""

from __future__ import annotations

import math

import numpy as np

from ..._numba_cache import cached_njit
from .canvas import rasterise_with_area
from .cxx import SPLINE_SAMPLES
from .runs import EMPTY_HI, EMPTY_LO, polyline_runs, rasterise_runs
from .spline import _SPLINE_SLACK, _cubic, _round_float32, _spline_moments, official_spline, official_spline_pixels


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
                  step_runs, step_counts, step_info, clip_runs, clip_counts):
    """(meta, lo, hi, by_canvas): the masks of lanes points[starts[i]:starts[i + 1]], as runs per
    row, packed; by_canvas[i] for a lane that only the canvas draws (polyline_runs: far points, or
    a row of many runs), left out here for the caller to draw and pack in (raster.LaneRuns.packed).

    Each other lane of 2+ points is official_lane_runs' mask (`official`) or map_lane_runs' (with
    spline .. truncate); a lane of fewer points is not drawn. meta[i] = (y0, first, rows, area,
    drawn, x0, x1): the lane's rows y0 .. y0 + rows - 1 are rows first .. first + rows - 1 of lo
    and hi, whose columns are as many as the fullest row of any lane needs (unused slots (1, 0));
    x0, x1 are the one-lane kernel's box. The canvas, rare in real lanes, is not compiled into
    this kernel: a first run compiles it only where a lane needs it.
    """
    n = starts.size - 1
    meta = np.zeros((n, 7), np.int64)
    by_canvas = np.zeros(n, np.bool_)
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
        ok, x0, y0, x1, lo, hi, area = polyline_runs(px, py, thickness, width, height, step_runs, step_counts,
                                                     step_info, clip_runs, clip_counts)
        if not ok:
            by_canvas[i] = True
            continue
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
    lo_all = np.full((total, slots), EMPTY_LO, np.int64)
    hi_all = np.full((total, slots), EMPTY_HI, np.int64)
    for i in range(n):
        first = meta[i, _SET_FIRST]
        lo = los[i]
        hi = his[i]
        for r in range(lo.shape[0]):
            for k in range(lo.shape[1]):
                lo_all[first + r, k] = lo[r, k]
                hi_all[first + r, k] = hi[r, k]
    return meta, lo_all, hi_all, by_canvas


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
