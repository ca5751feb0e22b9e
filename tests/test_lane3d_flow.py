"""The 3-D lane comparison the OpenLane 3D and Apollo 3D scorers share (roneld_eval.metrics.lane3d_flow):
its resampling written out is scipy's interp1d, lane by lane and for a frame's lanes at once, bit for bit."""

from __future__ import annotations

import numpy as np
import pytest

from roneld_eval.metrics import lane3d_flow


def _one_at_a_time(lanes):
    """sampled's twin: each lane through `resample` and the evaluators' visibility, as they loop."""
    points, visibility = np.zeros((len(lanes), 100, 2)), np.zeros((len(lanes), 100))
    for i, lane in enumerate(lanes):
        min_y, max_y = np.min(lane[:, 1]), np.max(lane[:, 1])
        x_values, z_values, near = lane3d_flow.resample(lane)
        points[i] = np.vstack([x_values, z_values]).T
        visibility[i, :] = np.logical_and(x_values >= lane3d_flow.X_MIN, np.logical_and(
            x_values <= lane3d_flow.X_MAX, np.logical_and(lane3d_flow.Y_SAMPLES >= min_y,
                                                          lane3d_flow.Y_SAMPLES <= max_y)))
        visibility[i, :] = np.logical_and(visibility[i, :], near)
    return points, visibility


def _lanes(rng: np.random.Generator) -> list[np.ndarray]:
    lanes = []
    for _ in range(int(rng.integers(0, 8))):
        m = int(rng.integers(2, 40))
        y = (rng.uniform(-20, 150, m) if rng.random() < 0.5
             else np.linspace(rng.uniform(0, 30), rng.uniform(40, 130), m))
        if rng.random() < 0.2:
            y[1] = y[0]  # a repeated y: inf and NaN, as interp1d gives them
        if rng.random() < 0.2:
            y = np.round(y)  # samples landing on points
        lane = np.column_stack([rng.normal(0, 8, m), y, rng.normal(0, 1, m)])
        lanes.append(lane[:, :2] if rng.random() < 0.2 else lane)
    return lanes


@pytest.mark.parametrize("block", [100, 5000, lane3d_flow.SAMPLED_AT_ONCE])
def test_a_frames_lanes_resampled_together_are_each_lanes_bits(block, monkeypatch):
    monkeypatch.setattr(lane3d_flow, "SAMPLED_AT_ONCE", block)
    rng = np.random.default_rng(block)
    for _ in range(1000):
        lanes = _lanes(rng)
        together, alone = lane3d_flow.sampled(lanes), _one_at_a_time(lanes)
        assert together[0].tobytes() == alone[0].tobytes() and together[1].tobytes() == alone[1].tobytes()


def test_linear_is_interp1ds_bit_for_bit():
    from scipy.interpolate import interp1d

    rng = np.random.default_rng(0)
    for _ in range(500):
        n = int(rng.integers(2, 25))
        x, y = rng.uniform(-5, 5, n), rng.normal(0, 3, n)
        if rng.random() < 0.3:
            x = np.round(x)  # equal x and points on the samples
        at = rng.uniform(-8, 8, 50)
        with np.errstate(divide="ignore", invalid="ignore"):
            theirs = interp1d(x, y, fill_value="extrapolate")(at)
        assert lane3d_flow.linear(x, y, at).tobytes() == theirs.tobytes()
