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

from functools import lru_cache
from typing import Sequence

from ..config import PaperMetricParams
from ..geometry import MapGeometry
from ..model import Lane
from .raster import MaskSet, map_mask_set

SIDES = ("left", "right")


def bottom_x(lane: Lane, bottom_row: float) -> float:
    """x where the line through a lane's two lowest points meets `bottom_row`."""
    return lane.bottom_x(bottom_row)


def ego_lanes(lanes: Sequence[Lane], image_width: int, image_height: int,
              center_ratio: float) -> tuple[Lane | None, Lane | None]:
    """(left, right) ground-truth lanes bounding the ego lane; lanes of < 2 points are ignored."""
    if isinstance(lanes, tuple):  # a frame's lanes: scoring asks twice per frame (paper and official)
        return _ego_lanes_of(lanes, image_width, image_height, center_ratio)
    return _ego_lanes(lanes, image_width, image_height, center_ratio)


# Lanes hash by identity and never change (frozen, read-only points): a tuple of them is a key.
@lru_cache(maxsize=4)
def _ego_lanes_of(lanes: tuple[Lane, ...], image_width: int, image_height: int,
                  center_ratio: float) -> tuple[Lane | None, Lane | None]:
    return _ego_lanes(lanes, image_width, image_height, center_ratio)


def _ego_lanes(lanes: Sequence[Lane], image_width: int, image_height: int,
               center_ratio: float) -> tuple[Lane | None, Lane | None]:
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
    return _thicknesses(params, geometry.map_width, geometry.map_height)


@lru_cache(maxsize=64)
def _thicknesses(params: PaperMetricParams, map_width: int, map_height: int) -> tuple[int, int]:
    # Cached: PaperMetricParams.thickness computes with Decimal, and every scored frame asks.
    return (params.thickness(params.gt_thickness_px, map_width, map_height),
            params.thickness(params.pred_thickness_px, map_width, map_height))


def ego_masks(gt_lanes: Sequence[Lane], geometry: MapGeometry, params: PaperMetricParams,
              center_ratio: float) -> MaskSet:
    """Masks of the ground-truth ego lanes, left then right (not drawn where a side has no lane)."""
    gt_thickness, _ = thicknesses(params, geometry)
    chosen = ego_lanes(gt_lanes, geometry.image_width, geometry.image_height, center_ratio)
    return map_mask_set(chosen, geometry, gt_thickness)


def side_ious(gt: MaskSet, predicted: Sequence[Lane | None], geometry: MapGeometry,
              params: PaperMetricParams, spline: bool = False) -> dict[str, float]:
    """IoU per side that has a ground-truth lane (ego_masks); 0 where the method gave no lane."""
    scored = [k for k in range(min(len(SIDES), len(predicted))) if gt.drawn(k)]
    if not scored:
        return {}
    _, pred_thickness = thicknesses(params, geometry)
    # Only the sides scored are drawn; a side without a lane (or of < 2 points) is not: IoU 0.
    lanes = [predicted[k] if k in scored else None for k in range(len(SIDES))]
    values = gt.ious(map_mask_set(lanes, geometry, pred_thickness, spline, params.prediction_rounding))
    out = {}
    for k in scored:
        value = float(values[k, k])
        out[SIDES[k]] = 0.0 if value != value else value
    return out
