"""LLAMAS (Behrendt & Soussan, ICCV 2019 workshops) as its culane_metric/evaluate.py reads it
(karstenBehrendt/unsupervised_llamas 9b99f46): a label JSON per image,
`<labels>/<recording>/<frame>.json` (the split's folder, walked), whose lane markers become four
lanes (l1, l0, r0, r1) by its label_scripts/spline_creator.py, and predictions as CULane
`.lines.txt` mirroring it (`<recording>/<frame>.lines.txt`).

From a label to the lanes scored, as the code does it:
- read_json (label_file_scripts.py): lanes whose markers' start rows span under 20 px, or with
  fewer than 2 markers, are dropped; ids renamed l0, l1, ... and r0, r1, ... in the sorted order
  of the old ids (a string sort); pixel coordinates cast with int(), world ones with float();
- _extend_lane: the marker nearest the car (smallest world_start z among those whose pixel start
  and end differ in both x and y) is extended to the bottom row 716 (or to the image's left or
  right edge, x = 0 or 1276) by a new first marker, rounded with Python's round() (`ir`); not
  when that z < 0;
- _sample_points: each marker's start row gets its x; a marker over more than 2 rows gets a
  point on every row from start to end (x and y rounded); a row's x is the mean of its points;
  rows between two set rows are filled linearly (each from the row before), rows outside stay -1
  (a row whose mean is exactly -1 counts as unset);
- get_horizontal_values_for_four_lanes: l1, l0, r0, r1 (all -1 when absent); load_labels keeps a
  lane with at least two x >= 0 and add_ys takes its points (x, y) of rows 300..716 with x >= 0.

Where the code stops, here the label is refused naming the problem (or, for a lane whose valid
points all lie above row 300, where add_ys' assert fails, that lane is left out and counted).
"""

from __future__ import annotations

import os
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from ...errors import InputError
from ...json_fields import is_finite_number, shown
from ...lanes_io import FAR_FROM_ORIGIN, MAX_PREDICTED_COORDINATE, parse_json, read_bytes
from ...limits import CONFIG, LANES as LANE_COUNT
from ...model import Clip, Frame, Lane
from ...datasets._paths import check_folder, files_below, under_root

IMAGE_WIDTH, IMAGE_HEIGHT = 1276, 717  # common/constants.py
FIRST_ROW = 300  # add_ys: xs[300:], rows 300..716
MIN_LANE_HEIGHT = 20  # read_json(min_lane_height=20)
MIN_MARKERS = 2  # _filter_few_markers
LANES = ("l1", "l0", "r0", "r1")  # get_horizontal_values_for_four_lanes, left to right
ROWS = 717


def _ir(value: float) -> int:
    """helper_scripts.ir: Python's round (halves to even), then int."""
    return int(round(value))


@dataclass(frozen=True)
class LlamasLabel:
    """The four lanes' x per row (-1 where unset), and the lanes scored (add_ys points)."""

    rows: tuple[tuple[float, ...], ...]  # l1, l0, r0, r1: 717 values each
    lanes: tuple[Lane, ...]  # those with two x >= 0, as (x, y) of rows 300..716 with x >= 0
    dropped_above: int = 0  # lanes whose valid points lie above row 300 (add_ys' assert)


class _Bad(Exception):
    pass


def _number(value, cast, what: str):
    """A marker's coordinate as read_json casts it (int() for pixels, float() for metres). Only a
    JSON number is taken: int() and float() would also read the string "345", which LLAMAS's
    labels never hold (a file that does was not written by its tools), nor a pixel beyond 2^24 px,
    where the sampling's arithmetic leaves a float's range (a 400-digit integer overflows it)."""
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        kind = "a string" if isinstance(value, str) else type(value).__name__
        raise _Bad(f"{what} {shown(value)} is not a number but {kind}: LLAMAS's labels hold JSON numbers")
    if not is_finite_number(value):
        raise _Bad(f"{what} {shown(value)} is not a finite number")
    if cast is int and abs(value) > MAX_PREDICTED_COORDINATE:
        raise _Bad(f"{what} {shown(value)} {FAR_FROM_ORIGIN}: not a pixel coordinate")
    return cast(value)


