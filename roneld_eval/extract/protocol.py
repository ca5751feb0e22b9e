"""What a lane extractor is: built once per clip, called once per frame, returns a `Prediction`.

An extractor factory is any callable `factory(geometry, params) -> extractor`: `geometry` is
the clip's `MapGeometry` (map size and where the maps sit in the image; `map_to_image` turns
map pixels into image pixels), `params` a dict of its settings. The extractor is a callable
`extractor(maps) -> Prediction`, given each frame's `FrameMaps` in time order. It may set
`stateless = True` when a frame's lanes depend on that frame alone: the runner then calls it
only on the frames it scores. The built-in extractors are registered in `registry`; plug-ins
are found the same way (see README, "Your own extractor").
"""

from __future__ import annotations

import contextlib
import math
import time
from dataclasses import dataclass
from typing import Any, Callable, Mapping, Protocol, Sequence, runtime_checkable

import numpy as np

from ..geometry import MapGeometry
from ..model import FrameMaps, Lane


@dataclass(frozen=True, eq=False)
class Prediction:
    """One frame's output of an extractor, in image pixels.

    `lanes`: every lane found (what the official scores and lane files see). `active`: the
    left and right active (ego) lanes the paper's protocol scores, each one of `lanes` or None;
    an active lane missing from `lanes` is added to them. `spline`: whether the lanes are
    sparse points that the paper's protocol draws through the official cubic spline (as the
    models' own prob2lines output is) rather than as a polyline.
    """

    lanes: tuple[Lane, ...] = ()
    active: tuple[Lane | None, Lane | None] = (None, None)
    spline: bool = False

    def __post_init__(self):
        lanes = tuple(self.lanes) if not isinstance(self.lanes, tuple) else self.lanes
        active = tuple(self.active) if not isinstance(self.active, tuple) else self.active
        present = {id(lane) for lane in lanes}
        extra = tuple(lane for lane in active if lane is not None and id(lane) not in present)
        object.__setattr__(self, "lanes", lanes + extra)
        object.__setattr__(self, "active", active)


@runtime_checkable
class Extractor(Protocol):
    """One clip's extractor: called with each frame's maps in time order."""

    def __call__(self, maps: FrameMaps) -> Prediction: ...


ExtractorFactory = Callable[[MapGeometry, Mapping[str, Any]], Extractor]


_one_time_s = [0.0]


@contextlib.contextmanager
def one_time_work():
    """Work a built-in extractor does once per process, inside a call (an import at first use):
    the runner leaves its seconds out of that call's time (`one_time_seconds`), as it leaves
    out what warm-up does before the first call."""
    start = time.perf_counter()
    try:
        yield
    finally:
        _one_time_s[0] += time.perf_counter() - start


def one_time_seconds() -> float:
    """Seconds of `one_time_work` so far in this process."""
    return _one_time_s[0]


def is_stateless(extractor: object) -> bool:
    """Whether the runner may skip the frames it does not score (`stateless = True`)."""
    return getattr(extractor, "stateless", False) is True


# How far outside the image a point may lie (in image sizes) before the lane is refused: lanes
# that run a little past the border are normal (the official scorer clips them); farther out
# they are a unit or coordinate-system mistake.
OUTSIDE_MARGIN = 1.0


def prediction_problem(prediction: Any, image_width: int, image_height: int) -> str | None:
    """Why an extractor's output cannot be scored (None when it can): a plug-in's output is
    untrusted, and a bad lane must be named, not found later deep inside the scorer."""
    if not isinstance(prediction, Prediction):
        return (f"returned {type(prediction).__name__}, not a roneld_eval.Prediction "
                f"(Prediction(lanes=..., active=(left, right)))")
    if not isinstance(prediction.spline, (bool, np.bool_)):
        return f"spline must be True or False, got {prediction.spline!r}"
    if len(prediction.active) != 2:
        return f"active must be (left, right), got {len(prediction.active)} lanes"
    for index, lane in enumerate(prediction.lanes):
        problem = _lane_problem(lane, image_width, image_height)
        if problem is not None:
            return f"lane {index + 1} of {len(prediction.lanes)}: {problem}"
    return None


def _lane_problem(lane: Any, image_width: int, image_height: int) -> str | None:
    if not isinstance(lane, Lane):
        return f"is a {type(lane).__name__}, not a roneld_eval.Lane"
    if len(lane) < 2:
        return f"has {len(lane)} point{'s' if len(lane) != 1 else ''}; a lane needs at least 2"
    points = lane.points
    if not np.isfinite(points).all():
        return "has NaN or infinite coordinates"
    low_x, high_x = -OUTSIDE_MARGIN * image_width, (1 + OUTSIDE_MARGIN) * image_width
    low_y, high_y = -OUTSIDE_MARGIN * image_height, (1 + OUTSIDE_MARGIN) * image_height
    outside = ((points[:, 0] < low_x) | (points[:, 0] > high_x) | (points[:, 1] < low_y) | (points[:, 1] > high_y))
    if outside.any():
        x, y = points[int(np.argmax(outside))]
        return (f"point ({_number(x)}, {_number(y)}) lies far outside the {image_width}x{image_height} image "
                f"(lanes are in image pixels, not map pixels or normalised units)")
    if min(image_width, image_height) > 4 * NORMALISED_BOX and np.abs(points).max() <= NORMALISED_BOX:
        return (f"every point lies within {NORMALISED_BOX:g} px of the image's corner: lanes are in image pixels "
                f"of the {image_width}x{image_height} image, not normalised units")
    return None


# A lane whose every |coordinate| is at most this many pixels is normalised units by mistake
# (x/W, y/H in [0, 1]): no real lane fits in a 2x2-pixel corner.
NORMALISED_BOX = 2.0


def _number(value: float) -> str:
    return str(int(value)) if math.isfinite(value) and value == int(value) else f"{value:.1f}"


def ego_pair(lanes: Sequence[Lane], image_width: int, image_height: int,
             center_ratio: float) -> tuple[Lane | None, Lane | None]:
    """The lanes nearest the ego position on each side where they meet the image bottom, by
    the rule that picks the ground truth's ego lanes: how a lane list without channel order (a
    detector's output) gets its two active lanes. Lanes of fewer than 2 points are ignored."""
    centre = center_ratio * image_width
    left: tuple[float, Lane] | None = None
    right: tuple[float, Lane] | None = None
    for lane in lanes:
        if len(lane) < 2:
            continue
        x = lane.bottom_x(image_height - 1)
        if x < centre:
            if left is None or x > left[0]:
                left = (x, lane)
        elif right is None or x < right[0]:
            right = (x, lane)
    return (None if left is None else left[1]), (None if right is None else right[1])
