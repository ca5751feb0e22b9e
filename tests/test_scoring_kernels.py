"""Scoring a frame in a few kernel calls: lane sets and their IoUs, the official matching, the
tables of quads an image edge clips, and the paper's spline with t * t * t.

Each is checked against a slow, obvious version (the one-lane masks, full-image numpy masks,
iou.match_lanes, quads drawn on a canvas, the pow spline) and against its own .py_func.
"""

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from test_runs import assert_same_mask, obvious_runs, pixels_of, runs_of, wild_lanes

from roneld_eval.geometry import MapGeometry
from roneld_eval.metrics import _kernels as K
from roneld_eval.metrics.iou import KM_TOLERANCE, match_lanes
from roneld_eval.metrics.paper import ego_lanes
from roneld_eval.metrics.raster import (
    LaneRuns,
    MaskList,
    _quad_extras,
    _step_extras,
    map_mask,
    map_mask_set,
    map_mask_set_by_canvas,
    official_mask,
    official_mask_by_canvas,
    official_mask_set,
    official_mask_set_by_canvas,
)
from roneld_eval.model import Lane

SETTINGS = settings(max_examples=100, deadline=None, derandomize=True, suppress_health_check=[HealthCheck.too_slow])
GEOMETRY = MapGeometry(1640, 590, 800, 288)


def maybe_lanes(min_size=0, max_size=5, none=False):
    """Lists of wild lanes, some of one point, and (with `none`) some None."""
    one_point = st.builds(lambda x, y: Lane.from_xy([x], [y]), st.floats(0, 1640), st.floats(0, 590))
    choices = [wild_lanes(), one_point] + ([st.none()] if none else [])
    return st.lists(st.one_of(*choices), min_size=min_size, max_size=max_size)


def full_mask(mask, width, height):
    return np.zeros((height, width), np.uint8) if mask is None else mask.full(width, height)


def obvious_ious(a_masks, b_masks, width, height) -> np.ndarray:
    """IoUs of full-image masks pixel by pixel: 0 where a lane is not drawn, NaN for 0/0."""
    out = np.zeros((len(a_masks), len(b_masks)))
    for i, a in enumerate(a_masks):
        for j, b in enumerate(b_masks):
            if a is None or b is None:
                continue
            first, second = full_mask(a, width, height), full_mask(b, width, height)
            inter, union = int((first & second).sum()), int((first | second).sum())
            out[i, j] = inter / union if union else np.nan
    return out


# ---- lane sets ------------------------------------------------------------------------------------


@SETTINGS
@given(maybe_lanes(), st.sampled_from([30, 16, 3]))
def test_an_official_set_is_its_lanes_masks(lanes, thickness):
    drawn = official_mask_set(lanes, 1640, 590, thickness)
    assert isinstance(drawn, LaneRuns) and len(drawn) == len(lanes)
    for i, lane in enumerate(lanes):
        one = official_mask(lane, 1640, 590, thickness)
        assert drawn.drawn(i) == (one is not None)
        assert_same_mask(drawn.mask(i), one)
        if one is not None:
            assert (drawn.mask(i).x1, drawn.mask(i).area) == (one.x1, one.area)


@SETTINGS
@given(maybe_lanes(none=True), st.sampled_from([16, 30, 1]), st.booleans(), st.sampled_from(["nearest", "truncate"]))
def test_a_map_set_is_its_lanes_masks(lanes, thickness, spline, rounding):
    drawn = map_mask_set(lanes, GEOMETRY, thickness, spline, rounding)
    for i, lane in enumerate(lanes):
        if lane is None or len(lane) < 2:
            assert not drawn.drawn(i) and drawn.mask(i) is None
            continue
        assert_same_mask(drawn.mask(i), map_mask(lane, GEOMETRY, thickness, spline, rounding))
        assert_same_mask(drawn.mask(i), map_mask_by_canvas_of(lane, thickness, spline, rounding))


def map_mask_by_canvas_of(lane, thickness, spline, rounding):
    return map_mask_set_by_canvas([lane], GEOMETRY, thickness, spline, rounding).mask(0)


