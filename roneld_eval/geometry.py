"""Where a probability map lies in its camera frame, and the transform between the two.

A map of size (map_width, map_height) covers image rows [crop_top_px, crop_bottom_px) and
all columns of an (image_width, image_height) frame: SCNN's 800x288 CULane maps cover the
whole 1640x590 frame, ENet-SAD's 976x208 maps rows 240..589. Map pixel (u, v) corresponds to
image pixel (u * image_width / map_width, crop_top_px + v * crop_height_px / map_height): the
scaling the models' own tools (prob2lines) and RONELD's reference use.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from .errors import ConfigError


@dataclass(frozen=True)
class MapGeometry:
    """Image size, map size and the band of image rows a map covers."""

    image_width: int
    image_height: int
    map_width: int
    map_height: int
    crop_top_px: int = 0
    crop_bottom_px: int | None = None

    def __post_init__(self):
        if self.crop_bottom_px is None:
            object.__setattr__(self, "crop_bottom_px", self.image_height)
        for name in ("image_width", "image_height", "map_width", "map_height"):
            if int(getattr(self, name)) <= 0:
                raise ConfigError(f"{name} must be positive, got {getattr(self, name)}")
        if not 0 <= self.crop_top_px < self.crop_bottom_px <= self.image_height:
            raise ConfigError(
                f"map crop rows [{self.crop_top_px}, {self.crop_bottom_px}) must lie inside the "
                f"{self.image_height}-row image"
            )

    @property
    def crop_height_px(self) -> int:
        return self.crop_bottom_px - self.crop_top_px

    @property
    def scale_x(self) -> float:
        """Image pixels per map pixel, horizontally."""
        return self.image_width / self.map_width

    @property
    def scale_y(self) -> float:
        """Image pixels per map pixel, vertically."""
        return self.crop_height_px / self.map_height

    def with_map_size(self, map_width: int, map_height: int) -> "MapGeometry":
        """The same frame and crop, for maps of another size."""
        return replace(self, map_width=int(map_width), map_height=int(map_height))

    def map_to_image(self, points: np.ndarray) -> np.ndarray:
        """(N, 2) map pixels -> image pixels."""
        points = np.asarray(points, np.float64)
        return np.stack(
            [points[:, 0] * self.scale_x, self.crop_top_px + points[:, 1] * self.scale_y], axis=1
        )

    def image_to_map(self, points: np.ndarray) -> np.ndarray:
        """(N, 2) image pixels -> map pixels (may fall outside the map)."""
        points = np.asarray(points, np.float64)
        return np.stack(
            [points[:, 0] / self.scale_x, (points[:, 1] - self.crop_top_px) / self.scale_y], axis=1
        )
