"""The models' own lane extraction: SCNN's tools/prob2lines (ENet-SAD's is the same rule).

For each sampled image row (0-based y; MATLAB's 1-based row is y + 1), read the map row
round((y + 1 - crop_top) * map_h / crop_h) (1-based, MATLAB's round half away from zero),
take the first maximum; keep it when value/255 > 0.3 as x = round(col * image_w / map_w) - 1
with col 1-based. A channel is kept when its existence is > 0.5 (when known) and it has at
least 2 points. Points are listed bottom row first, as prob2lines writes them. No spline
here: the cubic spline belongs to drawing the lane for scoring.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Mapping

import numpy as np

from ..config import BaselineParams

from ..thresholds import parse_rows
from ..geometry import MapGeometry
from ..model import EGO_CHANNELS, FrameMaps, Lane, read_only
from ._kernels import row_argmax
from .protocol import Prediction, ego_pair


def _round_half_up(numerator: np.ndarray, denominator: int) -> np.ndarray:
    """round(n / d) for n >= 0, halves up, in exact integer arithmetic (MATLAB's uint16())."""
    return (2 * numerator + denominator) // (2 * denominator)


@dataclass(frozen=True)
class SampleRows:
    """Where the baseline reads a map: output rows (image y) and the map rows they map to."""

    image_rows: np.ndarray  # bottom first
    map_rows: np.ndarray


def sample_rows(params: BaselineParams, geometry: MapGeometry) -> SampleRows:
    """Map rows for the configured image rows; rows outside the map's crop are skipped."""
    rows = np.array(list(parse_rows(params.rows))[::-1], dtype=np.int64)
    relative = rows + 1 - geometry.crop_top_px
    map_rows = _round_half_up(relative * geometry.map_height, geometry.crop_height_px) - 1
    inside = (relative > 0) & (map_rows >= 0) & (map_rows < geometry.map_height)
    return SampleRows(image_rows=rows[inside], map_rows=map_rows[inside])


def baseline_lanes(maps: FrameMaps, params: BaselineParams, geometry: MapGeometry,
                   rows: SampleRows | None = None) -> list[Lane | None]:
    """One lane (or None) per channel, in image pixels, bottom point first."""
    probabilities = maps.probabilities
    if (geometry.map_width, geometry.map_height) != (maps.width, maps.height):
        geometry = geometry.with_map_size(maps.width, maps.height)
        rows = None  # sampled for the other size
    if rows is None:
        rows = sample_rows(params, geometry)
    # The first maximum, as MATLAB's max; read-only: one compiled specialisation for every kind of maps
    columns, values = row_argmax(read_only(probabilities), rows.map_rows)
    found = values.astype(np.float64) / 255.0 > params.threshold
    xs = _round_half_up((columns + 1) * geometry.image_width, geometry.map_width) - 1
    lanes: list[Lane | None] = []
    for channel in range(maps.n_channels):
        exists = maps.existence is None or maps.existence[channel] > params.existence_threshold
        keep = found[channel]
        if not exists or keep.sum() < params.min_points:
            lanes.append(None)
            continue
        lanes.append(Lane.from_xy(xs[channel][keep], rows.image_rows[keep]))
    return lanes


class BaselineExtractor:
    """The method 'baseline': the model's own lanes. From maps, prob2lines as above, active
    lanes from the ego channels; from lane files (`FrameMaps.lanes`), the detector's lanes as
    they are, active lanes the nearest on each side of the ego position."""

    stateless = True  # each frame's lanes depend on that frame alone

    def __init__(self, geometry: MapGeometry, params: Mapping[str, Any]):
        params = dict(params)
        self.ego_center_ratio = float(params.pop("ego_center_ratio", 0.5))
        self.params = BaselineParams(**params)
        self.geometry = geometry
        self.rows = sample_rows(self.params, geometry)

    def __call__(self, maps: FrameMaps) -> Prediction:
        if maps.lanes is not None:
            lanes = tuple(maps.lanes)
            active = ego_pair(lanes, self.geometry.image_width, self.geometry.image_height, self.ego_center_ratio)
            return Prediction(lanes, active, spline=True)
        per_channel = baseline_lanes(maps, self.params, self.geometry, self.rows)
        left, right = (per_channel[c] if c < len(per_channel) else None for c in EGO_CHANNELS)
        # The models' lanes are sparse points that their own tools draw through a cubic spline.
        return Prediction(tuple(lane for lane in per_channel if lane is not None), (left, right), spline=True)
