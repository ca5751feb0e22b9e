"""Masks held as runs per row: exactly the pixels the canvas rasteriser draws, however a lane lies.

The canvas (metrics._kernels.rasterise; raster.official_mask_by_canvas, map_mask_by_canvas) is
what the golden files check against the official tool's spline and OpenCV 4.6; the runs kernels
are checked against it, and each against a slow, obvious numpy version and its own .py_func.
"""

import hashlib
import json

import numpy as np
import pytest
from conftest import GOLDEN
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from roneld_eval import api
from roneld_eval.geometry import MapGeometry
from roneld_eval.metrics import _kernels as K
from roneld_eval.metrics.raster import (
    _quad_extras,
    _step_extras,
    map_mask,
    map_mask_by_canvas,
    official_mask,
    official_mask_by_canvas,
)
from roneld_eval.metrics.reference import drawn_masks
from roneld_eval.model import Lane

SETTINGS = settings(max_examples=150, deadline=None, derandomize=True, suppress_health_check=[HealthCheck.too_slow])
CASES = json.loads((GOLDEN / "raster_opencv46.json").read_text())["cases"]


def obvious_runs(canvas: np.ndarray, x0: int) -> list[list[tuple[int, int]]]:
    """Each row's runs of set pixels (image x, inclusive), read one pixel at a time."""
    out = []
    for row in canvas:
        runs, start = [], None
        for x, value in enumerate(list(row) + [0]):
            if value and start is None:
                start = x
            elif not value and start is not None:
                runs.append((x0 + start, x0 + x - 1))
                start = None
        out.append(runs)
    return out


def runs_of(lo: np.ndarray, hi: np.ndarray) -> list[list[tuple[int, int]]]:
    return [sorted((int(a), int(b)) for a, b in zip(row_lo, row_hi) if b >= a) for row_lo, row_hi in zip(lo, hi)]


def assert_same_mask(runs_mask, canvas_mask):
    if canvas_mask is None:
        assert runs_mask is None
        return
    assert (runs_mask.x0, runs_mask.y0, runs_mask.area) == (canvas_mask.x0, canvas_mask.y0, canvas_mask.area)
    np.testing.assert_array_equal(runs_mask.pixels, canvas_mask.pixels)


# ---- whole masks against the canvas ------------------------------------------------------------


@pytest.mark.parametrize("case", CASES, ids=[f"lane{i}" for i in range(len(CASES))])
def test_official_runs_are_the_golden_masks(case):
    lane = Lane(np.array(case["points"]).reshape(-1, 2))
    mask = official_mask(lane, case["width"], case["height"], case["thickness"])
    assert mask.lo is not None  # held as runs, whatever the lane (NaN points included)
    assert_same_mask(mask, official_mask_by_canvas(lane, case["width"], case["height"], case["thickness"]))
    full = mask.full(case["width"], case["height"])
    assert int(full.sum()) == case["pixels"] == mask.area
    assert hashlib.sha1(np.packbits(full).tobytes()).hexdigest() == case["sha1"]


@st.composite
def wild_lanes(draw, width=1640, height=590):
    """Lanes of 2-12 points anywhere near (or well beyond) the image: steep, flat, zig-zagging
    (rows with several runs), repeated points (NaN spline samples), steps long and short."""
    n = draw(st.integers(2, 12))
    style = draw(st.sampled_from(["smooth", "zigzag", "anywhere", "repeat"]))
    if style == "anywhere":
        xs = draw(st.lists(st.floats(-400, width + 400), min_size=n, max_size=n))
        ys = draw(st.lists(st.floats(-200, height + 200), min_size=n, max_size=n))
        return Lane.from_xy(xs, ys)
    ys = sorted(draw(st.lists(st.integers(-40, height + 40), min_size=n, max_size=n, unique=True)), reverse=True)
    x = draw(st.floats(-100, width + 100))
    slope = draw(st.floats(-12, 12))
    amplitude = draw(st.floats(0, 120)) if style == "zigzag" else draw(st.floats(0, 6))
    xs = [x + slope * (ys[0] - y) + amplitude * (-1) ** k for k, y in enumerate(ys)]
    if style == "repeat":
        k = draw(st.integers(0, n - 1))
        xs.insert(k, xs[k])
        ys.insert(k, ys[k])
    return Lane.from_xy(xs, ys)


@SETTINGS
@given(wild_lanes(), st.sampled_from([30, 30, 36, 19, 16, 3, 2, 1]))
def test_official_runs_match_the_canvas(lane, thickness):
    assert_same_mask(official_mask(lane, 1640, 590, thickness), official_mask_by_canvas(lane, 1640, 590, thickness))