@SETTINGS
@given(maybe_lanes(max_size=4), maybe_lanes(max_size=4))
def test_set_ious_are_those_of_full_masks(a, b):
    runs = official_mask_set(a, 1640, 590, 30), official_mask_set(b, 1640, 590, 30)
    canvas = official_mask_set_by_canvas(a, 1640, 590, 30), official_mask_set_by_canvas(b, 1640, 590, 30)
    assert isinstance(canvas[0], MaskList)
    expected = obvious_ious(canvas[0].masks, canvas[1].masks, 1640, 590)
    for got in (runs[0].ious(runs[1]), canvas[0].ious(canvas[1]), runs[0].ious(canvas[1]), canvas[0].ious(runs[1]),
                K.lane_set_ious.py_func(runs[0].meta, runs[0].lo, runs[0].hi, runs[1].meta, runs[1].lo, runs[1].hi)):
        np.testing.assert_array_equal(got, expected)


def test_set_ious_by_hand():
    vertical = Lane.from_xy([800, 800], [589, 300])
    drawn = official_mask_set([vertical, Lane.from_xy([5], [5]), Lane.from_xy([-900, -800], [100, 200])],
                              1640, 590, 30)
    ious = drawn.ious(drawn)
    assert ious[0, 0] == 1.0 and ious[1, 1] == 0.0  # a lane of one point is not drawn: IoU 0
    assert np.isnan(ious[2, 2]) and ious[0, 2] == 0.0  # drawn outside the image: empty, 0/0 with itself
    assert drawn.meta[2, 3] == 0 and drawn.drawn(2) and not drawn.drawn(1)


# Lanes that polyline_runs leaves to the canvas: a point far outside the image, and a comb whose
# rows each cross more runs than a row holds.
FAR = Lane.from_xy([800, 3e7], [589, 300])
COMB = Lane.from_xy([100 + 60 * k for k in range(20)], [100, 200] * 10)


def test_lane_set_runs_py_func():
    lanes = [Lane.from_xy([700, 760, 800, 815], [589, 450, 330, 260]), Lane.from_xy([0, 5], [0, 0]),
             Lane.from_xy([100, 1700], [600, 100]), FAR, COMB]
    points = np.concatenate([lane.points for lane in lanes])
    starts = np.array([0, 4, 6, 8, 10, 30], np.int64)
    for official in (True, False):
        args = (points, starts, official, False, 2.05, 2.0486, 0.0, False, 2, 800 if not official else 1640,
                288 if not official else 590, *_step_extras(2))
        expected = K.lane_set_runs(*args)
        for got, same in zip(K.lane_set_runs.py_func(*args), expected):
            np.testing.assert_array_equal(got, same)
        assert expected[3].tolist() == [False, False, False, True, True]  # by_canvas
        assert not expected[0][3:, 4].any()  # left for the caller to draw


@pytest.mark.parametrize("thickness", [2, 30])
def test_lanes_only_the_canvas_draws_are_packed_in_among_the_others(thickness):
    # LaneRuns.packed draws them through the canvas; every mask and IoU is the canvas's, and the
    # packing is lane_set_runs' own (rows in lane order, as many slots as the fullest row needs).
    lanes = [Lane.from_xy([700, 760, 800, 815], [589, 450, 330, 260]), COMB, Lane.from_xy([5], [5]), FAR,
             Lane.from_xy([-900, -800], [100, 200]), Lane.from_xy([650, 790], [589, 270])]
    for drawn, reference in (
            (official_mask_set(lanes, 1640, 590, thickness), official_mask_set_by_canvas(lanes, 1640, 590, thickness)),
            (map_mask_set(lanes, GEOMETRY, thickness), map_mask_set_by_canvas(lanes, GEOMETRY, thickness))):
        assert isinstance(drawn, LaneRuns)
        np.testing.assert_array_equal(drawn.ious(drawn), reference.ious(reference))
        first = 0
        for i in range(len(lanes)):
            assert drawn.drawn(i) == reference.drawn(i)
            if drawn.drawn(i):
                assert_same_mask(drawn.mask(i), reference.mask(i))
                assert drawn.meta[i, 1] == first
                first += drawn.meta[i, 2]
        assert first == drawn.lo.shape[0] == drawn.hi.shape[0]
        runs_per_row = [int(((drawn.hi[r] >= drawn.lo[r])).sum()) for r in range(first)]
        assert drawn.lo.shape[1] == max(runs_per_row) > 8  # the comb's rows: more than polyline_runs holds