def _marker(raw) -> dict:
    if not isinstance(raw, dict):
        raise _Bad("a marker is not an object")
    out = {}
    for key, cast in (("pixel_start", int), ("pixel_end", int), ("world_start", float), ("world_end", float)):
        point = raw.get(key)
        axes = ("x", "y") if key.startswith("pixel") else ("x", "y", "z")
        if not isinstance(point, dict) or any(axis not in point for axis in axes):
            raise _Bad(f"a marker's {key} lacks {'/'.join(axes)}")
        out[key] = {axis: _number(point[axis], cast, f"{key}.{axis}") for axis in axes}
    return out


def _lanes_of(record) -> list[dict]:
    """read_json: the lanes kept, renamed, with typed markers."""
    if not isinstance(record, dict) or not isinstance(record.get("lanes"), list):
        raise _Bad("not a LLAMAS label: no list of lanes")
    if "projection_matrix" not in record:
        raise _Bad("not a LLAMAS label: no projection_matrix (read_json needs it)")
    if len(record["lanes"]) > LANE_COUNT.count:
        raise _Bad(LANE_COUNT.problem(len(record["lanes"])))
    lanes = [lane for lane in map(_kept_lane, record["lanes"]) if lane is not None]
    mapping: dict[str, str] = {}
    counters = {"l": 0, "r": 0}
    for key in sorted(lane["lane_id"] for lane in lanes):
        if key[:1] in counters:
            mapping[key] = key[0] + str(counters[key[0]])
            counters[key[0]] += 1
    for lane in lanes:
        if lane["lane_id"] not in mapping:
            raise _Bad(f"lane id {lane['lane_id']!r} starts with neither l nor r")
        lane["lane_id"] = mapping[lane["lane_id"]]
    return lanes


def _kept_lane(raw) -> dict | None:
    """A lane's id and typed markers; None where read_json drops it (too short, too few markers)."""
    if not isinstance(raw, dict) or not isinstance(raw.get("markers"), list) or not isinstance(
            raw.get("lane_id"), str):
        raise _Bad("a lane lacks its lane_id or its list of markers")
    if not raw["markers"]:
        raise _Bad(f"lane {raw['lane_id']!r} has no markers")  # min() of nothing: the code stops
    markers = []
    for number, marker in enumerate(raw["markers"]):
        try:
            markers.append(_marker(marker))
        except _Bad as problem:
            raise _Bad(f"lane {raw['lane_id']!r}, marker {number}: {problem}") from None
    starts = [marker["pixel_start"]["y"] for marker in markers]
    if max(starts) - min(starts) < MIN_LANE_HEIGHT or len(markers) < MIN_MARKERS:
        return None
    return {"lane_id": raw["lane_id"], "markers": markers}


def _extended(markers: list[dict]) -> list[dict]:
    """_extend_lane: a first marker from the nearest one down to the image's bottom or side."""
    usable = [m for m in markers if m["pixel_start"]["y"] != m["pixel_end"]["y"]
              and m["pixel_start"]["x"] != m["pixel_end"]["x"]]
    if not usable:
        raise _Bad("a lane has no marker that is neither horizontal nor vertical (the code stops: min() of nothing)")
    closest = min(usable, key=lambda m: m["world_start"]["z"])
    if closest["world_start"]["z"] < 0:
        return markers
    if closest["world_end"]["z"] == closest["world_start"]["z"]:
        raise _Bad("a marker's world start and end have the same z (the code divides by zero)")
    start, end = closest["pixel_start"], closest["pixel_end"]
    pixel_x_gradient = (end["x"] - start["x"]) / (end["y"] - start["y"])
    pixel_y_gradient = (end["y"] - start["y"]) / (end["x"] - start["x"])
    pixel_zero_x = start["x"] + (716 - start["y"]) * pixel_x_gradient
    if pixel_zero_x < 0:
        point = (0, start["y"] - start["x"] * pixel_y_gradient)
    elif pixel_zero_x > 1276:
        point = (1276, start["y"] + (1276 - start["x"]) * pixel_y_gradient)
    else:
        point = (pixel_zero_x, 716)
    new = {"pixel_start": {"x": _ir(point[0]), "y": _ir(point[1])}, "pixel_end": dict(start)}
    return [new] + markers


