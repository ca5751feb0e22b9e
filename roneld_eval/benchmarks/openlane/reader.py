"""OpenLane's 2D lanes (OpenDriveLab/OpenLane, eval/LANE_evaluation/lane2d, 8a0ce6b) as its
evaluator reads them: one JSON file per image, `<segment>/<frame>.json`, whose `lane_lines` each
hold a `category` and `uv` ([[u...], [v...]], image pixels). As src/evaluate.cpp:277-303 does it:
a lane of fewer than two points is left out (not counted), points are sorted by v, coordinates
kept as float32 (cv::Point2f). A missing file means no lanes; where the C++ parser would read a
broken file as no lanes, or an absent category or a short v list as undefined values, the file
is refused here with its problem named.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ...errors import InputError
from ...json_fields import is_finite_number, shown
from ...limits import LANES
from ...lanes_io import check_coordinates, decode_text, parse_json, read_bytes
from ...model import Lane, image_stem
from ...datasets._paths import read_image_list, check_folder, files_below, frame_sort_key, under_root

IMAGE_WIDTH, IMAGE_HEIGHT = 1920, 1280  # evaluate.cpp:125-126 (-c, -r): the canvas every frame is drawn on


@dataclass(frozen=True)
class OpenLaneLanes:
    """A frame's lanes as the evaluator keeps them, and each lane's category (None where absent)."""

    lanes: tuple[Lane, ...]
    categories: tuple[int | None, ...]


def json_path(root: Path, relpath: str) -> Path:
    return under_root(root, f"{image_stem(relpath)}.json")


def read_list(path: Path) -> list[str]:
    """The images to score, as test_list.txt names them (`<segment>/<frame>.jpg`)."""
    return read_image_list(path, keep_suffix=True)


def every_labelled_frame(labels: Path) -> list[str]:
    """`<segment>/<frame>.jpg` for every `<segment>/<frame>.json` below `labels`, sorted."""
    check_folder(labels, "annotation folder not found")
    entries = [relpath[:-len(".json")] + ".jpg" for relpath in files_below(labels, ".json", frame_sort_key)]
    if not entries:
        raise InputError(labels, "no <segment>/<frame>.json here: is this OpenLane's lane2d annotation folder?")
    return entries


def read_lanes(path: Path, need_categories: bool = True) -> OpenLaneLanes:
    """One frame's lanes; a missing file is a frame without lanes."""
    data = read_bytes(path, missing_ok=True)
    if data is None:
        return OpenLaneLanes((), ())
    record = parse_json(decode_text(data, path), path, "not JSON", "not an OpenLane file")
    return lanes_of_record(record, path, need_categories)


def lanes_of_record(record, path, need_categories: bool = True) -> OpenLaneLanes:
    """The lanes of one frame's JSON object (`lane_lines`), as the evaluator keeps them; `path`
    names it in errors."""
    lines = record.get("lane_lines", []) if isinstance(record, dict) else None
    if not isinstance(lines, list):
        raise InputError(path, "`lane_lines` must be a list of lanes")
    if len(lines) > LANES.count:
        raise InputError(path, LANES.problem(len(lines)))
    lanes, categories = [], []
    for index, line in enumerate(lines):
        points = _points(line, path, index)
        if len(points) < 2:
            continue  # evaluate.cpp:285-287: not a lane
        category = line.get("category") if isinstance(line, dict) else None
        if category is not None and (not is_finite_number(category) or abs(category) >= 2**31):
            raise InputError(path, f"lane {index}: `category` must be a number, got {shown(category)}")
        if category is None and need_categories:
            raise InputError(path, f"lane {index} has no `category` (the evaluator would read an undefined value); "
                                   "score with any category only (--any-category)")
        order = np.argsort(points[:, 1], kind="stable")  # std::sort by v (evaluate.cpp:296, lessmark)
        lanes.append(Lane(points[order].astype(np.float64)))
        # read as an int (a float truncated, as CJsonObject's Get), kept as uint8 (evaluate.cpp:298-299)
        categories.append(None if category is None else int(category) % 256)
    check_coordinates(lanes, path)  # labels and predictions alike: drawn by the same spline
    return OpenLaneLanes(tuple(lanes), tuple(categories))


def _points(line, path: Path, index: int) -> np.ndarray:
    uv = line.get("uv") if isinstance(line, dict) else None
    if uv is None:
        return np.zeros((0, 2), np.float32)
    if (not isinstance(uv, list) or len(uv) != 2 or not all(isinstance(part, list) for part in uv)
            or len(uv[1]) < len(uv[0])):
        raise InputError(path, f"lane {index}: `uv` must be [[u, ...], [v, ...]] with a v for every u")
    values = uv[0] + uv[1][:len(uv[0])]
    if not all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in values):
        raise InputError(path, f"lane {index}: `uv` holds something other than numbers")
    n = len(uv[0])
    not_finite = InputError(path, f"lane {index}: `uv` holds a value that is not a finite float32")
    try:
        with np.errstate(over="ignore"):
            points = np.array([uv[0], uv[1][:n]], np.float64).T.astype(np.float32)  # cv::Point2f
    except OverflowError:  # an integer beyond a float's range (JSON allows 400 digits)
        raise not_finite from None
    if not np.isfinite(points).all():
        raise not_finite
    return points
