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