@SETTINGS
@given(wild_lanes(), st.sampled_from([16, 30, 8, 1]), st.booleans(), st.sampled_from(["nearest", "truncate"]))
def test_map_runs_match_the_canvas(lane, thickness, spline, rounding):
    geometry = MapGeometry(1640, 590, 800, 288)
    assert_same_mask(map_mask(lane, geometry, thickness, spline, rounding),
                     map_mask_by_canvas(lane, geometry, thickness, spline, rounding))


@SETTINGS
@given(wild_lanes(), wild_lanes())
def test_overlaps_of_runs_match_the_canvas(a, b):
    runs = official_mask(a, 1640, 590, 30), official_mask(b, 1640, 590, 30)
    drawn = official_mask_by_canvas(a, 1640, 590, 30), official_mask_by_canvas(b, 1640, 590, 30)
    if runs[0] is None or runs[1] is None:
        return
    expected = int((drawn[0].full(1640, 590) & drawn[1].full(1640, 590)).sum())
    assert runs[0].intersection(runs[1]) == runs[1].intersection(runs[0]) == expected
    assert drawn[0].intersection(drawn[1]) == expected


def test_a_lane_far_outside_or_of_one_point():
    assert official_mask(Lane(np.zeros((1, 2))), 1640, 590, 30) is None
    outside = official_mask(Lane.from_xy([-500, -400, -300], [100, 200, 300]), 1640, 590, 30)
    assert outside.area == 0 and outside.intersection(outside) == 0
    far = Lane.from_xy([100, 3e7], [500, 100])  # beyond the far-point limit: read off the canvas
    assert_same_mask(official_mask(far, 1640, 590, 30), official_mask_by_canvas(far, 1640, 590, 30))


# ---- the kernels against obvious versions and their .py_func -----------------------------------


