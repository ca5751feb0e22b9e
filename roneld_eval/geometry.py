"""Where a probability map lies in its camera frame, and the transform between the two.

A map of size (map_width, map_height) covers image rows [crop_top_px, crop_bottom_px) and
all columns of an (image_width, image_height) frame: SCNN's 800x288 CULane maps cover the
whole 1640x590 frame, ENet-SAD's 976x208 maps rows 240..589. Map pixel (u, v) corresponds to
image pixel (u * image_width / map_width, crop_top_px + v * crop_height_px / map_height): the
scaling the models' own tools (prob2lines) and RONELD's reference use.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass, replace

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
        bottom = self.image_height if self.crop_bottom_px is None else self.crop_bottom_px
        object.__setattr__(self, "crop_bottom_px", bottom)
        for name in ("image_width", "image_height", "map_width", "map_height"):
            if int(getattr(self, name)) <= 0:
                raise ConfigError(f"{name} must be positive, got {getattr(self, name)}")
        if not 0 <= self.crop_top_px < bottom <= self.image_height:
            raise ConfigError(
                f"map crop rows [{self.crop_top_px}, {self.crop_bottom_px}) must lie inside the "
                f"{self.image_height}-row image"
            )

    @property
    def crop_height_px(self) -> int:
        assert self.crop_bottom_px is not None  # __post_init__ fills it in
        return self.crop_bottom_px - self.crop_top_px

    @property
    def image_size(self) -> tuple[int, int]:
        return self.image_width, self.image_height

    @property
    def scale_x(self) -> float:
        """Image pixels per map pixel, horizontally."""
        return self.image_width / self.map_width

    @property
    def scale_y(self) -> float:
        """Image pixels per map pixel, vertically."""
        return self.crop_height_px / self.map_height

    def with_map_size(self, map_width: int, map_height: int) -> "MapGeometry":
        """The same frame and crop, for maps of another size (itself for maps of its size):
        the one rule by which maps of any size are placed in the image."""
        if (map_width, map_height) == (self.map_width, self.map_height):
            return self
        return replace(self, map_width=int(map_width), map_height=int(map_height))

    def at_image_size(self, image_width: int, image_height: int) -> "MapGeometry":
        """The same maps over a frame of another size: the crop rows scale with the height
        (a benchmark whose videos come in several sizes configures them at its reference size)."""
        if (image_width, image_height) == (self.image_width, self.image_height):
            return self
        assert self.crop_bottom_px is not None  # __post_init__ fills it in
        top = round(self.crop_top_px * image_height / self.image_height)
        bottom = round(self.crop_bottom_px * image_height / self.image_height)
        return replace(self, image_width=int(image_width), image_height=int(image_height),
                       crop_top_px=top, crop_bottom_px=max(bottom, top + 1))

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


@dataclass(frozen=True)
class EffectiveGeometry:
    """What a run really drew: the maps' size as found and the thicknesses that follow from it.

    The configuration names a reference map size (SCNN: 800x288); maps of another size are
    rescaled, and the paper's thicknesses scale with them. Reports state these, not the preset's.
    """

    image_width: int
    image_height: int
    map_width: int  # as found in the first frame's maps
    map_height: int
    crop_top_px: int
    crop_bottom_px: int
    rescaled: bool  # the maps' size differs from the configuration's
    gt_thickness_px: int  # paper protocol, in map pixels
    pred_thickness_px: int
    official_lane_width_px: int  # official CULane protocol, at image resolution
    official_iou_threshold: float
    # (width, height) of the frames where they come in several sizes (VIL-100), each frame then
    # drawn at its own (image_width x image_height is the configured reference); empty: one size
    frame_sizes: tuple[tuple[int, int], ...] = ()

    def describe(self) -> str:
        """One line for reports: map size, crop and every thickness really used."""
        if self.frame_sizes:
            frames = f"each frame at its own size ({self.sizes_text()})"
            if (self.crop_top_px, self.crop_bottom_px) != (0, self.image_height):
                frames = (f"image rows {self.crop_top_px}..{self.crop_bottom_px - 1} of {self.image_width}x"
                          f"{self.image_height}, scaled with the height of {frames}")
            else:
                frames = f"the whole of {frames}"
            return (f"maps {self.map_width}x{self.map_height} over {frames}"
                    f"{' (rescaled from the preset)' if self.rescaled else ''}; "
                    f"paper protocol: ground truth {self.gt_thickness_px} px, predictions {self.pred_thickness_px} px")
        return (f"maps {self.map_width}x{self.map_height} "
                f"over image rows {self.crop_top_px}..{self.crop_bottom_px - 1} "
                f"of {self.image_width}x{self.image_height}{' (rescaled from the preset)' if self.rescaled else ''}; "
                f"paper protocol: ground truth {self.gt_thickness_px} px, predictions {self.pred_thickness_px} px; "
                f"official: IoU > {self.official_iou_threshold:g}, {self.official_lane_width_px} px at "
                f"{self.image_width}x{self.image_height}")

    def sizes_text(self) -> str:
        return ", ".join(f"{width}x{height}" for width, height in self.frame_sizes)

    def to_dict(self) -> dict:
        data = asdict(self)
        if not self.frame_sizes:
            del data["frame_sizes"]  # as summary.json held it before frames had sizes of their own
        return data


# Maps may be stored at another resolution than the configuration's (they are rescaled), but
# not with another shape: that means they cover another part of the frame than configured.
ASPECT_TOLERANCE = 0.10


def check_map_shape(expected: MapGeometry, map_width: int, map_height: int, where: str) -> None:
    """Stop (ConfigError naming `where`) when maps' aspect ratio is not the configured maps'."""
    found = map_width / map_height
    wanted = expected.map_width / expected.map_height
    if abs(found / wanted - 1) <= ASPECT_TOLERANCE:
        return
    last_row = expected.crop_top_px + expected.crop_height_px - 1
    region = (f"image rows {expected.crop_top_px}..{last_row} of the "
              f"{expected.image_width}x{expected.image_height} frame")
    whole = expected.image_width / expected.image_height
    if expected.crop_height_px != expected.image_height and abs(found / whole - 1) <= ASPECT_TOLERANCE:
        fix = ("they look like maps of the whole frame: use a preset for such maps (e.g. scnn-culane) or "
               f"--set maps.crop_top_px=0 --set maps.crop_bottom_px={expected.image_height} "
               f"--set maps.width={map_width} --set maps.height={map_height}")
    else:
        fix = ("use the preset of the model that wrote them, or say which image rows they cover with "
               f"--set maps.crop_top_px=... --set maps.crop_bottom_px=... --set maps.width={map_width} "
               f"--set maps.height={map_height}")
    raise ConfigError(f"{where}: maps are {map_width}x{map_height} (aspect {found:.2f}), but the configuration "
                      f"expects {expected.map_width}x{expected.map_height} maps (aspect {wanted:.2f}) over {region}; "
                      f"{fix}")
