"""OpenLane 3D's files as its lane3d evaluator reads them (OpenDriveLab/OpenLane 8a0ce6b,
eval/LANE_evaluation/lane3d/eval_3D_lane.py `bench_one_submit`): one JSON file per image under the
annotation and the results folders, named by the list's `<segment>/<frame>.jpg` with `jpg` made
`json`. A label holds `file_path`, the camera's 4 x 4 `extrinsic` and `lane_lines`, each with `xyz`
([[x...], [y...], [z...]], camera coordinates), `visibility` (one value a point) and `category`; a
result holds `file_path` and `lane_lines`, each with `xyz` ([[x, y, z], ...], ground coordinates)
and `category`. A result is paired with the label of its own `file_path`, as the evaluator pairs
them. Where the evaluator would stop with a traceback, or read a value it cannot use, the file is
refused here with its problem named.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from ...datasets._paths import read_image_list, under_root
from ...errors import InputError
from ...json_fields import is_finite_number, shown
from ...lanes_io import decode_text, finite_numbers, numpy_array_of, parse_json, read_bytes
from ...limits import LANES
from ...model import image_stem

MAX_POINTS = 1 << 16  # of one lane


@dataclass(frozen=True)
class Truth:
    """A label: its `file_path`, extrinsic, and each lane's points (3 x N), visibility and category."""

    key: str
    extrinsic: np.ndarray
    lanes: tuple[np.ndarray, ...]
    visibility: tuple[np.ndarray, ...]
    categories: tuple[int | float, ...]


@dataclass(frozen=True)
class Predicted:
    """A result: its `file_path`, and each lane's points (N x 3, or N x 2) and category."""

    key: str | None  # None for a frame without a result file (no lanes)
    lanes: tuple[np.ndarray, ...]
    categories: tuple[int, ...]


def json_path(root: Path, relpath: str) -> Path:
    return under_root(root, f"{image_stem(relpath)}.json")


def read_list(path: Path) -> list[str]:
    """The images to score, as test_list.txt names them (`<segment>/<frame>.jpg`)."""
    return read_image_list(path, keep_suffix=True)


def _record(path: Path, lanes_key: str = "lane_lines") -> dict:
    record = parse_json(decode_text(read_bytes(path), path), path, "not JSON", "not an OpenLane 3D file")
    if not isinstance(record, dict):
        raise InputError(path, "not an OpenLane 3D file: a JSON object is expected")
    key = record.get("file_path")
    if not isinstance(key, str):
        raise InputError(path, "has no `file_path` text (the evaluator pairs a result with its label by it)")
    lines = record.get(lanes_key)
    if not isinstance(lines, list):
        other = {"lane_lines": ("laneLines", "persformer-train"), "laneLines": ("lane_lines", "file")}[lanes_key]
        hint = (f" (it holds `{other[0]}`: give --protocol {other[1]})" if other[0] in record
                else " (is this a folder of results, mirroring --labels?)" if "extrinsic" in record else "")
        raise InputError(path, f"`{lanes_key}` must be a list of lanes{hint}")
    if len(lines) > LANES.count:
        raise InputError(path, LANES.problem(len(lines)))
    return record


def _numbers(values, path: Path, what: str) -> np.ndarray:
    """A list (of equally long lists) of finite JSON numbers as a float array, as NumPy makes one of
    them for the evaluator (true and false are 1 and 0 there too); text, null, numbers beyond a
    float's range and ragged lists are refused."""
    array = numpy_array_of(values)
    if not finite_numbers(array):
        raise InputError(path, f"{what}: something other than finite numbers")
    return array.astype(float)


def _category(line: dict, path: Path, index: int) -> int | float:
    category: Any = line.get("category")
    if not is_finite_number(category) or abs(category) >= 2**63:
        raise InputError(path, f"lane {index}: `category` must be a number, got {shown(category)}")
    return category


