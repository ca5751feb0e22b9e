"""TuSimple's lane format: one JSON object a line, `raw_file` (the image path), `lanes` (each lane's x
per row of `h_samples`, -2 where it has none) and `h_samples`, as its labels and a detector's
predictions.json hold them; read with every value checked, and written."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any, Iterable

import numpy as np

from ...datasets._paths import normalise_relpath
from ...errors import InputError
from ...json_fields import RepeatedKey, is_finite_number, loads
from ...lanes_io import (FAR_FROM_ORIGIN, MAX_PREDICTED_COORDINATE, _all_numbers, check_coordinates, read_text,
                         split_lines)
from ...limits import JSON_LINES, LANES
from ...lanes_io import check_score
from ...maps.lanes import LanesAndScores
from ...model import Lane


def parse_tusimple_record(line: str, path, number: int, predictions: bool = False) -> dict[str, Any]:
    """One TuSimple JSON line, checked: raw_file, lanes, h_samples (optional in predictions).

    Predictions may leave out run_time (taken as 0 ms, never penalised).
    """
    record = _json_object(line, path, number)
    required = ("raw_file", "lanes") if predictions else ("raw_file", "lanes", "h_samples")
    for key in required:
        if key not in record:
            raise InputError(path, f"missing key {key!r}", line=number)
    if not isinstance(record["raw_file"], str) or not record["raw_file"].strip():
        raise InputError(path, "raw_file must be a non-empty string", line=number)
    lanes = record["lanes"]
    _check_lanes(lanes, path, number)
    if "h_samples" in record:
        rows = record["h_samples"]
        if not isinstance(rows, list) or not _all_numbers(rows):
            raise InputError(path, "h_samples must be a list of numbers", line=number)
        for index, lane in enumerate(lanes):
            if len(lane) != len(rows):
                raise InputError(
                    path, f"lane {index} has {len(lane)} values but h_samples has {len(rows)}", line=number
                )
    if "run_time" in record:
        if not is_finite_number(record["run_time"]):
            raise InputError(path, "run_time must be a number (milliseconds)", line=number)
    elif predictions:
        record["run_time"] = 0
    return record


def _json_object(line: str, path, number: int) -> dict[str, Any]:
    try:
        record = loads(line)
    except RepeatedKey as error:
        raise InputError(path, str(error), line=number) from None
    except json.JSONDecodeError as error:
        raise InputError(path, f"not valid JSON: {error.msg}", line=number) from None
    except (ValueError, RecursionError) as error:  # a 5,000-digit number; arrays nested 100,000 deep
        raise InputError(path, f"not JSON this tool can read: {str(error).splitlines()[0]}", line=number) from None
    if not isinstance(record, dict):
        raise InputError(path, "each line must be a JSON object", line=number)
    return record


def _check_lanes(lanes: Any, path, number: int) -> None:
    """Lists of finite x values, not too many, none far from the origin."""
    if not isinstance(lanes, list) or not all(isinstance(lane, list) for lane in lanes):
        raise InputError(path, "lanes must be a list of lists of x values", line=number)
    if len(lanes) > LANES.count:
        raise InputError(path, LANES.problem(len(lanes)), line=number)
    for index, lane in enumerate(lanes):
        if not _all_numbers(lane):
            raise InputError(path, f"lane {index} holds a value that is not a finite number", line=number)
        if lane and max(map(abs, lane)) > MAX_PREDICTED_COORDINATE:  # as check_coordinates, for every reader
            far = max(lane, key=abs)
            raise InputError(path, f"lane {index}: x = {far:.10g} {FAR_FROM_ORIGIN}: not a lane coordinate",
                             line=number)


def check_h_samples(rows, path, line: int, image_height: int) -> None:
    """A label's rows: at least one, each inside the image, none twice (lanes are read row by row)."""
    if not rows:
        raise InputError(path, "h_samples is empty: a label needs at least one row", line=line)
    for y in rows:
        if not 0 <= y < image_height:
            raise InputError(path, f"h_samples row {y:g} lies outside the {image_height}-row image", line=line)
    if len(set(rows)) != len(rows):
        repeated = next(y for y in rows if rows.count(y) > 1)
        raise InputError(path, f"h_samples lists row {repeated:g} twice", line=line)


def read_tusimple_records(path: Path, predictions: bool = False,
                          errors: list[InputError] | None = None) -> list[tuple[int, dict[str, Any]]]:
    """(line number, record) of every non-blank line of a TuSimple JSON-lines file.

    With an `errors` list, bad lines are left out and their errors appended.
    """
    text = read_text(path, JSON_LINES)
    records = []
    for number, line in enumerate(split_lines(text), start=1):
        if line.strip():
            try:
                records.append((number, parse_tusimple_record(line, path, number, predictions=predictions)))
            except InputError as error:
                if errors is None:
                    raise
                errors.append(error)
    return records


def lane_from_tusimple(xs: list[float], h_samples: list[float]) -> Lane:
    """A TuSimple lane (x per row, negative = no point) as the points it has."""
    points = [(float(x), float(y)) for x, y in zip(xs, h_samples) if x >= 0]
    return Lane(np.array(points, np.float64).reshape(-1, 2))


def tusimple_xs(lane: Lane, h_samples: Iterable[float]) -> list[float]:
    """x of a lane at each row, -2 where it has no point (exact for lanes read from labels)."""
    lookup = {float(y): float(x) for x, y in lane.points}
    return [lookup.get(float(y), -2.0) for y in h_samples]


def format_tusimple_record(raw_file: str, lanes_xs: list[list[float]], h_samples, run_time: float = 0) -> str:
    """One TuSimple prediction line (JSON, no trailing newline)."""
    def number(v: float):
        return int(v) if float(v).is_integer() else v

    record = {
        "raw_file": raw_file,
        "lanes": [[number(v) for v in xs] for xs in lanes_xs],
        "h_samples": [number(v) for v in h_samples],
        "run_time": run_time,
    }
    return json.dumps(record, separators=(", ", ": "))


def predicted_frames(path: Path) -> dict[str, LanesAndScores]:
    """relpath -> (lanes, scores) of a predictions.json (maps.lanes.JsonLinesFile reads it once)."""
    frames: dict[str, LanesAndScores] = {}
    for number, record in read_tusimple_records(path, predictions=True):
        relpath = normalise_relpath(record["raw_file"], path, number)
        if relpath in frames:
            raise InputError(path, f"{relpath} has lanes twice", line=number)
        rows = record.get("h_samples")
        if rows is None:
            raise InputError(path, "missing key 'h_samples' (needed to place the lanes)", line=number)
        lanes = tuple(lane_from_tusimple(xs, rows) for xs in record["lanes"])
        check_coordinates(lanes, path, number)
        scores = record.get("scores", [1.0] * len(lanes))
        if not isinstance(scores, list) or len(scores) != len(lanes):
            raise InputError(path, "scores must be a list with one number in [0, 1] per lane", line=number)
        frames[relpath] = (lanes, tuple(check_score(value, path, number) for value in scores))
    return frames
