"""Lane rasterisation: the same pixels as the official evaluator's spline + OpenCV 4.6 drawing."""

import hashlib
import json

import numpy as np
import pytest
from conftest import GOLDEN
from scipy.interpolate import CubicSpline

from roneld_eval.metrics import _kernels as K
from roneld_eval.metrics.raster import LaneMask, mask_from_pixels, official_mask
from roneld_eval.model import Lane

CASES = json.loads((GOLDEN / "raster_opencv46.json").read_text())["cases"]


@pytest.mark.parametrize("case", CASES, ids=[f"lane{i}" for i in range(len(CASES))])
def test_masks_equal_opencv_46(case):
    lane = Lane(np.array(case["points"]).reshape(-1, 2))
    mask = official_mask(lane, case["width"], case["height"], case["thickness"])
    full = mask.full(case["width"], case["height"])
    assert int(full.sum()) == case["pixels"]
    assert hashlib.sha1(np.packbits(full).tobytes()).hexdigest() == case["sha1"]


def test_golden_covers_the_awkward_cases():
    points = [np.array(c["points"]).reshape(-1, 2) for c in CASES]
    assert any(len(p) == 2 for p in points)
    assert any(((p[:, 0] < 0) | (p[:, 1] > 600)).any() for p in points)  # partly outside
    assert any((np.diff(p, axis=0) == 0).all(axis=1).any() for p in points)  # repeated point: NaN spline
    assert {c["thickness"] for c in CASES} == {30, 36, 16, 19}


def test_official_spline_is_a_natural_spline_over_chord_length():
    points = np.array([[100.0, 590], [130, 500], [180, 420], [250, 350], [330, 300]])
    samples = np.stack(K.official_spline(points[:, 0].copy(), points[:, 1].copy(), 50), axis=1)
    assert len(samples) == 4 * 50 + 1
    chord = np.concatenate([[0], np.cumsum(np.hypot(*np.diff(points, axis=0).T))])
    reference = CubicSpline(chord, points, bc_type="natural")
    t = np.concatenate([chord[i] + (chord[i + 1] - chord[i]) / 50 * np.arange(50) for i in range(4)] + [[chord[-1]]])
    np.testing.assert_allclose(samples, reference(t), atol=1e-9)
    py = K.official_spline.py_func(points[:, 0].copy(), points[:, 1].copy(), 50)
    np.testing.assert_array_equal(np.stack(py, axis=1), samples)


def test_rounding_like_opencv():
    """cv::Point2f -> cv::Point: half to even; NaN and out-of-range values become INT_MIN."""
    values = [0.5, 1.5, 2.5, -0.5, float("nan"), 3e9, -1.4]
    for kernel in (K._round_float32, K._round_float32.py_func):
        assert [kernel(v) for v in values] == [0, 2, 2, 0, K.INT_MIN, K.INT_MIN, -1]


def test_overlap_matches_numpy():
    rng = np.random.default_rng(3)
    for _ in range(30):
        a = mask_from_pixels(rng.integers(0, 200, 3), rng.integers(0, 100, 3), int(rng.integers(1, 20)), 200, 100)
        b = mask_from_pixels(rng.integers(0, 200, 4), rng.integers(0, 100, 4), int(rng.integers(1, 20)), 200, 100)
        expected = int((a.full(200, 100) & b.full(200, 100)).sum())
        assert a.intersection(b) == expected
        assert K.overlap.py_func(a.x0, a.y0, a.pixels, b.x0, b.y0, b.pixels) == expected


def test_disc_is_opencvs_filled_circle():
    import cv2

    for radius in (1, 8, 10, 15, 18):
        image = np.zeros((60, 60), np.uint8)
        cv2.circle(image, (30, 30), radius, 1, -1)  # LINE_8, filled: the same Circle() routine
        half = K.disc_half_widths(radius)
        ours = np.zeros_like(image)
        for k, h in enumerate(half):
            ours[30 - radius + k, 30 - h:30 + h + 1] = 1
        np.testing.assert_array_equal(ours, image)


def test_few_points_draw_nothing_and_empty_masks():
    assert official_mask(Lane(np.zeros((1, 2))), 1640, 590, 30) is None
    one = mask_from_pixels(np.array([5]), np.array([5]), 30, 100, 100)
    assert one.area == 0
    assert LaneMask.empty().intersection(one) == 0


# ---- the paper protocol's map-resolution lanes against plain Python ---------------------------


def obvious_map_pixels(points, scale_x, scale_y, offset_y, truncate):
    """Image points -> map pixels, as the method document says: divide, snap, drop non-finite."""
    snap = np.trunc if truncate else np.rint  # rint: half to even, as numpy and numba round
    keep = np.isfinite(points).all(axis=1)
    xs = snap(points[keep, 0] / scale_x).astype(np.int64)
    ys = snap((points[keep, 1] - offset_y) / scale_y).astype(np.int64)
    return xs, ys


@pytest.mark.parametrize("seed", range(10))
@pytest.mark.parametrize("truncate", [False, True])
def test_map_pixels_and_map_lane_match_plain_python(seed, truncate):
    from roneld_eval.metrics.raster import _points, _quad_extras

    rng = np.random.default_rng(seed)
    points = np.stack([rng.uniform(-100, 1740, 6), np.sort(rng.uniform(200, 650, 6))], axis=1)
    points[rng.integers(0, 6)] = [np.nan, 400.0] if seed % 3 == 0 else points[0]
    lane = _points(Lane(points))
    scale_x, scale_y, offset_y = 1640 / 800, 590 / 288, 0.0
    px, py = K.map_pixels(lane, False, scale_x, scale_y, offset_y, truncate)
    xs, ys = obvious_map_pixels(points, scale_x, scale_y, offset_y, truncate)
    np.testing.assert_array_equal(px, xs)
    np.testing.assert_array_equal(py, ys)
    # map_lane is those pixels through the golden-tested rasteriser, compiled or not.
    extras = _quad_extras(9)
    drawn = K.map_lane(lane, False, scale_x, scale_y, offset_y, truncate, 9, 800, 288, *extras)
    expected = K.rasterise_with_area(xs, ys, 9, 800, 288, *extras)
    python = K.map_lane.py_func(lane, False, scale_x, scale_y, offset_y, truncate, 9, 800, 288, *extras)
    for got in (drawn, python):
        assert got[0] == expected[0] and got[1] == expected[1] and got[3] == expected[3]
        np.testing.assert_array_equal(got[2], expected[2])
    assert drawn[3] == int(np.count_nonzero(drawn[2])) > 0
