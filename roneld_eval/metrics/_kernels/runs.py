"""The same pixels as canvas.py, kept as per-row runs (lo, hi) without a canvas."""

from __future__ import annotations

import numpy as np

from ..._numba_cache import cached_njit
from .canvas import (_low_high, disc_half_widths, line2_pixels, line_buffers, polyline_box, quad_corners,
                     quad_scanlines, rasterise_with_area)
from .cxx import HALF, XY_SHIFT
from .run_tables import STEP_REACH, _clipped_edge, _quad_unclipped


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
EMPTY_LO = 1  # an unused run slot in a finished mask is (1, 0): it overlaps nothing
EMPTY_HI = 0


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
def _add_quad(lo, hi, counts, x0, y0, x1, y1, width, height, ax, ay, bx, by, thickness):
    """_segment_quad for runs: the filled quad ThickLine draws between two integer points, its
    scanlines and its outline (canvas.py's walks, each pixel or span added as a run)."""
    drawn, qx, qy = quad_corners(ax, ay, bx, by, thickness)
    if not drawn:
        return True
    first_buffer, second_buffer = line_buffers(width, height)
    top = max(y0, 0)
    bottom = min(y1, height)
    leftmost = max(x0, 0)
    rightmost = min(x1, width) - 1
    first, count = quad_scanlines(qx, qy, width, height, first_buffer, second_buffer)
    for k in range(count):
        y = first + k
        left = max(first_buffer[k], leftmost)
        right = min(second_buffer[k], rightmost)
        # kept to the image and the box as _span keeps it; the usual case of _merge_run inline
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
    px = qx[3]
    py = qy[3]
    for i in range(4):
        for k in range(line2_pixels(px, py, qx[i], qy[i], width, height, first_buffer, second_buffer)):
            x = first_buffer[k]
            y = second_buffer[k]
            if 0 <= x < width and 0 <= y < height and x0 <= x < x1 and y0 <= y < y1:
                row = y - y0
                if counts[row] == 1 and lo[row, 0] - 1 <= x <= hi[row, 0] + 1:
                    lo[row, 0] = min(lo[row, 0], x)
                    hi[row, 0] = max(hi[row, 0], x)
                elif not _merge_run(lo, hi, counts, row, x, x):
                    return False
        px = qx[i]
        py = qy[i]
    return True


_NO_PIXEL = np.int64(1 << 40)  # chain_lo of a row no disc has reached; chain_hi is -_NO_PIXEL


@cached_njit(nogil=True)
def _add_chain(lo, hi, counts, x0, y0, x1, y1, width, height, chain_lo, chain_hi, pad, first_row, last_row):
    """Add a chain's rows (chain_lo/chain_hi, index = image row - y0 + pad) as _add_quad adds
    its scanlines, and empty them again."""
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
    far points or a row of more than _RUN_SLOTS runs, which only the canvas draws (rasterise_runs).
    Fewer than 2 points or an empty box draw nothing, as rasterise() draws them: x0 = y0 = x1 = 0, no rows.
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
        return True, 0, 0, 0, none, none, 0
    clip_reach = (clip_runs.shape[2] - 1) // 2
    x_low, x_high = _low_high(xs)
    y_low, y_high = _low_high(ys)
    if (x_low < -(1 << 20)) or (y_low < -(1 << 20)) or (x_high > (1 << 20)) or (y_high > (1 << 20)):
        return False, 0, 0, 0, none, none, 0
    x0, y0, x1, y1 = polyline_box(xs, ys, thickness, width, height)
    if x1 <= x0 or y1 <= y0:
        return True, 0, 0, 0, none, none, 0
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
    first = np.full((counts.size, most), EMPTY_LO, np.int64)
    last = np.full((counts.size, most), EMPTY_HI, np.int64)
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
    lo = np.full((rows, most), EMPTY_LO, np.int64)
    hi = np.full((rows, most), EMPTY_HI, np.int64)
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
