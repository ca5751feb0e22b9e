"""CurveLanes (Xu et al., ECCV 2020) as CondLaneNet's metric reads it: one `<name>.lines.json` per
image, `{"Lines": [[{"x": "..", "y": ".."}, ...], ...]}` (values as strings or numbers, image
pixels), each image at its own size (read from its file's header). A prediction file is the same,
a lane optionally `{"points": [...], "score": s}`: kept when its score is above the threshold
(LaneMetricCore.__call__); lanes without points are not lanes.
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass
from pathlib import Path

from ...errors import InputError
from ...json_fields import shown
from ...limits import LANES
from ...image_header import image_file_size
from ...lanes_io import decode_text, parse_json, read_bytes
from ...model import image_stem
from ...datasets._paths import read_image_list, check_folder, files_below, under_root

SUFFIX = ".lines.json"
IMAGE_SUFFIXES = (".jpg", ".png", ".jpeg")
MAX_SIDE = 16384

Point = tuple[float, float]


@dataclass(frozen=True)
class CurveLanesFrame:
    lanes: tuple[tuple[Point, ...], ...]
    scores: tuple[float | None, ...]


def lanes_path(root: Path, relpath: str) -> Path:
    return under_root(root, image_stem(relpath) + SUFFIX)


def read_list(path: Path) -> list[str]:
    """The images to score, `<name>.jpg` a line (kept without the extension)."""
    return read_image_list(path, keep_suffix=False)


def every_labelled_image(labels: Path) -> list[str]:
    check_folder(labels, "label folder not found")
    entries = [relpath[:-len(SUFFIX)] for relpath in files_below(labels, SUFFIX)]
    if not entries:
        raise InputError(labels, f"no <name>{SUFFIX} here: is this CurveLanes' labels folder?")
    return entries


def read_frame(path: Path, missing_ok: bool) -> CurveLanesFrame:
    data = read_bytes(path, missing_ok=missing_ok)
    if data is None:
        return CurveLanesFrame((), ())
    record = parse_json(decode_text(data, path), path, "not JSON", "not a CurveLanes file")
    return frame_of_record(record, path)


def frame_of_record(record, path) -> CurveLanesFrame:
    """One image's lanes (and scores) from its `.lines.json` object; `path` names it in errors."""
    lines = record.get("Lines") if isinstance(record, dict) else None
    if not isinstance(lines, list):
        raise InputError(path, "`Lines` must be a list of lanes")
    if len(lines) > LANES.count:
        raise InputError(path, LANES.problem(len(lines)))
    lanes, scores = [], []
    for index, line in enumerate(lines):
        score = None
        if isinstance(line, dict):
            if "score" not in line or not isinstance(line.get("points"), list):
                raise InputError(path, f"lane {index}: a lane is a list of points, or "
                                       "{\"points\": [...], \"score\": s}")
            score = _number(line["score"], path, index, "score")
            line = line["points"]
        if not isinstance(line, list):
            raise InputError(path, f"lane {index}: a lane is a list of points")
        points = tuple(_point(point, path, index) for point in line)
        if points:
            lanes.append(points)
            scores.append(score)
    return CurveLanesFrame(tuple(lanes), tuple(scores))


def _number(value, path: Path, index: int, what: str) -> float:
    try:
        number = float(value) if isinstance(value, (str, int, float)) and not isinstance(value, bool) else None
    except (ValueError, OverflowError):  # OverflowError: an integer beyond a float's range (JSON allows 400 digits)
        number = None
    if number is None or not math.isfinite(number) or abs(number) > 1e7:
        raise InputError(path, f"lane {index}: {what} {shown(value)} is not a finite number of pixels")
    return number


def _point(point, path: Path, index: int) -> Point:
    if not isinstance(point, dict) or "x" not in point or "y" not in point:
        raise InputError(path, f"lane {index}: a point is {{\"x\": .., \"y\": ..}}, got {point!r:.60}")
    return _number(point["x"], path, index, "x"), _number(point["y"], path, index, "y")


def image_size(root: Path, relpath: str) -> tuple[int, int]:
    for suffix in IMAGE_SUFFIXES:
        path = under_root(root, relpath + suffix)
        if os.path.lexists(path):  # there: a folder or a FIFO is refused as such
            size = image_file_size(path)
            if not all(1 <= side <= MAX_SIDE for side in size):
                raise InputError(path, f"image of {size[0]}x{size[1]}: sides of 1..{MAX_SIDE} px are scored")
            return size
    raise InputError(under_root(root, relpath + IMAGE_SUFFIXES[0]), "image not found (needed for its size)")
