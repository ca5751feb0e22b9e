"""The baseline and RONELD on synthetic maps with known lanes, and RONELD on the real clip."""

import numpy as np
import pytest
from conftest import clip_frames, lane_map

from roneld_eval.config import BaselineParams, MapsConfig, RoneldParams
from roneld_eval.extract import RoneldTracker, baseline_lanes, sample_rows
from roneld_eval.geometry import MapGeometry
from roneld_eval.maps import load_maps
from roneld_eval.model import FrameMaps

H, W = 288, 800
GEOMETRY = MapGeometry(1640, 590, W, H)
ROWS = np.arange(H, dtype=float)


def line(x_bottom, x_top, top=100):
    """x per map row of a straight lane from (x_bottom, H-1) up to row `top`."""
    xs = x_bottom + (x_top - x_bottom) * (H - 1 - ROWS) / (H - 1 - top)
    xs[ROWS < top] = np.nan
    return xs


def frame(*channels, existence=None):
    maps = np.zeros((4, H, W), np.uint8)
    for index, xs in channels:
        maps[index] = lane_map(H, W, xs)
    return FrameMaps(maps, None if existence is None else np.array(existence, float))


EGO = frame((1, line(250, 380)), (2, line(560, 420)))


# ---- baseline --------------------------------------------------------------------------------


def test_baseline_sample_rows_follow_prob2lines():
    rows = sample_rows(BaselineParams(), GEOMETRY)
    assert rows.image_rows.tolist()[:3] == [589, 569, 549] and len(rows.image_rows) == 18
    # getLane.m: lineId = uint16(288 - (i-1)*20/590*288), 1-based.
    assert rows.map_rows.tolist() == [int(np.floor(288 - i * 20 / 590 * 288 + 0.5)) - 1 for i in range(18)]
    enet = MapGeometry(1640, 590, 976, 208, crop_top_px=240)
    assert sample_rows(BaselineParams(), enet).map_rows.tolist() == [
        int(np.floor(208 - i * 20 / 350 * 208 + 0.5)) - 1 for i in range(18)]


def test_baseline_points_on_a_known_lane():
    lanes = baseline_lanes(EGO, BaselineParams(), GEOMETRY)
    assert lanes[0] is None and lanes[3] is None
    left = lanes[1]
    assert left.points[0].tolist() == [round(251 * 1640 / 800) - 1, 589]  # column 250, 1-based 251
    assert (np.diff(left.ys) < 0).all()  # bottom row first, as prob2lines writes
    expected = line(250, 380)[sample_rows(BaselineParams(), GEOMETRY).map_rows]
    keep = np.isfinite(expected)
    assert np.abs(left.xs - (np.round(expected[keep]) + 1) * 1640 / 800 + 1).max() <= 3


def test_baseline_threshold_existence_and_min_points():
    weak = FrameMaps(np.full((4, H, W), 76, np.uint8))  # 76/255 = 0.298: below 0.3
    assert baseline_lanes(weak, BaselineParams(), GEOMETRY) == [None] * 4
    strong = FrameMaps(np.full((4, H, W), 77, np.uint8))
    assert all(lane is not None for lane in baseline_lanes(strong, BaselineParams(), GEOMETRY))
    hidden = FrameMaps(EGO.probabilities, np.array([1, 0, 1, 1.0]))
    assert baseline_lanes(hidden, BaselineParams(), GEOMETRY)[1] is None
    one_row = np.zeros((4, H, W), np.uint8)
    one_row[1, H - 1, 300] = 255
    assert baseline_lanes(FrameMaps(one_row), BaselineParams(), GEOMETRY)[1] is None


# ---- RONELD ----------------------------------------------------------------------------------


def test_roneld_finds_the_ego_lanes_of_a_clean_frame():
    lanes = RoneldTracker(RoneldParams(), GEOMETRY)(EGO)
    left = GEOMETRY.image_to_map(lanes.left.points)
    right = GEOMETRY.image_to_map(lanes.right.points)
    # A straight segment from the bottom row up to the top of the detected points.
    assert left[1, 1] == pytest.approx(H - 1) and left[1, 0] == pytest.approx(250, abs=1.5)
    assert right[1, 0] == pytest.approx(560, abs=1.5)
    assert left[0, 1] == pytest.approx(right[0, 1])  # both up to the same top row
    assert left[0, 1] <= 110 and left[0, 0] == pytest.approx(380, abs=4)


def test_empty_maps_give_no_lanes():
    lanes = RoneldTracker(RoneldParams(), GEOMETRY)(FrameMaps(np.zeros((4, H, W), np.uint8)))
    assert lanes.left is None and lanes.right is None and lanes.as_list() == []