def read_truth(path: Path) -> Truth:
    """One label, checked as the evaluator would need it."""
    record = _record(path)
    extrinsic = record.get("extrinsic")
    if not (isinstance(extrinsic, list) and len(extrinsic) == 4
            and all(isinstance(row, list) and len(row) == 4 for row in extrinsic)):
        raise InputError(path, "`extrinsic` must be a 4 x 4 matrix")
    matrix = _numbers(extrinsic, path, "`extrinsic`")
    read = [_truth_lane(line, path, index) for index, line in enumerate(record["lane_lines"])]
    return Truth(record["file_path"], matrix, tuple(lane[0] for lane in read), tuple(lane[1] for lane in read),
                 tuple(lane[2] for lane in read))


def _truth_lane(line, path: Path, index: int) -> tuple[np.ndarray, np.ndarray, int | float]:
    """A label's lane: its points (3 x N), visibility (N) and category."""
    where = f"lane {index}"
    xyz = line.get("xyz") if isinstance(line, dict) else None
    if not (isinstance(xyz, list) and len(xyz) == 3 and all(isinstance(row, list) for row in xyz)
            and len({len(row) for row in xyz}) == 1 and len(xyz[0]) <= MAX_POINTS):
        raise InputError(path, f"{where}: `xyz` must be [[x, ...], [y, ...], [z, ...]] of equal lengths")
    points = _numbers(xyz, path, f"{where}: `xyz`")
    visible = line.get("visibility")
    if not isinstance(visible, list) or len(visible) != points.shape[1]:
        raise InputError(path, f"{where}: `visibility` must hold one value for each of its {points.shape[1]} points")
    return points, _numbers(visible, path, f"{where}: `visibility`"), _category(line, path, index)


def read_prediction(path: Path, prob_threshold: float | None = None) -> Predicted:
    """One result, checked as the evaluator would need it; a missing file is a frame without lanes.
    With `prob_threshold`, in the form PersFormer's training-time evaluation takes
    (`bench_one_submit_openlane_DDP`): `laneLines` and `laneLines_prob`, a lane kept when its
    highest class probability is above the threshold, its category the first highest."""
    if read_bytes(path, missing_ok=True) is None:
        return Predicted(None, (), ())
    if prob_threshold is not None:
        return _read_with_probabilities(path, prob_threshold)
    record = _record(path)
    lanes, categories = [], []
    for index, line in enumerate(record["lane_lines"]):
        lanes.append(_predicted_points(line.get("xyz") if isinstance(line, dict) else None, path, index))
        categories.append(int(_category(line, path, index)))  # int(lane['category'])
    return Predicted(record["file_path"], tuple(lanes), tuple(categories))


def _predicted_points(xyz, path: Path, index: int) -> np.ndarray:
    if not (isinstance(xyz, list) and 0 < len(xyz) <= MAX_POINTS and all(isinstance(p, list) for p in xyz)
            and len({len(p) for p in xyz}) == 1 and len(xyz[0]) in (2, 3)):
        raise InputError(path, f"lane {index}: its points must be a list of [x, y, z] (at least one)")
    return _numbers(xyz, path, f"lane {index}: its points")


def _read_with_probabilities(path: Path, prob_threshold: float) -> Predicted:
    record = _record(path, "laneLines")
    probabilities = record.get("laneLines_prob")
    if not isinstance(probabilities, list) or len(probabilities) != len(record["laneLines"]):
        raise InputError(path, "`laneLines_prob` must hold one list of class probabilities for each lane of "
                               "`laneLines`")
    probs = _numbers(probabilities, path, "`laneLines_prob`") if probabilities else np.zeros((0, 1))
    if probs.ndim != 2 or probs.shape[1] == 0:
        raise InputError(path, "`laneLines_prob` must hold lists of class probabilities of one length")
    kept = [k for k in range(len(probs)) if max(probs[k]) > prob_threshold]
    lanes = tuple(_predicted_points(record["laneLines"][k], path, k) for k in kept)
    categories = tuple(int(c) for c in np.argmax(probs[kept], 1)) if kept else ()
    return Predicted(record["file_path"], lanes, categories)
