"""Synthetic OpenLane 3D sets: labels (`<segment>/<frame>.json`: file_path, a camera's extrinsic,
lane_lines of xyz in camera coordinates with visibility and category) and a detector's results
(xyz in ground coordinates, category), for `score openlane3d`.

The roads are made to meet every rule of the evaluator: lanes partly beyond the x and y ranges,
stretches of invisible points, two-point lanes, predictions listed far to near, repeated y values,
offsets around the 1.5 m distance and the 75% ratio, duplicates of one lane (matchings of equal
cost), category swaps (20 on 21 and the other way), frames without lanes or without results."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from ...output import write_file
from ...synth import SynthResult
from .official import _CAMERA_REPRESENTATION, _R_GC, _R_VG

CATEGORIES = (1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 20, 21)


def _extrinsic(rng: np.random.Generator) -> np.ndarray:
    """A camera about 2.1 m up, slightly turned (as Waymo's front cameras are)."""
    angles = rng.normal(0, [0.003, 0.015, 0.003])
    cx, cy, cz = np.cos(angles)
    sx, sy, sz = np.sin(angles)
    rotation = (np.array([[1, 0, 0], [0, cx, -sx], [0, sx, cx]]) @ np.array([[cy, 0, sy], [0, 1, 0], [-sy, 0, cy]])
                @ np.array([[cz, -sz, 0], [sz, cz, 0], [0, 0, 1]]))
    extrinsic = np.eye(4)
    extrinsic[:3, :3] = rotation
    extrinsic[:3, 3] = [1.5 + rng.normal(0, 0.05), rng.normal(0, 0.03), 2.1 + rng.normal(0, 0.02)]
    return extrinsic


def _to_camera(extrinsic: np.ndarray, ground: np.ndarray) -> np.ndarray:
    """Ground points (N x 3) as the label's camera coordinates (3 x N): the inverse of the
    evaluator's transform for this extrinsic."""
    matrix = extrinsic.copy()
    matrix[:3, :3] = np.linalg.inv(_R_VG) @ matrix[:3, :3] @ _R_VG @ _R_GC
    matrix[0:2, 3] = 0.0
    forward = matrix @ _CAMERA_REPRESENTATION
    points = np.vstack([ground.T, np.ones(len(ground))])
    return (np.linalg.inv(forward) @ points)[:3]


def _road(rng: np.random.Generator) -> list[tuple[np.ndarray, int]]:
    """Ground-truth lanes in ground coordinates (x right, y forward, z up), near to far."""
    n = int(rng.choice([0, 1, 2, 3, 4, 5, 6], p=[0.04, 0.06, 0.15, 0.25, 0.25, 0.15, 0.10]))
    curve, slope = rng.normal(0, 0.0015), rng.normal(0, 0.01)
    lanes = []
    for k in range(n):
        offset = (k - (n - 1) / 2) * rng.uniform(3.2, 3.9) + rng.normal(0, 0.3)
        start, end = rng.uniform(0, 12), rng.uniform(25, 120)
        count = int(rng.integers(2, 40)) if rng.random() < 0.1 else int(rng.integers(8, 90))
        y = np.sort(rng.uniform(start, end, count)) if rng.random() < 0.5 else np.linspace(start, end, count)
        x = offset + curve * y ** 2 + rng.normal(0, 0.02, count)
        z = slope * y + 0.002 * y ** 1.5 * rng.normal(0, 1) + rng.normal(0, 0.01, count)
        category = int(rng.choice(CATEGORIES)) if k not in (0, n - 1) else int(rng.choice([20, 21, 1, 2]))
        lanes.append((np.column_stack([x, y, z]), category))
    return lanes


def _visibility(rng: np.random.Generator, count: int) -> list[float]:
    visible = np.ones(count)
    if rng.random() < 0.3:  # an occluded stretch
        a = int(rng.integers(0, count))
        visible[a:a + int(rng.integers(1, max(2, count // 2)))] = 0.0
    if rng.random() < 0.05:
        visible[:] = 0.0
    return visible.tolist()


def _detected(rng: np.random.Generator, truth: list[tuple[np.ndarray, int]]) -> list[tuple[np.ndarray, int]]:
    """A detector's lanes for these: shifted, cut, resampled, some missed, duplicated or invented."""
    out = []
    for points, category in truth:
        if rng.random() < 0.1:
            continue  # missed
        shift = rng.choice([rng.normal(0, 0.2), rng.normal(0, 1.2), rng.uniform(1.3, 1.7), rng.normal(0, 3)],
                           p=[0.55, 0.2, 0.15, 0.1])
        lane = points.copy()
        lane[:, 0] += shift + rng.normal(0, 0.05, len(lane))
        lane[:, 2] += rng.normal(0, 0.1)
        if rng.random() < 0.3:  # seen only part of the way
            keep = max(2, int(len(lane) * rng.uniform(0.3, 0.9)))
            lane = lane[:keep] if rng.random() < 0.5 else lane[-keep:]
        if rng.random() < 0.15:
            lane = lane[[0, -1]]  # two points
        if rng.random() < 0.05 and len(lane) > 3:
            lane[2, 1] = lane[1, 1]  # a repeated y
        swapped = {20: 21, 21: 20}.get(category, category) if rng.random() < 0.2 else category
        out.append((lane[::-1] if rng.random() < 0.1 else lane, swapped))
        if rng.random() < 0.08:
            out.append((lane + [rng.normal(0, 0.1), 0, 0], swapped))  # a duplicate
    for _ in range(int(rng.poisson(0.4))):
        start = rng.uniform(-5, 60)
        y = np.linspace(start, start + rng.uniform(5, 60), int(rng.integers(2, 30)))
        x = rng.uniform(-14, 14) + rng.normal(0, 0.01) * y
        out.append((np.column_stack([x, y, 0.01 * y]), int(rng.choice(CATEGORIES))))
    order = rng.permutation(len(out))
    return [out[k] for k in order]


def _round(values) -> list:
    return np.round(np.asarray(values, dtype=float), 6).tolist()


def synth_openlane3d(out: str | Path, clips: int = 3, frames: int = 4, seed: int = 0, progress=None) -> SynthResult:
    out = Path(out)
    labels, predictions = out / "labels", out / "predictions"
    listed = []
    for index in range(clips):
        segment = f"segment-{1000 + index:05d}_with_camera_labels"
        for k in range(frames):
            rng = np.random.default_rng([seed, index, k, 3])
            relpath = f"{segment}/{155000000000 + 100000 * k}"
            key = f"validation/{relpath}.jpg"
            extrinsic = _extrinsic(rng)
            truth = _road(rng)
            label = {"file_path": key, "extrinsic": _round(extrinsic), "intrinsic": [[2000.0, 0.0, 960.0],
                                                                                    [0.0, 2000.0, 640.0],
                                                                                    [0.0, 0.0, 1.0]],
                     "lane_lines": [{"category": category, "visibility": _visibility(rng, len(points)),
                                     "xyz": _round(_to_camera(extrinsic, points))} for points, category in truth]}
            result = {"file_path": key, "lane_lines": [{"category": category, "xyz": _round(lane)}
                                                       for lane, category in _detected(rng, truth)]}
            for root, record in ((labels, label), (predictions, result)):
                target = root / f"{relpath}.json"
                target.parent.mkdir(parents=True, exist_ok=True)
                write_file(target, json.dumps(record) + "\n")
            listed.append(f"{relpath}.jpg")
            if progress is not None:
                progress(1)
    write_file(out / "test_list.txt", "".join(f"{relpath}\n" for relpath in listed))
    command = ("roneld-eval", "score", "openlane3d", "--labels", str(labels), "--pred-root", str(predictions),
               "--list", str(out / "test_list.txt"))
    return SynthResult(labels, predictions, "openlane3d", "lanes", clips, len(listed), score_command=command)


def with_probabilities(results: Path, out: Path, seed: int = 0) -> None:
    """The result files under `results` as PersFormer's training-time evaluation holds them
    (`laneLines`: each lane's points, `laneLines_prob`: its 22 class probabilities), written under
    `out`: most lanes with their own category most probable, some below the 0.5 threshold or at it,
    some with another category most probable, some with two equal highest (argmax takes the first)."""
    for path in sorted(Path(results).rglob("*.json")):
        record = json.loads(path.read_text())
        rng = np.random.default_rng([seed, len(str(path.relative_to(results))), sum(path.read_bytes()) % 100003])
        lanes, probabilities = [], []
        for line in record["lane_lines"]:
            probs = rng.uniform(0, 0.05, 22)
            top = int(line["category"]) if rng.random() < 0.8 else int(rng.integers(0, 22))
            probs[top] = float(rng.choice([rng.uniform(0.5, 1.0), rng.uniform(0.3, 0.5), 0.5], p=[0.8, 0.15, 0.05]))
            if rng.random() < 0.05:
                probs[(top + 1) % 22] = probs[top]  # two equal highest
            lanes.append(line["xyz"])
            probabilities.append(np.round(probs, 6).tolist())
        target = Path(out) / path.relative_to(results)
        target.parent.mkdir(parents=True, exist_ok=True)
        write_file(target, json.dumps({"file_path": record["file_path"], "laneLines": lanes,
                                       "laneLines_prob": probabilities}) + "\n")
