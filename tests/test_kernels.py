"""Every numba kernel against a slow, obvious Python version (and its own uncompiled .py_func)."""

import math

import numpy as np
import pytest
from conftest import lane_map
from scipy import integrate

from roneld_eval.extract import _kernels as K
from roneld_eval.extract.online import egolanes_as_scnn, egolanes_planes
from roneld_eval.extract.roneld import CONSTANTS

# ---- obvious versions, written from shared/docs/roneld-method.md ------------------------------


def obvious_extract_points(channel, threshold, stride):
    height, width = channel.shape
    points, confidences = [], []
    left, right, row = 0, width, 0
    while row < height:
        for column in range(left, right):
            if channel[row][column] >= threshold:
                best, where = 0, None
                for r in range(row, min(row + stride, height)):
                    for c in range(left, right):
                        if channel[r][c] > best:
                            best, where = channel[r][c], (c, r)
                points.append(where)
                confidences.append(best)
                left = int(where[0] - width * 0.25) if where[0] - width * 0.25 >= 0 else 0
                right = int(where[0] + width * 0.25) if where[0] + width * 0.25 <= width else width
                row += stride
                break
        row += 1
    return points, confidences


def obvious_r2(xs, ys):
    if len(xs) <= 1:
        return -1
    vx, vy = np.var(xs), np.var(ys)
    if vx == 0 or vy == 0:
        return 1
    return np.cov(np.stack([xs, ys]), bias=True)[0][1] ** 2 / (vx * vy)