def _row(values: list, y: int) -> list:
    """x_values[y] as Python indexes it: a negative row counts from the end; past it the code
    stops (IndexError, where it opens a debugger)."""
    if not -ROWS <= y < ROWS:
        raise _Bad(f"a marker's row {y} lies outside the {ROWS}-row image")
    return values[y]


def sampled_rows(markers: list[dict]) -> list[float]:
    """_sample_points(ypp=1, between_markers=True): the lane's x on each of the 717 rows, -1 unset."""
    x_values: list = [[] for _ in range(ROWS)]
    for marker in markers:
        start, end = marker["pixel_start"], marker["pixel_end"]
        _row(x_values, start["y"]).append(start["x"])
        height = start["y"] - end["y"]
        if height > 2:
            slope = (end["x"] - start["x"]) / height
            step_size = (start["y"] - end["y"]) / float(height)
            for i in range(height + 1):
                x = start["x"] + slope * step_size * i
                y = start["y"] - step_size * i
                _row(x_values, _ir(y)).append(_ir(x))
    for y, xs in enumerate(x_values):
        x_values[y] = -1 if not xs else sum(xs) / float(len(xs))
    current_y = 0
    while current_y < ROWS and x_values[current_y] == -1:
        current_y += 1
    next_set_y = 0
    while current_y < ROWS:
        if x_values[current_y] != -1:
            current_y += 1
            continue
        while next_set_y <= current_y or x_values[next_set_y] == -1:
            next_set_y += 1
            if next_set_y >= ROWS:
                return x_values
        x_values[current_y] = (x_values[current_y - 1] + (x_values[next_set_y] - x_values[current_y - 1])
                               / (next_set_y - current_y + 1))
        current_y += 1
    return x_values


def four_lanes(record) -> list[list[float]]:
    """get_horizontal_values_for_four_lanes of a parsed label: l1, l0, r0, r1."""
    sampled: dict[str, list[float]] = {}
    for lane in _lanes_of(record):
        sampled[lane["lane_id"]] = sampled_rows(_extended(lane["markers"]))
    return [sampled.get(name, [-1] * ROWS) for name in LANES]


def label_lanes(rows: list[list[float]]) -> tuple[tuple[Lane, ...], int]:
    """load_labels: the lanes with two x >= 0, as add_ys' points; and how many add_ys would
    stop at (their valid points all above row 300)."""
    lanes, dropped = [], 0
    for xs in rows:
        if (np.array(xs) >= 0).sum() <= 1:
            continue
        tail = np.array(xs[FIRST_ROW:], dtype=np.float64)
        valid = tail >= 0
        if valid.sum() <= 1:
            dropped += 1
            continue
        lanes.append(Lane.from_xy(tail[valid], np.arange(FIRST_ROW, ROWS)[valid].astype(np.float64)))
    return tuple(lanes), dropped


def read_record(path: Path) -> object:
    """A label file's JSON value (InputError naming it when it is not JSON)."""
    data = read_bytes(path, limit=CONFIG)
    assert data is not None
    return parse_json(data, path, "not a LLAMAS label", "not a LLAMAS label")


def label_of(record, path: Path) -> LlamasLabel:
    """A label's lanes as the spline creator makes them (InputError naming the file where the
    code would stop)."""
    try:
        rows = four_lanes(record)
    except _Bad as problem:
        raise InputError(path, str(problem)) from None
    lanes, dropped = label_lanes(rows)
    return LlamasLabel(tuple(tuple(r) for r in rows), lanes, dropped)


def read_label(path: Path) -> LlamasLabel:
    """One label file's lanes (InputError naming it where the code would stop)."""
    return label_of(read_record(path), path)


@dataclass(frozen=True)
class MarkerLane:
    """A lane as read_json leaves it (filtered, renamed l0, l1, ... r0, r1, ...): its markers'
    world start and end points (x, y, z), what the segmentation labels are drawn from."""

    lane_id: str
    markers: tuple[tuple[tuple[float, float, float], tuple[float, float, float]], ...]


