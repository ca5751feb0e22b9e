"""Numba kernels of the extractors: plain arrays and scalars in and out, no objects.

Each kernel has an obvious pure-Python counterpart in tests/test_kernels.py, and its
`.py_func` runs the same code uncompiled. Map values are uint8 (0..255).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from numba import types

from .._numba_cache import cached_njit

# The r^2 comparison of the curve test treats differences below this as ties (straight):
# for exactly collinear points both sides are 1 up to rounding noise.
R2_TIE = 1e-12


@cached_njit(nogil=True)
def window_max(channel, row, left, right):
    """Largest value of channel[row, left:right] (0 when empty) of a uint8 map.

    Written as a branch-free uint8 reduction over unsigned indices (numba then skips its
    negative-index check) so that LLVM vectorises it: about 28x faster than a plain loop.
    """
    best = np.uint8(0)
    line = channel[row]
    for column in range(np.uint64(left), np.uint64(right)):
        value = line[column]
        best = value if value > best else best
    return best


@cached_njit(nogil=True)
def row_maxima(maps):
    """(C, H) maximum of every row of every channel: one pass over the maps."""
    channels, _, width = maps.shape
    planes = np.arange(channels)
    return channel_row_maxima(maps, planes, np.zeros(channels, np.int64), np.full(channels, width, np.int64))


@cached_njit(nogil=True)
def channel_row_maxima(maps, planes, lows, highs):
    """(C, H) maximum of every row of every channel, channel c being maps[planes[c]] with its
    columns outside [lows[c], highs[c]) read as 0 (see frame_lanes)."""
    channels = planes.size
    height = maps.shape[1]
    out = np.empty((channels, height), np.uint8)
    for channel in range(channels):
        plane = maps[planes[channel]]
        low = lows[channel]
        high = highs[channel]
        for row in range(height):
            out[channel, row] = window_max(plane, row, low, high)
    return out


@cached_njit(nogil=True)
def frame_threshold(row_max):
    """RONELD's adaptive confidence threshold: floor(max over all maps / 3), at least 1."""
    best = 0
    for channel in range(row_max.shape[0]):
        for row in range(row_max.shape[1]):
            best = max(best, int(row_max[channel, row]))
    return max(best // 3, 1)


@cached_njit(nogil=True)
def extract_points(channel, row_max, threshold, stride, low, high):
    """Adaptive lane point extraction of one (H, W) uint8 map (row_max: its row maxima), its
    columns outside [low, high) read as 0 (0 and W: the whole map).

    Scans rows from the top; in the first row whose window holds a value >= threshold, the
    highest value of rows [row, row + stride) in the window (first in row-major order on ties)
    is a lane point. The window then becomes that x +/- W/4, and the scan resumes stride + 1
    rows further down. Returns (xs, ys, confidences) in scan order, top first.
    The columns read as 0 are left out of every window rather than read: a point's value is at
    least the threshold (>= 1), so neither the maxima nor the first column holding one change.
    """
    height, width = channel.shape
    quarter = width * 0.25
    xs = np.empty(height, np.int64)
    ys = np.empty(height, np.int64)
    confidences = np.empty(height, np.float64)
    count = 0
    left: int | np.int64 = low
    right: int | np.int64 = high
    row = np.int64(0)
    while row < height:
        # The whole-row maximum rules most rows out without touching the map again.
        if row_max[row] >= threshold and (
            (left == low and right == high) or window_max(channel, row, left, right) >= threshold
        ):
            end = min(row + stride, height)
            best = 0
            best_row: int | np.int64 = row
            for r in range(row, end):
                value = window_max(channel, r, left, right)
                if value > best:
                    best = value
                    best_row = r
            line = channel[best_row]
            best_x: int | np.int64 = left
            for column in range(left, right):
                if line[column] == best:
                    best_x = column
                    break
            xs[count] = best_x
            ys[count] = best_row
            confidences[count] = best
            count += 1
            below = best_x - quarter
            above = best_x + quarter
            left = max(int(below) if below >= 0 else 0, low)
            right = min(int(above) if above <= width else width, high)
            row += stride
        row += 1
    return xs[:count].copy(), ys[:count].copy(), confidences[:count].copy()


@cached_njit(nogil=True)
def r_squared(xs, ys):
    """Coefficient of determination of a linear fit: Cov(x,y)^2 / (Var x Var y), population moments.

    1 when either variance is 0; -1 for one point or none.
    """
    n = xs.size
    if n <= 1:
        return -1.0
    mean_x = 0.0
    mean_y = 0.0
    for i in range(n):
        mean_x += xs[i]
        mean_y += ys[i]
    mean_x /= n
    mean_y /= n
    sxx = 0.0
    syy = 0.0
    sxy = 0.0
    for i in range(n):
        dx = xs[i] - mean_x
        dy = ys[i] - mean_y
        sxx += dx * dx
        syy += dy * dy
        sxy += dx * dy
    if sxx == 0.0 or syy == 0.0:
        return 1.0
    return (sxy * sxy) / (sxx * syy)


@cached_njit(nogil=True)
def is_curve(xs, ys, min_curve_points, top_points):
    """RONELD's curve test: enough points, and r^2 rises when the top points are removed."""
    if xs.size < min_curve_points:
        return False
    return r_squared(xs, ys) < r_squared(xs[top_points:], ys[top_points:]) - R2_TIE


@cached_njit(nogil=True)
def weighted_line_fit(xs, ys, weights):
    """Weighted least squares y = intercept + slope * x -> (slope, intercept).

    Equal x everywhere would make the fit singular: like the reference (which adds random
    jitter below 0.01), x is nudged by a deterministic amount below 0.01 first. A slope of
    exactly 0 becomes 0.001 so that x(y) stays defined.
    """
    n = xs.size
    fx = np.empty(n, np.float64)
    all_equal = True
    for i in range(n):
        fx[i] = xs[i]
        if xs[i] != xs[0]:
            all_equal = False
    if all_equal:
        for i in range(n):
            fx[i] += 0.01 * (i + 1) / (n + 1)
    total = 0.0
    mean_x = 0.0
    mean_y = 0.0
    for i in range(n):
        total += weights[i]
        mean_x += weights[i] * fx[i]
        mean_y += weights[i] * ys[i]
    mean_x /= total
    mean_y /= total
    sxx = 0.0
    sxy = 0.0
    for i in range(n):
        dx = fx[i] - mean_x
        sxx += weights[i] * dx * dx
        sxy += weights[i] * dx * (ys[i] - mean_y)
    slope = sxy / sxx
    intercept = mean_y - slope * mean_x
    if slope == 0.0:
        slope = 0.001
    return slope, intercept


@cached_njit(nogil=True)
def stable_argsort(keys):
    """np.argsort(keys, kind="mergesort") of a float64 array: ascending, NaN last, ties in order.

    An insertion sort: a lane has a few dozen points and a frame a few lanes, and numba's
    mergesort takes seconds to compile. A stable sort's permutation is unique, so both agree.
    """
    n = keys.size
    order = np.empty(n, np.int64)
    for i in range(n):
        key = keys[i]
        j = i
        # Move i before every earlier key that sorts strictly after it (NaN after any number).
        while j > 0 and _before(key, keys[order[j - 1]]):
            order[j] = order[j - 1]
            j -= 1
        order[j] = i
    return order


@cached_njit(nogil=True)
def _before(a, b):
    """a sorts strictly before b: numpy's order for floats, NaN after every number."""
    if math.isnan(a):
        return False
    if math.isnan(b):
        return True
    return a < b


@cached_njit(nogil=True)
def remove_outliers(xs, ys, weights, fraction, min_points):
    """One pass: fit, then drop the floor(fraction*m)+1 points farthest (horizontally) from the line.

    Nothing is dropped from m <= min_points points. Returns a boolean mask of the kept points.
    Ties in distance drop the later points (stable sort, as the reference).
    """
    n = xs.size
    keep = np.ones(n, np.bool_)
    if n <= min_points:
        return keep
    drop = int(n * fraction) + 1
    slope, intercept = weighted_line_fit(xs, ys, weights)
    distances = np.empty(n, np.float64)
    for i in range(n):
        distances[i] = abs(xs[i] - (ys[i] - intercept) / slope)
    order = stable_argsort(distances)
    for k in range(n - drop, n):
        keep[order[k]] = False
    return keep


@cached_njit(nogil=True)
def root_mean_square(values):
    """sqrt(mean(v^2)) in floating point (the reference squared uint8 and overflowed)."""
    total = 0.0
    for i in range(values.size):
        total += float(values[i]) * float(values[i])
    return math.sqrt(total / values.size)


@cached_njit(nogil=True)
def line_distance(slope_a, intercept_a, slope_b, intercept_b, height):
    """RMS over y in [0, height] of x_a(y) - x_b(y) for lines y = intercept + slope * x.

    x_a - x_b = D*y - E with D = 1/slope_a - 1/slope_b, E = intercept_a/slope_a - intercept_b/slope_b,
    and the mean of its square over [0, H] is D^2 H^2 / 3 - D E H + E^2 (the paper's zeta in
    closed form, without the reference's division by D).
    """
    d = 1.0 / slope_a - 1.0 / slope_b
    e = intercept_a / slope_a - intercept_b / slope_b
    mean_square = d * d * height * height / 3.0 - d * e * height + e * e
    return math.sqrt(max(mean_square, 0.0))


@cached_njit(nogil=True)
def channel_lane(channel, row_max, threshold, stride, low, high, min_points, min_curve_points, top_points,
                 outlier_fraction):
    """Points, curve flag and line of one channel (its columns [low, high): extract_points), as
    RONELD builds a lane from a map.

    Returns (xs, ys, confidences, curve, slope, intercept, rms_confidence); xs is empty when the
    channel yields no lane (min_points points or fewer). Straight lanes lose their outliers.
    """
    xs, ys, confidences = extract_points(channel, row_max, threshold, stride, low, high)
    if xs.size <= min_points:
        empty = np.empty(0, np.int64)
        return empty, empty, np.empty(0, np.float64), False, 0.0, 0.0, 0.0
    curve = is_curve(xs, ys, min_curve_points, top_points)
    if not curve:
        keep = remove_outliers(xs, ys, confidences, outlier_fraction, min_points)
        # xs[keep] etc. as loops: boolean indexing compiles numba's error-message machinery.
        kept = 0
        for i in range(keep.size):
            if keep[i]:
                xs[kept] = xs[i]
                ys[kept] = ys[i]
                confidences[kept] = confidences[i]
                kept += 1
        xs = xs[:kept]
        ys = ys[:kept]
        confidences = confidences[:kept]
    slope, intercept = weighted_line_fit(xs, ys, confidences)
    return xs, ys, confidences, curve, slope, intercept, root_mean_square(confidences)


# Columns of the per-lane field matrix the tracking kernels share.
F_SLOPE, F_INTERCEPT, F_WEIGHT, F_RMS, F_CURVE, F_CHANNEL, F_TOP_X, F_BOTTOM_X, F_TOP_Y, F_POINTS = range(10)
N_FIELDS = 10


@cached_njit(nogil=True)
def frame_lanes(maps, planes, lows, highs, rows_per_point, min_points, min_curve_points, top_points,
                outlier_fraction):
    """channel_lane for every channel of a frame, packed into flat arrays.

    Channel c is maps[planes[c]] with its columns outside [lows[c], highs[c]) read as 0: the
    identity (planes 0..C-1, columns 0..W) reads a (C, H, W) frame as it is; EgoLanes' three
    masks are read as SCNN's four channels this way without building them (online.py).
    Returns (counts, xs, ys, fields): counts[c] points of channel c follow those of channel
    c - 1 in xs/ys; fields is an (L, N_FIELDS) matrix, one row per lane found (weight 0).
    """
    channels = planes.size
    height = maps.shape[1]
    row_max = channel_row_maxima(maps, planes, lows, highs)
    threshold = frame_threshold(row_max)
    stride = height // rows_per_point
    counts = np.zeros(channels, np.int64)
    xs_all = np.empty(channels * height, np.int64)
    ys_all = np.empty(channels * height, np.int64)
    fields = np.zeros((channels, N_FIELDS), np.float64)
    offset = 0
    lanes = 0
    for channel in range(channels):
        xs, ys, confidences, curve, slope, intercept, rms_confidence = channel_lane(
            maps[planes[channel]], row_max[channel], threshold, stride, lows[channel], highs[channel],
            min_points, min_curve_points, top_points, outlier_fraction,
        )
        n = xs.size
        counts[channel] = n
        if n == 0:
            continue
        for i in range(n):  # a loop: slice assignment compiles a shape check with string formatting
            xs_all[offset + i] = xs[i]
            ys_all[offset + i] = ys[i]
        offset += n
        row = fields[lanes]
        row[F_SLOPE] = slope
        row[F_INTERCEPT] = intercept
        row[F_RMS] = rms_confidence
        row[F_CURVE] = 1.0 if curve else 0.0
        row[F_CHANNEL] = channel
        row[F_TOP_X] = xs[0]
        row[F_BOTTOM_X] = xs[n - 1]
        row[F_TOP_Y] = ys[0]
        row[F_POINTS] = n
        lanes += 1
    return counts, xs_all[:offset], ys_all[:offset], fields[:lanes].copy()


@cached_njit(nogil=True)
def track_lanes(previous, current, gains, height, merge_distance, decay, min_weight):
    """Preceding-frame tracking over field matrices (see roneld.py for the rule in words).

    previous: (P, N_FIELDS) tracked lanes with weights; current: (N, N_FIELDS) lanes of this
    frame; gains: (N,) psi * points * rms confidence. Returns (tracked, sources): the new
    tracked matrix sorted by weight (stable, heaviest first) and, per row, its source as an
    index into current (0..N-1) or previous (N + j).
    """
    n_current = current.shape[0]
    n_previous = previous.shape[0]
    closest = np.empty(n_current, np.int64)
    for i in range(n_current):
        closest[i] = -1
        best = np.inf
        for j in range(n_previous):
            distance = line_distance(
                current[i, F_SLOPE], current[i, F_INTERCEPT], previous[j, F_SLOPE], previous[j, F_INTERCEPT], height
            )
            if distance < merge_distance and distance < best:
                best = distance
                closest[i] = j
    sources = np.empty(n_current + n_previous, np.int64)
    weights = np.empty(n_current + n_previous, np.float64)
    matched = np.zeros(n_previous, np.bool_)
    k = 0
    for j in range(n_previous):
        for i in range(n_current):
            if closest[i] == j:
                sources[k] = i
                weights[k] = previous[j, F_WEIGHT] + gains[i]
                matched[j] = True
                k += 1
    for i in range(n_current):
        if closest[i] < 0:
            sources[k] = i
            weights[k] = gains[i]
            k += 1
    for j in range(n_previous):
        if not matched[j] and previous[j, F_WEIGHT] >= min_weight:
            sources[k] = n_current + j
            weights[k] = previous[j, F_WEIGHT] / decay
            k += 1
    keys = np.empty(k, np.float64)
    for row in range(k):
        keys[row] = -weights[row]
    order = stable_argsort(keys)
    tracked = np.empty((k, N_FIELDS), np.float64)
    ordered_sources = np.empty(k, np.int64)
    for row in range(k):
        source = sources[order[row]]
        ordered_sources[row] = source
        for column in range(N_FIELDS):
            if source < n_current:
                tracked[row, column] = current[source, column]
            else:
                tracked[row, column] = previous[source - n_current, column]
        tracked[row, F_WEIGHT] = weights[order[row]]
    return tracked, ordered_sources


@cached_njit(nogil=True)
def choose_active(tracked, height, center, curve_mode):
    """(left, right) row indices of the active lanes (-1 = none).

    Each is the first (heaviest) lane whose line meets row height-1 left (right) of the centre
    and whose top point lies right (left) of or at its bottom point, any lean in curve mode.
    """
    left = -1
    right = -1
    for row in range(tracked.shape[0]):
        x_bottom = (height - 1 - tracked[row, F_INTERCEPT]) / tracked[row, F_SLOPE]
        top_x = tracked[row, F_TOP_X]
        bottom_x = tracked[row, F_BOTTOM_X]
        if left < 0 and x_bottom < center and (top_x >= bottom_x or curve_mode):
            left = row
        if right < 0 and x_bottom > center and (top_x <= bottom_x or curve_mode):
            right = row
        if left >= 0 and right >= 0:
            break
    return left, right


@cached_njit(nogil=True)
def row_argmax(maps, rows):
    """(columns, values): first maximum of each channel's map row `rows[k]` (as MATLAB's max)."""
    channels, _, width = maps.shape
    columns = np.zeros((channels, rows.size), np.int64)
    values = np.zeros((channels, rows.size), np.uint8)
    start = np.int64(0)
    for channel in range(channels):
        plane = maps[channel]
        for k in range(rows.size):
            best = window_max(plane, rows[k], start, width)
            line = plane[rows[k]]
            for column in range(width):
                if line[column] == best:
                    columns[channel, k] = column
                    break
            values[channel, k] = best
    return columns, values


# ---- the argument types the extractors call the kernels above with --------------------------
# numba compiles one specialisation per tuple of argument types, where it is first called.
# roneld_eval.kernels compiles these ahead of a run, so that no call inside a timed region
# compiles. Maps come writable (PNG, float maps) or read-only (memory-mapped uint8 .npy), which
# numba would compile apart (4 s more of a first run): the extractors pass them read-only.
_MAPS = types.Array(types.uint8, 3, "C", readonly=True)
_FIELDS = types.Array(types.float64, 2, "C")
_VALUES = types.Array(types.float64, 1, "C")
_ROWS = types.Array(types.int64, 1, "C")
_PLANES = types.Array(types.int64, 1, "C", readonly=True)  # online.ChannelPlanes' frozen arrays
_I, _F = types.int64, types.float64

ENTRY_SIGNATURES: dict[str, list[tuple[Any, tuple]]] = {
    # roneld.current_lanes, roneld_step
    "roneld": [
        (frame_lanes, (_MAPS, _PLANES, _PLANES, _PLANES, _I, _I, _I, _I, _F)),
        (track_lanes, (_FIELDS, _FIELDS, _VALUES, _F, _F, _F, _F)),
        (choose_active, (_FIELDS, _F, _F, types.boolean)),
    ],
    # baseline.baseline_lanes
    "baseline": [(row_argmax, (_MAPS, _ROWS))],
}
