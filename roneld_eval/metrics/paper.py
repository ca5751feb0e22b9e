"""The RONELD paper's protocol (section IV-B): the two ego lanes, drawn at map resolution.

Ground truth: of all labelled lanes, the two bounding the ego lane. Each lane's x at the
image's bottom row (y = height - 1) is extended linearly from its two lowest points; the
left ego lane is the one with the largest such x below center_ratio * width, the right ego
lane the one with the smallest x at or above it. Predictions are the method's left and right
active lanes. Lanes are scaled from image to map pixels, rounded to whole pixels (predictions
may instead be truncated, as the authors' code draws them) and drawn with the configured
thicknesses (ground truth thinner than predictions); the baseline's sparse points go through
the official cubic spline first. IoU per side; a ground-truth lane without a prediction
has IoU 0; a prediction without ground truth is not scored. No thresholds here.
"""

from __future__ import annotations

from typing import Sequence

from ..config import PaperMetricParams
from ..geometry import MapGeometry
from ..model import Lane
from .iou import mask_iou
from .raster import LaneMask, map_mask

SIDES = ("left", "right")


def bottom_x(lane: Lane, bottom_row: float) -> float:
    """x where the line through a lane's two lowest points meets `bottom_row`."""
    return lane.bottom_x(bottom_row)


def ego_lanes(lanes: Sequence[Lane], image_width: int, image_height: int,
              center_ratio: float) -> tuple[Lane | None, Lane | None]:
    """(left, right) ground-truth lanes bounding the ego lane; lanes of < 2 points are ignored."""
    center = center_ratio * image_width
    left = right = None
    left_x = right_x = None
    for lane in lanes:
        if len(lane) < 2:
            continue
        x = bottom_x(lane, image_height - 1)
        if x < center:
            if left_x is None or x > left_x:
                left, left_x = lane, x
        elif right_x is None or x < right_x:
            right, right_x = lane, x
    return left, right


def thicknesses(params: PaperMetricParams, geometry: MapGeometry) -> tuple[int, int]:
    """(ground truth, prediction) thickness in map pixels."""
    return (
        params.thickness(params.gt_thickness_px, geometry.map_width, geometry.map_height),
        params.thickness(params.pred_thickness_px, geometry.map_width, geometry.map_height),
    )


def ego_masks(gt_lanes: Sequence[Lane], geometry: MapGeometry, params: PaperMetricParams,
              center_ratio: float) -> dict[str, LaneMask | None]:
    """Masks of the ground-truth ego lanes per side (None where the side has no lane)."""
    gt_thickness, _ = thicknesses(params, geometry)
    chosen = ego_lanes(gt_lanes, geometry.image_width, geometry.image_height, center_ratio)
    return {side: None if lane is None else map_mask(lane, geometry, gt_thickness) for side, lane in zip(SIDES, chosen)}


def side_ious(gt: dict[str, LaneMask | None], predicted: Sequence[Lane | None], geometry: MapGeometry,
              params: PaperMetricParams, spline: bool = False) -> dict[str, float]:
    """IoU per side that has a ground-truth lane; 0 where the method gave no lane."""
    _, pred_thickness = thicknesses(params, geometry)
    out = {}
    for side, lane in zip(SIDES, predicted):
        truth = gt[side]
        if truth is None:
            continue
        if lane is None:
            out[side] = 0.0
            continue
        drawn = map_mask(lane, geometry, pred_thickness, spline=spline, rounding=params.prediction_rounding)
        value = mask_iou(truth, drawn)
        out[side] = 0.0 if value != value else value
    return out