# ---- the official matching -------------------------------------------------------------------------


def matched_by_match_lanes(similarity, rows, columns):
    sub = similarity[np.ix_(rows, columns)]
    out = np.full(len(rows), -np.inf)
    if sub.size:
        match = match_lanes(sub)
        found = np.flatnonzero(match >= 0)
        out[found] = sub[found, match[found]]
    return out


@st.composite
def similarities(draw):
    rows, columns = draw(st.integers(0, 6)), draw(st.integers(0, 6))
    values = st.sampled_from([0.0, 0.1, 0.3, 0.305, 0.5, 0.5, 0.505, 0.9, 1.0, np.nan]) | st.floats(0, 1)
    matrix = np.array(draw(st.lists(values, min_size=rows * columns, max_size=rows * columns)), np.float64)
    matrix = matrix.reshape(rows, columns)
    picked_rows = np.array(draw(st.permutations(range(rows))), np.int64)[: draw(st.integers(0, rows))]
    picked_columns = np.array(draw(st.permutations(range(columns))), np.int64)[: draw(st.integers(0, columns))]
    return matrix, picked_rows, picked_columns


@settings(max_examples=400, deadline=None, derandomize=True)
@given(similarities())
def test_matched_ious_are_match_lanes_step_for_step(case):
    matrix, rows, columns = case
    expected = matched_by_match_lanes(matrix, rows, columns)
    for kernel in (K.matched_ious, K.matched_ious.py_func):
        np.testing.assert_array_equal(kernel(matrix, rows, columns, KM_TOLERANCE), expected)
    everything = np.arange(matrix.shape[0]), np.arange(matrix.shape[1])
    np.testing.assert_array_equal(K.matched_ious(matrix, *everything, KM_TOLERANCE),
                                  matched_by_match_lanes(matrix, *everything))


def test_matched_ious_by_hand():
    similarity = np.array([[0.9, 0.75], [0.9, 0.0]])
    rows = np.arange(2)
    assert K.matched_ious(similarity, rows, rows, KM_TOLERANCE).tolist() == [0.75, 0.9]  # total 1.65 beats 0.9
    assert K.matched_ious(similarity, rows[:1], rows, KM_TOLERANCE).tolist() == [0.9]
    assert K.matched_ious(similarity, rows, rows[:0], KM_TOLERANCE).tolist() == [-np.inf, -np.inf]


# ---- quads an image edge clips -----------------------------------------------------------------------