def random_channel(rng, height=120, width=200):
    xs = np.full(height, np.nan)
    start = int(rng.integers(0, height // 2))
    slope = rng.uniform(-1.5, 1.5)
    xs[start:] = (rng.uniform(20, width - 20) + slope * np.arange(height - start)
                  + rng.normal(0, 2, height - start).cumsum() * 0.2)
    plane = lane_map(height, width, xs, value=int(rng.integers(60, 255)), sigma=rng.uniform(1, 4)).astype(np.int64)
    noise = (rng.random((height, width)) < 0.01) * rng.integers(0, 150, (height, width))
    gaps = rng.random(height) < 0.2
    plane[gaps] = 0
    return np.clip(plane + noise, 0, 255).astype(np.uint8)


@pytest.mark.parametrize("seed", range(12))
def test_extract_points_matches_the_obvious_scan(seed):
    rng = np.random.default_rng(seed)
    channel = random_channel(rng)
    threshold = max(int(channel.max()) // 3, 1)
    stride = channel.shape[0] // 20
    expected_points, expected_conf = obvious_extract_points(channel, threshold, stride)
    row_max = channel.max(axis=1)
    for kernel in (K.extract_points, K.extract_points.py_func):
        xs, ys, conf = kernel(channel, row_max, threshold, stride, np.int64(0), channel.shape[1])
        assert list(zip(xs.tolist(), ys.tolist())) == expected_points
        assert conf.tolist() == [float(c) for c in expected_conf]


@pytest.mark.parametrize("seed", range(12))
def test_extract_points_within_columns_is_the_scan_of_the_map_zeroed_outside_them(seed):
    rng = np.random.default_rng(300 + seed)
    channel = random_channel(rng)
    width = channel.shape[1]
    low, high = sorted(int(v) for v in rng.integers(0, width + 1, 2))
    zeroed = np.zeros_like(channel)
    zeroed[:, low:high] = channel[:, low:high]
    threshold = max(int(channel.max()) // 3, 1)  # the frame's, as frame_lanes takes it
    stride = channel.shape[0] // 20
    expected = K.extract_points(zeroed, zeroed.max(axis=1), threshold, stride, np.int64(0), width)
    assert len(expected[0]) or low == high or not zeroed.any() or zeroed.max() < threshold
    row_max = K.channel_row_maxima(channel[None], np.zeros(1, np.int64), np.array([low]), np.array([high]))[0]
    np.testing.assert_array_equal(row_max, zeroed.max(axis=1))
    for kernel in (K.extract_points, K.extract_points.py_func):
        got = kernel(channel, row_max, threshold, stride, np.int64(low), np.int64(high))
        for got_values, expected_values in zip(got, expected):
            np.testing.assert_array_equal(got_values, expected_values)


def test_row_maxima_and_threshold():
    maps = np.random.default_rng(1).integers(0, 200, (4, 30, 50)).astype(np.uint8)
    np.testing.assert_array_equal(K.row_maxima(maps), maps.max(axis=2))
    assert K.frame_threshold(K.row_maxima(maps)) == maps.max() // 3
    assert K.frame_threshold(np.zeros((4, 3), np.uint8)) == 1


@pytest.mark.parametrize("seed", range(20))
def test_r_squared(seed):
    rng = np.random.default_rng(seed)
    n = int(rng.integers(0, 15))
    xs = rng.integers(0, 100, n).astype(np.int64)
    ys = np.sort(rng.integers(0, 100, n)).astype(np.int64)
    for kernel in (K.r_squared, K.r_squared.py_func):
        assert kernel(xs, ys) == pytest.approx(obvious_r2(xs, ys), abs=1e-12)
    assert K.r_squared(np.array([5, 5, 5]), np.array([1, 2, 3])) == 1.0


def test_curve_test_on_hand_made_points():
    ys = np.arange(0, 200, 20)
    straight = 100 + ys // 2
    bent = straight.copy()
    bent[:3] += np.array([60, 35, 15])  # the top points stray: a curve
    assert not K.is_curve(straight, ys, 9, 3)
    assert K.is_curve(bent, ys, 9, 3)
    assert not K.is_curve(bent[-8:], ys[-8:], 9, 3)  # fewer than 9 points: never a curve


@pytest.mark.parametrize("seed", range(10))
def test_weighted_line_fit_matches_numpy(seed):
    rng = np.random.default_rng(seed)
    xs = rng.integers(0, 800, 12)
    ys = np.sort(rng.integers(0, 288, 12))
    weights = rng.uniform(1, 255, 12)
    slope, intercept = K.weighted_line_fit(xs, ys, weights)
    expected = np.polyfit(xs.astype(float), ys.astype(float), 1, w=np.sqrt(weights))
    assert slope == pytest.approx(expected[0], rel=1e-9)
    assert intercept == pytest.approx(expected[1], rel=1e-9, abs=1e-6)
    assert K.weighted_line_fit.py_func(xs, ys, weights) == pytest.approx((slope, intercept))


def test_vertical_and_flat_lines_stay_finite():
    slope, intercept = K.weighted_line_fit(np.array([50, 50, 50, 50]), np.array([0, 10, 20, 30]), np.ones(4))
    assert math.isfinite(slope) and math.isfinite(intercept)
    assert (20 - intercept) / slope == pytest.approx(50, abs=0.01)
    slope, _ = K.weighted_line_fit(np.array([0, 10, 20]), np.array([7, 7, 7]), np.ones(3))
    assert slope == 0.001


def test_outlier_rule_on_hand_made_points():
    ys = np.arange(0, 100, 10)
    xs = 200 + ys
    xs[4] += 40  # one far point
    xs[7] += 15  # a nearer one
    keep = K.remove_outliers(xs, ys, np.ones(10), 0.2, 3)
    # m = 10: floor(0.2 * 10) + 1 = 3 points go, the farthest from the first fit.
    slope, intercept = np.polyfit(xs.astype(float), ys.astype(float), 1)
    distance = np.abs(xs - (ys - intercept) / slope)
    expected = np.ones(10, bool)
    expected[np.argsort(distance, kind="stable")[-3:]] = False
    assert keep.sum() == 7 and not keep[4]
    assert (keep == expected).all()
    assert K.remove_outliers(xs[:3], ys[:3], np.ones(3), 0.2, 3).all()  # m <= 3: nothing dropped
    assert (K.remove_outliers.py_func(xs, ys, np.ones(10), 0.2, 3) == keep).all()


@pytest.mark.parametrize("lines", [((2.0, 10.0), (2.1, 30.0)), ((-1.5, 500.0), (1.2, -300.0)),
                                   ((3.0, 5.0), (3.0, 80.0))])
def test_line_distance_is_the_rms_integral(lines):
    (a1, b1), (a2, b2) = lines
    height = 288
    mean_square = integrate.quad(lambda y: ((y - b1) / a1 - (y - b2) / a2) ** 2, 0, height)[0] / height
    assert K.line_distance(a1, b1, a2, b2, height) == pytest.approx(math.sqrt(mean_square), rel=1e-9)
    assert K.line_distance(a1, b1, a1, b1, height) == 0


# ---- tracking: the rule in words, as a slow twin -----------------------------------------------


def obvious_track(previous, current, gains, height, merge, decay, min_weight):
    """previous/current: lists of dicts with slope, intercept, weight; returns (weights, sources)."""
    closest = []
    for lane in current:
        candidates = [(K.line_distance(lane["slope"], lane["intercept"], old["slope"], old["intercept"], height), j)
                      for j, old in enumerate(previous)]
        candidates = [c for c in candidates if c[0] < merge]
        closest.append(min(candidates)[1] if candidates else -1)
    tracked = []
    for j, old in enumerate(previous):
        for i in range(len(current)):
            if closest[i] == j:
                tracked.append((old["weight"] + gains[i], i))
    for i in range(len(current)):
        if closest[i] < 0:
            tracked.append((gains[i], i))
    for j, old in enumerate(previous):
        if j not in closest and old["weight"] >= min_weight:
            tracked.append((old["weight"] / decay, len(current) + j))
    tracked = sorted(tracked, key=lambda item: -item[0])
    return [w for w, _ in tracked], [s for _, s in tracked]


def _fields(lanes):
    out = np.zeros((len(lanes), K.N_FIELDS))
    for row, lane in enumerate(lanes):
        out[row, K.F_SLOPE] = lane["slope"]
        out[row, K.F_INTERCEPT] = lane["intercept"]
        out[row, K.F_WEIGHT] = lane.get("weight", 0.0)
    return out


@pytest.mark.parametrize("seed", range(15))
def test_track_lanes_matches_the_rule(seed):
    rng = np.random.default_rng(seed)
    def lane():
        return dict(slope=rng.choice([-1, 1]) * rng.uniform(0.3, 2), intercept=rng.uniform(-300, 600),
                    weight=float(rng.choice([1e-5, 0.1, 5, 50])))
    previous = [lane() for _ in range(int(rng.integers(0, 8)))]
    current = [dict(previous[j % len(previous)]) if previous and rng.random() < 0.5 else lane()
               for j in range(int(rng.integers(0, 5)))]
    for c in current:
        c["intercept"] += rng.normal(0, 1)
    gains = rng.uniform(0, 100, len(current))
    args = (288.0, 4.0, math.e, math.e ** -10)
    expected_weights, expected_sources = obvious_track(previous, current, gains, *args)
    for kernel in (K.track_lanes, K.track_lanes.py_func):
        tracked, sources = kernel(_fields(previous), _fields(current), gains, *args)
        assert sources.tolist() == expected_sources
        assert tracked[:, K.F_WEIGHT].tolist() == pytest.approx(expected_weights)


def test_choose_active_leans_and_weights():
    lanes = np.zeros((3, K.N_FIELDS))
    # Rows sorted heaviest first. Lane 0 meets the bottom left of centre but leans left: skipped.
    for row, (slope, intercept, top_x, bottom_x) in enumerate([(-1.0, 387.0, 100, 200), (-1.0, 487.0, 300, 200),
                                                                (1.0, -313.0, 450, 600)]):
        lanes[row, [K.F_SLOPE, K.F_INTERCEPT, K.F_TOP_X, K.F_BOTTOM_X]] = slope, intercept, top_x, bottom_x
    assert K.choose_active(lanes, 288.0, 400.0, False) == (1, 2)
    assert K.choose_active(lanes, 288.0, 400.0, True) == (0, 2)  # curve mode: any lean
    assert K.choose_active(lanes[:0], 288.0, 400.0, False) == (-1, -1)


def test_constants_are_the_references():
    assert (CONSTANTS.min_straight_points, CONSTANTS.min_curve_points, CONSTANTS.outlier_fraction) == (3, 9, 0.2)
    assert CONSTANTS.ego_weight == pytest.approx(7.389056) and CONSTANTS.min_weight == pytest.approx(4.54e-5, rel=1e-3)


def test_row_argmax_is_numpys_first_maximum():
    maps = np.random.default_rng(5).integers(0, 4, (4, 30, 50)).astype(np.uint8)  # many ties
    rows = np.array([0, 7, 29, 13])
    for kernel in (K.row_argmax, K.row_argmax.py_func):
        columns, values = kernel(maps, rows)
        np.testing.assert_array_equal(columns, maps[:, rows, :].argmax(axis=2))
        np.testing.assert_array_equal(values, maps[:, rows, :].max(axis=2))


# ---- whole-lane kernels against the method document, step by step in plain Python ----------


def obvious_channel_lane(channel, threshold, stride):
    """(xs, ys, confidences, curve, slope, intercept, rms) of one channel, or None: extraction,
    curve test, one outlier pass for straight lanes, weighted fit (sections 1-3)."""
    points, confidences = obvious_extract_points(channel, threshold, stride)
    if len(points) <= CONSTANTS.min_straight_points:
        return None
    xs = np.array([p[0] for p in points], np.int64)
    ys = np.array([p[1] for p in points], np.int64)
    weights = np.array(confidences, np.float64)
    top = CONSTANTS.curve_top_points
    curve = len(xs) >= CONSTANTS.min_curve_points and obvious_r2(xs, ys) < obvious_r2(xs[top:], ys[top:]) - K.R2_TIE
    if not curve:
        slope, intercept = np.polyfit(xs.astype(float), ys.astype(float), 1, w=np.sqrt(weights))
        distance = np.abs(xs - (ys - intercept) / slope)
        drop = int(len(xs) * CONSTANTS.outlier_fraction) + 1
        keep = np.ones(len(xs), bool)
        keep[np.argsort(distance, kind="stable")[len(xs) - drop:]] = False
        xs, ys, weights = xs[keep], ys[keep], weights[keep]
    slope, intercept = np.polyfit(xs.astype(float), ys.astype(float), 1, w=np.sqrt(weights))
    return xs, ys, weights, curve, slope, intercept, math.sqrt(np.mean(weights**2))


def random_frame(rng, channels=4, height=120, width=200):
    return np.stack([random_channel(rng, height, width) if rng.random() < 0.8 else np.zeros((height, width), np.uint8)
                     for _ in range(channels)])


def test_root_mean_square_does_not_overflow_uint8():
    values = np.array([255, 255, 3, 0], np.uint8)
    expected = math.sqrt(np.mean(values.astype(float) ** 2))
    assert K.root_mean_square(values) == pytest.approx(expected, rel=1e-15)
    assert K.root_mean_square.py_func(values) == pytest.approx(expected, rel=1e-15)
    floats = np.random.default_rng(0).uniform(0, 255, 50)
    assert K.root_mean_square(floats) == pytest.approx(math.sqrt(np.mean(floats**2)), rel=1e-14)


@pytest.mark.parametrize("seed", range(16))
def test_channel_lane_matches_the_method_step_by_step(seed):
    rng = np.random.default_rng(seed)
    maps = random_frame(rng, channels=1)
    row_max = K.row_maxima(maps)
    threshold = K.frame_threshold(row_max)
    stride = maps.shape[1] // CONSTANTS.rows_per_point
    arguments = (maps[0], row_max[0], threshold, stride, np.int64(0), maps.shape[2], CONSTANTS.min_straight_points,
                 CONSTANTS.min_curve_points, CONSTANTS.curve_top_points, CONSTANTS.outlier_fraction)
    got = K.channel_lane(*arguments)
    expected = obvious_channel_lane(maps[0], threshold, stride)
    if expected is None:
        assert got[0].size == 0
        return
    xs, ys, weights, curve, slope, intercept, rms = expected
    np.testing.assert_array_equal(got[0], xs)
    np.testing.assert_array_equal(got[1], ys)
    np.testing.assert_array_equal(got[2], weights)
    assert got[3] == curve
    assert got[4:] == pytest.approx((slope, intercept, rms), rel=1e-7, abs=1e-7)
    python = K.channel_lane.py_func(*arguments)
    assert python[3:] == pytest.approx(got[3:], rel=1e-12)


@pytest.mark.parametrize("seed", range(8))
def test_frame_lanes_packs_every_channels_lane(seed):
    rng = np.random.default_rng(100 + seed)
    maps = random_frame(rng)
    arguments = (*_whole(maps), CONSTANTS.rows_per_point, CONSTANTS.min_straight_points, CONSTANTS.min_curve_points,
                 CONSTANTS.curve_top_points, CONSTANTS.outlier_fraction)
    counts, xs, ys, fields = K.frame_lanes(maps, *arguments)
    threshold = max(int(maps.max()) // 3, 1)
    stride = maps.shape[1] // CONSTANTS.rows_per_point
    offset, row = 0, 0
    for channel in range(maps.shape[0]):
        expected = obvious_channel_lane(maps[channel], threshold, stride)
        if expected is None:
            assert counts[channel] == 0
            continue
        lane_xs, lane_ys, _, curve, slope, intercept, rms = expected
        n = len(lane_xs)
        assert counts[channel] == n
        np.testing.assert_array_equal(xs[offset:offset + n], lane_xs)
        np.testing.assert_array_equal(ys[offset:offset + n], lane_ys)
        field = fields[row]
        assert field[K.F_SLOPE] == pytest.approx(slope, rel=1e-7)
        assert field[K.F_INTERCEPT] == pytest.approx(intercept, rel=1e-7, abs=1e-7)
        assert field[K.F_RMS] == pytest.approx(rms, rel=1e-12)
        assert (field[K.F_CURVE], field[K.F_CHANNEL], field[K.F_POINTS]) == (float(curve), channel, n)
        assert (field[K.F_TOP_X], field[K.F_BOTTOM_X], field[K.F_TOP_Y]) == (lane_xs[0], lane_xs[-1], lane_ys[0])
        assert field[K.F_WEIGHT] == 0.0
        offset, row = offset + n, row + 1
    assert fields.shape[0] == row and xs.size == offset
    python = K.frame_lanes.py_func(maps, *arguments)
    np.testing.assert_array_equal(python[0], counts)
    np.testing.assert_allclose(python[3], fields, rtol=1e-12)


def _whole(maps):
    channels, _, width = maps.shape
    return np.arange(channels), np.zeros(channels, np.int64), np.full(channels, width, np.int64)


@pytest.mark.parametrize("seed", range(8))
def test_frame_lanes_reads_egolanes_planes_as_the_channels_they_map_to(seed):
    """EgoLanes' masks read in place (planes 2, 0, 1, 2 split at the vehicle) give exactly the
    lanes of the four channels egolanes_as_scnn builds."""
    rng = np.random.default_rng(200 + seed)
    masks = random_frame(rng, channels=3)
    center = float(rng.choice([0.5, 0.37, 0.61]))
    mapped = egolanes_as_scnn(masks, center)
    constants = (CONSTANTS.rows_per_point, CONSTANTS.min_straight_points, CONSTANTS.min_curve_points,
                 CONSTANTS.curve_top_points, CONSTANTS.outlier_fraction)
    planes = egolanes_planes(masks.shape[2], center)
    for kernel in (K.frame_lanes, K.frame_lanes.py_func):
        got = kernel(masks, planes.planes, planes.lows, planes.highs, *constants)
        expected = kernel(mapped, *_whole(mapped), *constants)
        for got_values, expected_values in zip(got, expected):
            np.testing.assert_array_equal(got_values, expected_values)
