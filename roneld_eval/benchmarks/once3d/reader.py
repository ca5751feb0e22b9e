"""ONCE-3DLanes' files as its evaluator reads them (once_3dlanes_benchmark 7582fbb,
evaluation/eval_utils.py), not as its README describes them (once#5): labels under
`<root>/<segment>/cam01/<frame>.json`, each `{"lanes": [[[x, y, z], ...], ...]}` (a lane a bare list
of points, camera coordinates in metres: x right, y down, z forward); predictions in a tree of the
same names, each `{"lanes": [{"points": [[x, y, z], ...], "score": s}, ...]}`. The frames come in
the order the folders list them (os.listdir), which is the order the evaluator deals them to its
workers and adds up their float32 sums. Where the evaluator would stop with a traceback, or drop a
lane without a word, the file is refused here with its problem named.
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any

import numpy as np

from ...errors import InputError
from ...json_fields import is_finite_number, shown
from ...lanes_io import decode_text, parse_json, read_bytes
from ...limits import LANES
from .official import THRESHOLDS

MAX_POINTS = 1 << 16  # of one lane
CAMERA = "cam01"


def listed_frames(labels: Path, out: str | Path | None = None) -> list[str]:
    """`<segment>/cam01/<frame>.json` of every label, in the order os.listdir gives them: the
    evaluator's order. This tool's own output folders (a command's --out inside the labels, `out`
    among them while it is being written) are passed over; anything else that is not a segment
    folder with its cam01 folder is refused."""
    from ...datasets._paths import tool_folder

    if not labels.is_dir():
        raise InputError(labels, "label folder not found (expected <segment>/cam01/<frame>.json below it)")
    frames = []
    for segment in os.listdir(labels):
        folder = labels / segment
        if tool_folder(folder) or (out is not None and folder.resolve() == Path(out).resolve()):
            continue
        if not folder.is_dir():
            raise InputError(folder, "not a segment folder (the evaluator takes every entry of the label folder for "
                                     "one, and stops on this)")
        if not (folder / CAMERA).is_dir():
            raise InputError(folder, f"has no {CAMERA} folder: the evaluator reads <segment>/{CAMERA}/<frame>.json "
                                     "(the layout since once_3dlanes_benchmark 7582fbb)")
        frames += [f"{segment}/{CAMERA}/{name}" for name in os.listdir(folder / CAMERA) if name.endswith(".json")]
    if not frames:
        raise InputError(labels, f"no <segment>/{CAMERA}/<frame>.json here: is this ONCE-3DLanes' label folder?")
    return frames


def _record(path: Path) -> dict:
    record = parse_json(decode_text(read_bytes(path), path), path, "not JSON", "not an ONCE-3DLanes file")
    if not isinstance(record, dict) or not isinstance(record.get("lanes"), list):
        raise InputError(path, "not an ONCE-3DLanes file: a JSON object with a `lanes` list is expected")
    if len(record["lanes"]) > LANES.count:
        raise InputError(path, LANES.problem(len(record["lanes"])))
    return record


def _points(points: Any, path: Path, where: str) -> np.ndarray:
    """A lane's [x, y, z] points as an N x 3 float array (finite numbers only)."""
    if not (isinstance(points, list) and all(isinstance(p, list) and len(p) == 3 for p in points)):
        raise InputError(path, f"{where}: must be a list of [x, y, z] points")
    if len(points) > MAX_POINTS:
        raise InputError(path, f"{where}: {len(points):,} points, more than the {MAX_POINTS:,} a lane may have here")
    if not all(is_finite_number(v) for p in points for v in p):
        raise InputError(path, f"{where}: something other than finite numbers")
    return np.array(points, dtype=float).reshape(len(points), 3)


def read_truth(path: Path) -> tuple[np.ndarray, ...]:
    """A label's lanes (each N x 3)."""
    lanes = _record(path)["lanes"]
    found = []
    for k, lane in enumerate(lanes):
        if isinstance(lane, dict):
            raise InputError(path, f"lane {k}: a label's lane is a bare list of points (the README's "
                                   "{\"points\": ...} form is what the evaluator cannot read)")
        found.append(_points(lane, path, f"lane {k}"))
    return tuple(found)


def read_prediction(path: Path) -> tuple[tuple[np.ndarray, ...], tuple[float, ...]]:
    """A prediction file's lanes and their scores; a missing file is a frame without lanes."""
    if read_bytes(path, missing_ok=True) is None:
        return (), ()
    lanes, scores = [], []
    for k, lane in enumerate(_record(path)["lanes"]):
        if not isinstance(lane, dict) or "points" not in lane:
            raise InputError(path, f"lane {k}: must be {{\"points\": [[x, y, z], ...], \"score\": s}}")
        score: Any = lane.get("score")
        if not is_finite_number(score):
            raise InputError(path, f"lane {k}: `score` must be a number, got {shown(score)} (the evaluator drops a "
                                   "lane without one, and stops on one it cannot read)")
        points = _points(lane["points"], path, f"lane {k}")
        if len(points) < 2 and score > THRESHOLDS[0]:
            raise InputError(path, f"lane {k}: must have at least 2 points where its score is above "
                                   f"{THRESHOLDS[0]} (the evaluator stops on it)")
        lanes.append(points)
        scores.append(float(score))
    return tuple(lanes), tuple(scores)