@pytest.mark.parametrize("thickness", [30, 36, 16, 5, 2, 1])
def test_a_quad_one_edge_clips_is_its_clip_table_entry(thickness):
    """What _clipped_edge promises: an 8-neighbour step whose quad one edge clips, drawn there,
    is the clip table's pixels and its discs (clipped to the image)."""
    runs, counts = K.clip_extras(thickness)
    reach = (runs.shape[2] - 1) // 2
    radius = ((thickness << 15) + 32768) >> 16
    half = K.disc_half_widths(radius)
    info = _step_extras(thickness)[2]
    width, height = 4 * reach + 40, 3 * reach + 30
    # The end discs as the canvas's row fill draws them, once: 2 x 29 calls a case took most of the
    # test's 6.7 s.
    disc = np.zeros((2 * radius + 1, 2 * int(half.max()) + 1), np.uint8)
    for k, h in enumerate(half):
        K._span(disc, 0, 0, disc.shape[1], disc.shape[0], k, int(half.max()) - h, int(half.max()) + h)
    checked = set()
    for dx in (-1, 0, 1):
        for dy in (-1, 0, 1):
            if dx == dy == 0:
                continue
            d = (dx + 1) * 3 + (dy + 1)
            step = (dx + K.STEP_REACH) * (2 * K.STEP_REACH + 1) + (dy + K.STEP_REACH)
            for ax in [*range(-reach - 2, reach + 3), *range(width - reach - 2, width + reach + 3), width // 2]:
                for ay in [*range(-reach - 2, reach + 3), *range(height - reach - 2, height + reach + 3), height // 2]:
                    bx, by = ax + dx, ay + dy
                    edge, offset = K._clipped_edge(ax, ay, bx, by, info[step, 1], info[step, 2], width, height)
                    assert K._clipped_edge.py_func(ax, ay, bx, by, info[step, 1], info[step, 2], width,
                                                   height) == (edge, offset)
                    if edge < 0:
                        continue
                    canvas = np.zeros((height, width), np.uint8)
                    K._segment_quad(canvas, 0, 0, width, height, ax, ay, bx, by, thickness)
                    if abs(offset) > reach:  # beyond the table (drawn whole): the quad lies outside
                        assert not canvas.any()
                        continue
                    assert counts[edge, d, offset + reach] >= 0
                    checked.add(edge)
                    listed = np.zeros_like(canvas)
                    for y, left, right in runs[edge, d, offset + reach, :counts[edge, d, offset + reach]]:
                        assert 0 <= ay + y < height and 0 <= ax + left <= ax + right < width
                        listed[ay + y, ax + left:ax + right + 1] = 1
                    discs = np.zeros_like(canvas)
                    for cx, cy in ((ax, ay), (bx, by)):
                        _stamp(discs, disc, cx, cy)
                    if not np.array_equal(canvas | discs, listed | discs):  # the message only on failure
                        np.testing.assert_array_equal(canvas | discs, listed | discs)
    assert checked == {0, 1, 2, 3}


def _stamp(canvas: np.ndarray, disc: np.ndarray, cx: int, cy: int) -> None:
    """`disc` (centred) set in `canvas` around (cx, cy), clipped to it."""
    top, left = cy - disc.shape[0] // 2, cx - disc.shape[1] // 2
    y0, x0 = max(top, 0), max(left, 0)
    y1, x1 = min(top + disc.shape[0], canvas.shape[0]), min(left + disc.shape[1], canvas.shape[1])
    if y0 < y1 and x0 < x1:
        canvas[y0:y1, x0:x1] |= disc[y0 - top:y1 - top, x0 - left:x1 - left]


def test_clip_tables_py_func_and_edges_by_hand():
    for got, expected in zip(K.clip_extras.py_func(3), K.clip_extras(3)):
        np.testing.assert_array_equal(got, expected)
    info = _step_extras(30)[2]

    def corners(dx, dy):  # a 30 px quad's corner offsets: 15 px across the step (16-bit fixed point)
        step = (dx + K.STEP_REACH) * (2 * K.STEP_REACH + 1) + (dy + K.STEP_REACH)
        return info[step, 1], info[step, 2]

    across, down, diagonal = corners(1, 0), corners(0, 1), corners(1, 1)
    assert across == (0, 15 << 16) and down == (15 << 16, 0)
    assert K._clipped_edge(800, 300, 801, 300, *across, 1640, 590) == (-1, 0)  # nothing clipped
    assert K._clipped_edge(800, 580, 801, 580, *across, 1640, 590) == (3, -10)  # the bottom: y - height
    assert K._clipped_edge(800, 14, 801, 14, *across, 1640, 590) == (2, 14)  # the top: y
    assert K._clipped_edge(5, 14, 6, 14, *across, 1640, 590) == (2, 14)  # a step across reaches no side
    assert K._clipped_edge(5, 300, 5, 301, *down, 1640, 590) == (0, 5)  # the left: x
    assert K._clipped_edge(1630, 300, 1630, 301, *down, 1640, 590) == (1, -10)  # the right: x - width
    assert K._clipped_edge(3, 2, 4, 3, *diagonal, 1640, 590) == (-1, 0)  # a corner: two edges


@st.composite
def edge_lanes(draw, width=1640, height=590):
    """Lanes that run along, into and out of an image edge, in small steps (spline-sampled)."""
    edge = draw(st.sampled_from(["left", "right", "top", "bottom"]))
    n = draw(st.integers(3, 8))
    along = sorted(draw(st.lists(st.floats(0, 1), min_size=n, max_size=n, unique=True)))
    across = draw(st.lists(st.floats(-25, 25), min_size=n, max_size=n))
    if edge in ("left", "right"):
        base = 0 if edge == "left" else width
        return Lane.from_xy([base + a for a in across], [40 + t * (height - 80) for t in along])
    base = 0 if edge == "top" else height
    return Lane.from_xy([40 + t * (width - 80) for t in along], [base + a for a in across])


@SETTINGS
@given(edge_lanes(), st.sampled_from([30, 16, 5, 2]))
def test_lanes_along_an_edge_are_the_canvas(lane, thickness):
    assert_same_mask(official_mask(lane, 1640, 590, thickness), official_mask_by_canvas(lane, 1640, 590, thickness))
    xs, ys = pixels_of(lane.points)
    x0, y0, canvas = K.rasterise(xs, ys, thickness, 1640, 590, *_quad_extras(thickness))
    ok, rx0, ry0, rx1, lo, hi, area = K.polyline_runs(xs, ys, thickness, 1640, 590, *_step_extras(thickness))
    if ok:
        assert (rx0, ry0, area) == (x0, y0, int(canvas.sum()))
        assert runs_of(lo, hi) == obvious_runs(canvas, x0)


def test_polyline_runs_py_func_along_an_edge():
    xs, ys = pixels_of(np.array([[3.0, 580], [10, 589], [25, 592], [60, 588]]))
    expected = K.polyline_runs(xs, ys, 30, 1640, 590, *_step_extras(30))
    got = K.polyline_runs.py_func(xs, ys, 30, 1640, 590, *_step_extras(30))
    assert got[:4] == expected[:4] and got[6] == expected[6]
    assert runs_of(got[4], got[5]) == runs_of(expected[4], expected[5])


# ---- the paper's spline -------------------------------------------------------------------------------


@SETTINGS
@given(wild_lanes(), st.sampled_from([(2.05, 2.048611111111111, 0.0), (1640 / 976, 350 / 208, 240.0), (1.0, 1.0, 0.0)]),
       st.booleans())
def test_map_spline_pixels_are_those_of_the_pow_spline(lane, scales, truncate):
    points = np.ascontiguousarray(lane.points)
    points.flags.writeable = False
    for spline in (True, False):
        fast = K.map_spline_pixels(points, spline, *scales, truncate)
        by_pow = K.map_pixels(points, spline, *scales, truncate)
        np.testing.assert_array_equal(fast[0], by_pow[0])
        np.testing.assert_array_equal(fast[1], by_pow[1])


def test_map_spline_pixels_py_func_and_samples_on_a_half():
    # Each segment's first sample is its point: on a half pixel (scale 1), so close to where rint
    # turns that it is computed again with pow (the path a t * t * t sample takes when unsure).
    points = np.array([[10.5, 600.5], [40.5, 420.0], [120.0, 300.5], [300.0, 260.0]])
    for scales in ((1.0, 1.0, 0.0), (2.05, 2.048611111111111, 0.0)):
        for truncate in (False, True):
            expected = K.map_pixels(points, True, *scales, truncate)
            for kernel in (K.map_spline_pixels, K.map_spline_pixels.py_func):
                got = kernel(points, True, *scales, truncate)
                np.testing.assert_array_equal(got[0], expected[0])
                np.testing.assert_array_equal(got[1], expected[1])


# ---- the ego lanes, asked twice per frame ---------------------------------------------------------------


def test_ego_lanes_of_a_tuple_are_those_of_a_list():
    lanes = (Lane.from_xy([700, 760], [589, 300]), Lane.from_xy([900, 850], [589, 300]),
             Lane.from_xy([100, 300], [589, 300]))
    assert ego_lanes(lanes, 1640, 590, 0.5) == ego_lanes(list(lanes), 1640, 590, 0.5) == (lanes[0], lanes[1])
    assert ego_lanes(lanes, 1640, 590, 0.5) is ego_lanes(lanes, 1640, 590, 0.5)
    assert ego_lanes(lanes, 1640, 590, 0.1) == (lanes[2], lanes[0])  # the centre at x = 164
