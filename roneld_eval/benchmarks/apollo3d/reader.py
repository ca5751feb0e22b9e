"""Apollo 3D Synthetic's files as Gen-LaneNet's evaluator reads them (45c6cc4,
tools/eval_3D_lane.py): JSON lines, one frame a line. A label holds `raw_file`, `laneLines` (each
lane a list of [x, y, z] points in ground coordinates, metres: x right, y forward, z up) with
`laneLines_visibility` (a value a point), and `centerLines` with `centerLines_visibility`; a
prediction holds `raw_file`, `laneLines` with `laneLines_prob` (a probability a lane), and
`centerLines` with `centerLines_prob`. Predictions are paired with labels by `raw_file`, exactly
as written. Where the evaluator would stop with a traceback, or pair frames it should not (a frame
predicted twice and another never), the file is refused here, naming the line and the problem.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from ...errors import InputError
from ...json_fields import RepeatedKey, is_finite_number, loads, shown
from ...lanes_io import finite_numbers, numpy_array_of, read_text, split_lines
from ...limits import JSON_LINES, LANES
from .official import THRESHOLDS

LOWEST_THRESHOLD = float(THRESHOLDS[0])

MAX_POINTS = 1 << 16  # of one lane
KEYS = {"laneline": ("laneLines", "laneLines_visibility", "laneLines_prob"),
        "centerline": ("centerLines", "centerLines_visibility", "centerLines_prob")}
KEYS_OF = {keys[2]: keys[0] for keys in KEYS.values()}  # a probability list's lanes


@dataclass(frozen=True)
class Truth:
    """A label line: each lane type's lanes (N x 3) and their points' visibility (None: the label
    has no such lanes)."""

    lanes: dict[str, tuple[np.ndarray, ...] | None]
    visibility: dict[str, tuple[np.ndarray, ...] | None]


@dataclass(frozen=True)
class Predicted:
    """A prediction line: each lane type's lanes (N x 3, or N x 2) and probabilities (None: the line
    has no such lanes)."""

    lanes: dict[str, tuple[np.ndarray, ...] | None]
    probabilities: dict[str, np.ndarray | None]


def records(path: Path) -> list[tuple[int, str, dict[str, Any]]]:
    """(line number, raw_file, record) of every line of a JSON-lines file, in order. A blank line
    is refused: the evaluator counts lines, and stops on one that is not JSON."""
    text = read_text(path, JSON_LINES)
    found = []
    for number, line in enumerate(split_lines(text), start=1):
        if not line.strip():
            raise InputError(path, "a blank line (the evaluator reads every line as a frame)", line=number)
        try:
            record = loads(line)
        except RepeatedKey as error:
            raise InputError(path, str(error), line=number) from None
        except RecursionError:
            raise InputError(path, "not an Apollo 3D line: nested too deeply", line=number) from None
        except ValueError:
            raise InputError(path, "not JSON (one JSON object a line is expected)", line=number) from None
        if not isinstance(record, dict) or not isinstance(record.get("raw_file"), str):
            raise InputError(path, "not an Apollo 3D line: a JSON object with a `raw_file` text is expected",
                             line=number)
        found.append((number, record["raw_file"], record))
    if not found:
        raise InputError(path, "holds no frame")
    return found


def _lanes(record: dict, key: str, path: Path, number: int) -> tuple[np.ndarray, ...] | None:
    lanes = record.get(key)
    if lanes is None and key not in record:
        return None
    if not isinstance(lanes, list):
        raise InputError(path, f"`{key}` must be a list of lanes", line=number)
    if len(lanes) > LANES.count:
        raise InputError(path, LANES.problem(len(lanes)), line=number)
    return tuple(_points(lane, path, number, f"{key}[{k}]") for k, lane in enumerate(lanes))


def _points(lane: Any, path: Path, number: int, where: str) -> np.ndarray:
    """A lane's [x, y, z] (or [x, y]) points as an N x 3 (N x 2) float array, as NumPy makes one of
    them for the evaluator (true and false are 1 and 0 there too); text, null, numbers beyond a
    float's range and ragged lists are refused."""
    if not isinstance(lane, list):
        raise InputError(path, f"{where}: must be a list of [x, y, z] points", line=number)
    if len(lane) > MAX_POINTS:
        raise InputError(path, f"{where}: {len(lane):,} points, more than the {MAX_POINTS:,} a lane may have here",
                         line=number)
    array = numpy_array_of(lane) if lane else np.zeros((0, 3))
    if array.ndim != 2 or array.shape[1] not in (2, 3):
        raise InputError(path, f"{where}: must be a list of [x, y, z] points", line=number)
    if not finite_numbers(array):
        raise InputError(path, f"{where}: something other than finite numbers", line=number)
    return array.astype(float)


