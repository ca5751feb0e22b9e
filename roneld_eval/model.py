"""Small frozen records every stage shares: lanes, frames, clips, datasets and map stacks.

Coordinates are image pixels unless a name says otherwise: x is the column, y the row, and
y grows downwards. Nothing here reads files or computes metrics.
"""

from __future__ import annotations

import posixpath
from dataclasses import dataclass, field
from pathlib import Path
from typing import Mapping

import numpy as np


def _frozen_array(values, dtype, shape_tail: tuple[int, ...], what: str) -> np.ndarray:
    array = np.array(values, dtype=dtype, copy=True)
    if array.size == 0:
        array = array.reshape((0,) + shape_tail)
    if array.ndim != 1 + len(shape_tail) or array.shape[1:] != shape_tail:
        raise ValueError(f"{what} must have shape (N, {', '.join(map(str, shape_tail))}), got {array.shape}")
    array.flags.writeable = False
    return array


@dataclass(frozen=True, eq=False)
class Lane:
    """One lane as a polyline: an (N, 2) float64 array of (x, y) image pixels.

    Points keep the order in which the lane was produced or read: files of the official
    formats list CULane lanes bottom to top, the baseline extractor does the same (as SCNN's
    prob2lines), and RONELD emits top to bottom. The order matters only to the official CULane
    scorer, whose spline numerics we reproduce bit for bit; `top_to_bottom()` gives the
    canonical order. A lane may hold fewer than two points: the official protocol counts such
    a lane (with IoU 0) rather than dropping it.
    """

    points: np.ndarray

    def __post_init__(self):
        object.__setattr__(self, "points", _frozen_array(self.points, np.float64, (2,), "Lane points"))

    @classmethod
    def from_xy(cls, xs, ys) -> "Lane":
        """Build a lane from separate x and y sequences."""
        return cls(np.stack([np.asarray(xs, np.float64), np.asarray(ys, np.float64)], axis=1))

    @property
    def xs(self) -> np.ndarray:
        return self.points[:, 0]

    @property
    def ys(self) -> np.ndarray:
        return self.points[:, 1]

    def __len__(self) -> int:
        return len(self.points)

    def bottom_x(self, bottom_row: float) -> float:
        """x where the line through the lane's two lowest points meets `bottom_row` (2+ points):
        where a lane meets the image bottom, which says on which side of the car it lies."""
        order = self.points[:, 1].argsort(kind="stable")
        (x1, y1), (x2, y2) = self.points[order[-2]], self.points[order[-1]]
        if y2 == y1:
            return float(x2)
        return float(x2 + (bottom_row - y2) * (x2 - x1) / (y2 - y1))

    def top_to_bottom(self) -> "Lane":
        """The same lane with its points sorted by increasing y (stable)."""
        order = np.argsort(self.points[:, 1], kind="stable")
        return Lane(self.points[order])

    def scaled(self, sx: float, sy: float, dx: float = 0.0, dy: float = 0.0) -> "Lane":
        """x*sx + dx, y*sy + dy for every point."""
        return Lane(self.points * np.array([sx, sy]) + np.array([dx, dy]))

    def __repr__(self) -> str:
        return f"Lane({len(self)} points)"


def read_only(array: np.ndarray) -> np.ndarray:
    """The array itself if it cannot be written, else a read-only view of it."""
    if not array.flags.writeable:
        return array
    view = array.view()
    view.flags.writeable = False
    return view


def image_stem(relpath: str) -> str:
    """An image path without its extension, cut at the last '.' of the file name only.

    Every file of a frame (labels, maps) is named by this stem: ``d/05.MP4/00000.jpg`` ->
    ``d/05.MP4/00000``; ``d/05.MP4/00000`` (no extension) stays whole; a name that starts
    with its only dot (``d/.png``) has no extension.
    """
    return posixpath.splitext(relpath)[0]


@dataclass(frozen=True, slots=True)
class Frame:
    """One video frame: where it lies in the dataset, and its ground truth when labelled.

    `relpath` is the image path relative to the dataset root, with forward slashes and no
    leading slash (``driver_37_30frame/05181432_0203.MP4/00000.jpg``). `lanes` are all the
    ground-truth lanes of the frame in file order; `h_samples` are the TuSimple label rows.
    `image_size` is (width, height) where a benchmark's frames come in several sizes (VIL-100
    scores each video at its own); None: the dataset's one size.
    """

    relpath: str
    lanes: tuple[Lane, ...] = ()
    labelled: bool = True
    h_samples: tuple[int, ...] | None = None
    image_size: tuple[int, int] | None = None

    @property
    def stem(self) -> str:
        """`relpath` without its image extension (see `image_stem`)."""
        return image_stem(self.relpath)


@dataclass(frozen=True)
class Clip:
    """A video clip: its id (the folder of its frames) and its frames in time order."""

    clip_id: str
    frames: tuple[Frame, ...]

    @property
    def labelled_frames(self) -> tuple[Frame, ...]:
        return tuple(frame for frame in self.frames if frame.labelled)


@dataclass(frozen=True)
class Dataset:
    """A benchmark as read from disk, normalised so that later stages need not know which."""

    name: str
    root: Path
    image_width: int
    image_height: int
    clips: tuple[Clip, ...]
    # category name -> relpaths of the frames it holds (CULane's test_split lists)
    categories: Mapping[str, frozenset[str]] = field(default_factory=dict)
    source_file: Path | None = None
    # False when frames do not carry their lanes yet (CULane read with labels=False: each
    # clip's labels are read where the clip is evaluated).
    labels_loaded: bool = True

    @property
    def frame_sizes(self) -> tuple[tuple[int, int], ...]:
        """The frames' own sizes, largest first, where they have them (else empty)."""
        sizes = {frame.image_size for clip in self.clips for frame in clip.frames if frame.image_size is not None}
        return tuple(sorted(sizes, key=lambda size: (-size[0] * size[1], size)))

    @property
    def n_frames(self) -> int:
        return sum(len(clip.frames) for clip in self.clips)

    @property
    def n_labelled(self) -> int:
        return sum(len(clip.labelled_frames) for clip in self.clips)


# Channels of the two ego lanes in SCNN/ENet-SAD's lane order (outer left, ego left, ego right,
# outer right): the models' own active lanes, and the lanes RONELD weighs e^2 more.
EGO_CHANNELS = (1, 2)


@dataclass(frozen=True, eq=False)
class FrameMaps:
    """The lane probability maps of one frame.

    `probabilities` is a (C, H, W) uint8 array, 0..255 = probability * 255, lane channels
    only (background dropped), channel 0 the outermost left lane. It may be a read-only
    memory map. `existence` holds the model's per-channel lane existence in [0, 1] when the
    stored output has it, else None. `lanes` are the lanes the maps were drawn from when they
    come from another detector's lane files (`--maps-format lanes`): that detector's own output.
    """

    probabilities: np.ndarray
    existence: np.ndarray | None = None
    lanes: tuple[Lane, ...] | None = None

    @property
    def n_channels(self) -> int:
        return self.probabilities.shape[0]

    @property
    def height(self) -> int:
        return self.probabilities.shape[1]

    @property
    def width(self) -> int:
        return self.probabilities.shape[2]