def marker_lanes(record, path: Path) -> tuple[np.ndarray, tuple[MarkerLane, ...]]:
    """read_json's projection matrix (a 3x3 array of numbers) and lanes, for the segmentation
    labels (InputError naming the file where the code would stop)."""
    try:
        lanes = _lanes_of(record)
        assert isinstance(record, dict)
        matrix = _checked_projection(record["projection_matrix"])
    except _Bad as problem:
        raise InputError(path, str(problem)) from None
    exact = np.asarray(matrix)  # as project_point makes it: int64 when every entry is an integer
    out = []
    for lane in lanes:
        out.append(MarkerLane(lane["lane_id"], tuple(
            (tuple(m["world_start"][a] for a in "xyz"), tuple(m["world_end"][a] for a in "xyz"))
            for m in lane["markers"])))
    return exact, tuple(out)


def _checked_projection(matrix):
    """A 3x3 list of finite numbers whose last row is not all zeros."""
    if (not isinstance(matrix, list) or len(matrix) != 3
            or any(not isinstance(row, list) or len(row) != 3 for row in matrix)):
        raise _Bad("projection_matrix is not a 3x3 list of numbers")
    values = [v for row in matrix for v in row]
    # numpy.asarray takes the lists as they are (no float() as for the markers): numbers only
    if any(not is_finite_number(v) or abs(v) >= 2**63 for v in values):
        raise _Bad("projection_matrix holds an entry that is not a finite number")
    if not any(matrix[2]):  # project_point divides by the third coordinate: 0 for every point
        raise _Bad("projection_matrix's last row is all zeros, so every point projects to a division by "
                   "zero and no marker is drawn: not a camera's projection")
    return matrix


def frame_key(relative: str) -> str:
    """What a label is known by: its last two path parts without .json (evaluate.py's
    get_label_base), `<recording>/<frame>`; its prediction is pred_dir/<key>.lines.txt."""
    return "/".join(relative.split("/")[-2:])[:-len(".json")]


def every_label(labels: Path) -> dict[str, Path]:
    """key -> label file for every .json below `labels` (load_labels walks the folder), sorted by key."""
    check_folder(labels, "label folder not found (expected <recording>/<frame>.json below it)")
    found: dict[str, Path] = {}
    for relative in files_below(labels, ".json"):
        path = labels / relative
        key = frame_key(relative)
        if key in found:
            raise InputError(path, f"a second label known as {key} (first: {found[key]}): evaluate.py pairs "
                                   "a label with pred_dir/<recording>/<frame>.lines.txt, so both would be scored "
                                   "against one prediction; give one split's folder")
        found[key] = path
    if not found:
        raise InputError(labels, "no .json label below this folder: is it LLAMAS's labels/<split>?")
    return dict(sorted(found.items()))


def prediction_path(root: Path, key: str) -> Path:
    return under_root(root, f"{key}.lines.txt")


def map_path(root: Path, key: str, channel: int) -> Path:
    """A class's probability map as evaluate_segmentation.py names it: <key>.json_<channel>.png
    (0 background, 1..4 l1, l0, r0, r1)."""
    return under_root(root, f"{key}.json_{channel}.png")


def read_llamas_run(root: Path, limit: int | None) -> list[tuple[str, tuple[Frame, ...]]]:
    """(recording, its frames in time order) for `run`: every label below `root`, labels not yet
    read (`with_labels`). A frame's relpath is its label's path below the root, so that maps
    mirror the labels: <maps-root>/<recording>/<frame>.json_<c>.png."""
    found = every_label(root)
    clips: dict[str, list[Frame]] = {}
    for key, path in found.items():  # sorted by key: a recording's frames by their time stamps
        relpath = os.path.relpath(path, root).replace(os.sep, "/")
        clips.setdefault(key.split("/")[0], []).append(Frame(relpath=relpath))
    return [(name, tuple(frames)) for name, frames in list(clips.items())[:limit]]


def with_labels(clip: Clip, root: Path, errors: list[InputError] | None) -> Clip:
    """The clip with its frames' lanes (bad labels left out and appended to `errors`, if given)."""
    frames = []
    for frame in clip.frames:
        try:
            label = read_label(under_root(root, frame.relpath))
        except InputError as error:
            if errors is None:
                raise
            errors.append(error)
            continue
        frames.append(replace(frame, lanes=label.lanes))
    return replace(clip, frames=tuple(frames))