def _values(record: dict, key: str, count: int, path: Path, number: int, what: str) -> list:
    values = record.get(key)
    if not isinstance(values, list) or len(values) != count:
        raise InputError(path, f"`{key}` must hold {what} for each of its {count} lanes", line=number)
    return values


def _by_type(record: dict, path: Path, number: int, column: int, read) -> tuple[dict, dict]:
    """Each lane type's lanes (None where the line has none), and what `read` makes of the list
    under KEYS[type][column] for them (their visibility or probabilities)."""
    lanes: dict[str, tuple[np.ndarray, ...] | None] = {}
    values: dict[str, Any] = {}
    for kind, keys in KEYS.items():
        lanes[kind] = found = _lanes(record, keys[0], path, number)
        values[kind] = None if found is None else read(found, keys[column])
    return lanes, values


def truth_of(record: dict, path: Path, number: int) -> Truth:
    """A label line's lanes and visibility."""
    def visibility(found: tuple[np.ndarray, ...], key: str) -> tuple[np.ndarray, ...]:
        checked = []
        for k, (lane, values) in enumerate(zip(found, _values(record, key, len(found), path, number,
                                                              "a visibility list"))):
            array = numpy_array_of(values) if isinstance(values, list) else np.zeros(0, dtype=object)
            if not finite_numbers(array) or array.shape != (len(lane),):
                raise InputError(path, f"`{key}`[{k}] must hold a number for each of its lane's {len(lane)} points",
                                 line=number)
            checked.append(array.astype(float))
        return tuple(checked)

    truth = Truth(*_by_type(record, path, number, 1, visibility))
    if truth.lanes["laneline"] is None:
        raise InputError(path, "has no `laneLines` (the evaluator stops on it)", line=number)
    return truth


def prediction_of(record: dict, path: Path, number: int) -> Predicted:
    """A prediction line's lanes and their probabilities (a lane the sweep may keep of two points or more)."""
    def probabilities(found: tuple[np.ndarray, ...], key: str) -> np.ndarray:
        values = _values(record, key, len(found), path, number, "a probability")
        bad = next((v for v in values if not is_finite_number(v)), None)
        if bad is not None:
            raise InputError(path, f"`{key}` holds {shown(bad)}, not a probability", line=number)
        short = next((k for k, lane in enumerate(found) if len(lane) < 2 and values[k] > LOWEST_THRESHOLD), None)
        if short is not None:  # one below every threshold is never compared, and may have fewer
            raise InputError(path, f"{KEYS_OF[key]}[{short}]: must be a list of [x, y, z], at least 2 points where "
                                   f"its probability is above {LOWEST_THRESHOLD} (the evaluator's resampling asserts "
                                   "two)", line=number)
        return np.array(values, dtype=float).reshape(len(found))

    lanes, chances = _by_type(record, path, number, 2, probabilities)
    if lanes["laneline"] is None:
        raise InputError(path, "has no `laneLines` (the evaluator stops on it)", line=number)
    return Predicted(lanes, chances)