def pixels_of(points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    points = np.ascontiguousarray(points, np.float64)
    points.flags.writeable = False
    return K.official_pixels(points)


@SETTINGS
@given(wild_lanes())
def test_spline_pixels_are_those_of_the_pow_spline(lane):
    points = np.ascontiguousarray(lane.points, np.float64)
    points.flags.writeable = False
    fast, by_pow = K.official_pixels(points), K.official_pixels_by_pow(points)
    np.testing.assert_array_equal(fast[0], by_pow[0])
    np.testing.assert_array_equal(fast[1], by_pow[1])


def test_spline_pixels_py_func():
    xs = np.array([10.0, 30.5, 80.25, 200.0]).astype(np.float32).astype(np.float64)
    ys = np.array([590.0, 400.0, 300.0, 250.0]).astype(np.float32).astype(np.float64)
    compiled = K.official_spline_pixels(xs, ys, 50)
    python = K.official_spline_pixels.py_func(xs, ys, 50)
    samples = K.official_spline(xs, ys, 50)
    obvious = [np.array([K._round_float32(float(np.float32(v))) for v in axis]) for axis in samples]
    for got in (compiled, python):
        np.testing.assert_array_equal(got[0], obvious[0])
        np.testing.assert_array_equal(got[1], obvious[1])


@pytest.mark.parametrize("seed", range(8))
def test_polyline_runs_are_the_canvas_read_row_by_row(seed):
    rng = np.random.default_rng(seed)
    n = int(rng.integers(3, 9))
    points = np.stack([rng.uniform(-50, 1690, n), np.sort(rng.uniform(200, 640, n))[::-1]], axis=1)
    xs, ys = pixels_of(points)
    thickness = int(rng.choice([30, 16, 5]))
    tables = _quad_extras(thickness)
    x0, y0, canvas = K.rasterise(xs, ys, thickness, 1640, 590, *tables)
    expected = obvious_runs(canvas, x0)
    for kernel in (K.polyline_runs, K.polyline_runs.py_func):
        ok, rx0, ry0, rx1, lo, hi, area = kernel(xs, ys, thickness, 1640, 590, *_step_extras(thickness))
        assert ok
        assert (rx0, ry0, rx1, area) == (x0, y0, x0 + canvas.shape[1], int(canvas.sum()))
        assert runs_of(lo, hi) == expected


def test_canvas_runs_and_run_overlap_against_numpy():
    rng = np.random.default_rng(5)
    for _ in range(20):
        a = (rng.random((int(rng.integers(1, 30)), int(rng.integers(1, 40)))) < 0.5).astype(np.uint8)
        b = (rng.random((int(rng.integers(1, 30)), int(rng.integers(1, 40)))) < 0.5).astype(np.uint8)
        ax0, ay0, bx0, by0 = (int(v) for v in rng.integers(0, 10, 4))
        runs = []
        for canvas, x0 in ((a, ax0), (b, bx0)):
            for kernel in (K.canvas_runs, K.canvas_runs.py_func):
                lo, hi, area = kernel(canvas)
                assert runs_of(lo, hi) == obvious_runs(canvas, 0) and area == int(canvas.sum())
            runs.append((lo + np.where(hi >= lo, x0, 0), hi + np.where(hi >= lo, x0, 0)))
        full_a = np.zeros((50, 60), np.uint8)
        full_b = np.zeros((50, 60), np.uint8)
        full_a[ay0:ay0 + a.shape[0], ax0:ax0 + a.shape[1]] = a
        full_b[by0:by0 + b.shape[0], bx0:bx0 + b.shape[1]] = b
        expected = int((full_a & full_b).sum())
        for kernel in (K.run_overlap, K.run_overlap.py_func):
            assert kernel(ay0, *runs[0], by0, *runs[1]) == expected


@pytest.mark.parametrize("thickness", [30, 16, 3])
def test_step_extras_are_each_quad_outside_its_discs(thickness):
    reach = 3
    runs, counts, info = K.step_extras(thickness, reach)
    py_runs, py_counts, py_info = K.step_extras.py_func(thickness, reach)
    np.testing.assert_array_equal(counts, py_counts)
    np.testing.assert_array_equal(info, py_info)
    radius = ((thickness << 15) + 32768) >> 16  # round(thickness / 2), as the kernels
    half = K.disc_half_widths(radius)
    centre, size = 60, 121
    for dx in range(-reach, reach + 1):
        for dy in range(-reach, reach + 1):
            if dx == 0 and dy == 0:
                continue
            d = (dx + reach) * (2 * reach + 1) + (dy + reach)
            np.testing.assert_array_equal(py_runs[d, :py_counts[d]], runs[d, :counts[d]])
            quad = np.zeros((size, size), np.uint8)
            K._segment_quad(quad, 0, 0, size, size, centre, centre, centre + dx, centre + dy, thickness)
            discs = np.zeros_like(quad)
            for cx, cy in ((centre, centre), (centre + dx, centre + dy)):
                for k, h in enumerate(half):
                    discs[cy - radius + k, cx - h:cx + h + 1] = 1
            outside = quad & (1 - discs)
            table = np.zeros_like(quad)
            for y, left, right in runs[d, :counts[d]]:
                table[centre + y, centre + left:centre + right + 1] = 1
            np.testing.assert_array_equal(table, outside)
            union = quad | discs
            both = [y for y in range(size) if abs(y - centre) <= radius and abs(y - centre - dy) <= radius]
            one_run = all(np.count_nonzero(np.diff(np.concatenate([[0], union[y], [0]])) == 1) == 1 for y in both)
            assert info[d, 0] == one_run
            # The corners' offsets, as ThickLine computes them (16-bit fixed point).
            r = ((thickness << 15) + (thickness & 1) * 65536 * 0.5) / np.hypot(dx, dy)
            assert (info[d, 1], info[d, 2]) == (abs(round(dy * r)), abs(round(dx * r)))


def test_a_quad_that_fits_the_image_is_its_table_entry_there():
    """What _quad_unclipped promises: a step whose quad it passes, drawn at the image's edge,
    is the table's pixels and its discs (clipped), as drawn far inside."""
    thickness, reach = 30, 8
    runs, counts, info = K.step_extras(thickness, reach)
    width, height = 80, 60
    for dx, dy in ((1, 1), (0, 1), (3, -2), (8, 5), (-2, 0)):
        d = (dx + reach) * (2 * reach + 1) + (dy + reach)
        for ax in range(-20, width + 20):
            for ay in (0, 1, 10, height - 12, height - 2, height - 1):
                bx, by = ax + dx, ay + dy
                if not K._quad_unclipped(ax, ay, bx, by, info[d, 1], info[d, 2], width, height):
                    continue
                canvas = np.zeros((height, width), np.uint8)
                K._segment_quad(canvas, 0, 0, width, height, ax, ay, bx, by, thickness)
                expected = np.zeros_like(canvas)
                for y, left, right in runs[d, :counts[d]]:
                    expected[ay + y, ax + left:ax + right + 1] = 1
                discs = np.zeros_like(canvas)
                for cx, cy in ((ax, ay), (bx, by)):
                    # the discs as draw_polyline draws them, clipped to the image
                    for k, h in enumerate(K.disc_half_widths(15)):
                        K._span(discs, 0, 0, width, height, cy - 15 + k, cx - h, cx + h)
                np.testing.assert_array_equal(canvas | discs, expected | discs)


# ---- whole runs -----------------------------------------------------------------------------------


def test_a_run_scores_the_same_bytes_with_canvas_masks(tmp_path):
    config = api.default_config("culane").with_overrides(pft_ablation=True, workers=1)
    api.run(config, tmp_path / "runs", progress=False)
    with drawn_masks():
        api.run(config, tmp_path / "canvas", progress=False)
    for name in ("per_frame.csv", "official.csv", "accuracy.csv"):
        assert (tmp_path / "runs" / name).read_bytes() == (tmp_path / "canvas" / name).read_bytes(), name