def test_one_channel_only():
    lanes = RoneldTracker(RoneldParams(), GEOMETRY)(frame((2, line(560, 420))))
    assert lanes.left is None and lanes.right is not None


def test_broken_lane_is_bridged_by_the_fit():
    xs = line(250, 380)
    xs[150:230] = np.nan  # a long gap: the lane is drawn across it as one line
    lanes = RoneldTracker(RoneldParams(), GEOMETRY)(frame((1, xs), (2, line(560, 420))))
    left = GEOMETRY.image_to_map(lanes.left.points)
    assert len(left) == 2 and left[1, 0] == pytest.approx(250, abs=2)


def test_noise_outliers_are_dropped():
    noisy = EGO.probabilities.copy()
    noisy[1, 200:203, 330:334] = 255  # a bright false blob beside the lane
    lanes = RoneldTracker(RoneldParams(), GEOMETRY)(FrameMaps(noisy))
    clean = RoneldTracker(RoneldParams(), GEOMETRY)(EGO)
    np.testing.assert_allclose(lanes.left.points, clean.left.points, atol=3 * 1640 / 800)


def test_curves_switch_curve_mode_on_after_enough_frames():
    xs = line(250, 380) + np.where(ROWS < 200, 0.02 * (200 - ROWS) ** 2, 0)
    curve_left = frame((1, xs), (2, 800 - xs))
    tracker = RoneldTracker(RoneldParams(), GEOMETRY)
    modes = [tracker(curve_left).curve_mode for _ in range(12)]
    assert modes[:7] == [False] * 7 and modes[-1] is True  # 2 curves a frame: ring sum 16 at frame 8
    lanes = tracker(curve_left)
    assert len(lanes.left) > 2  # drawn as a sampled quadratic spline
    no_pft = RoneldTracker(RoneldParams(), GEOMETRY, pft=False)
    assert not any(no_pft(curve_left).curve_mode for _ in range(12))


def test_tracking_carries_a_lane_through_missing_frames():
    seen = EGO
    gone = frame((2, line(560, 420)))  # the left ego lane vanishes
    with_pft = RoneldTracker(RoneldParams(), GEOMETRY, pft=True)
    without = RoneldTracker(RoneldParams(), GEOMETRY, pft=False)
    for _ in range(5):
        last_seen = with_pft(seen)
        without(seen)
    carried = [with_pft(gone).left for _ in range(3)]
    # The missed lane keeps its old line (its weight decays by e per frame).
    assert all(lane is not None for lane in carried)
    for lane in carried:
        np.testing.assert_allclose(lane.points, last_seen.left.points)
    assert without(gone).left is None


def test_state_does_not_leak_between_clips():
    tracker = RoneldTracker(RoneldParams(), GEOMETRY)
    for _ in range(5):
        tracker(EGO)
    tracker.reset()
    assert tracker(frame((2, line(560, 420)))).left is None


def test_float_and_uint8_maps_agree():
    as_float = EGO.probabilities.astype(np.float32) / 255
    from roneld_eval.maps._checks import canonical_probabilities

    np.testing.assert_array_equal(canonical_probabilities(as_float, "x", MapsConfig()), EGO.probabilities)


# ---- the real clip -----------------------------------------------------------------------------


def _draw(lane, geometry, thickness):
    import cv2

    mask = np.zeros((geometry.map_height, geometry.map_width), np.uint8)
    if lane is not None:
        points = np.trunc(geometry.image_to_map(lane.points)).astype(np.int32)  # as the reference draws
        cv2.polylines(mask, [points], False, 1, thickness)
    return mask.astype(bool)


@pytest.mark.parametrize("mode", ["pft", "nopft"])
def test_real_clip_matches_the_reference_masks(real_clip, mode):
    reference = np.load(real_clip / "reference_roneld_masks.npz")
    masks = np.unpackbits(reference[mode], axis=-1)[..., :976].astype(bool)
    frames = clip_frames(real_clip)
    assert list(reference["frames"]) == frames
    geometry = MapGeometry(1640, 590, 976, 351)
    tracker = RoneldTracker(RoneldParams(), geometry, pft=mode == "pft")
    ious = []
    config = MapsConfig(format="scnn-png", width=976, height=351)
    for k, name in enumerate(frames):
        lanes = tracker(load_maps(real_clip, f"{name}.jpg", config))
        for side, lane in enumerate((lanes.left, lanes.right)):
            ours, theirs = _draw(lane, geometry, 36), masks[k, side]
            union = (ours | theirs).sum()
            ious.append(1.0 if union == 0 else (ours & theirs).sum() / union)
    ious = np.array(ious)
    assert len(ious) == 180
    assert (ious >= 0.9).mean() >= 0.95
    assert ious.min() >= 0.5
