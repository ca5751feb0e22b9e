"""Synthetic ONCE-3DLanes sets: labels (`<segment>/cam01/<frame>.json`: lanes of [x, y, z] points in
camera coordinates, x right, y down, z forward) and a detector's predictions (the same names: lanes
with points and a score), for `score once3d`, in the layout its evaluator reads.

The roads are made to meet every rule of the evaluator: lanes reaching past x +/-10 m and z 50 m,
lanes starting beyond z 10 m (drawn as nothing: IoU 0), lanes listed far to near, two-point lanes,
offsets around the 0.3 m distance in x and in height, depth errors (which it does not measure),
duplicated lanes (equal IoUs for Munkres to choose between), scores exactly at thresholds and a
hair either side (0.35 and 0.35000000000000003 among them), frames without labels or predictions."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from ...output import write_file
from ...synth import SynthResult

SCORES = (0.1, 0.3, 0.35, 0.35000000000000003, 0.3500000000000001, 0.5, 0.7, 0.95, 0.9500000000000001, 0.05, 0.99)


def _road(rng: np.random.Generator) -> list[np.ndarray]:
    """Labelled lanes, near to far: about 3.6 m apart, curving, the road dipping and climbing."""
    n = int(rng.choice([0, 1, 2, 3, 4, 5], p=[0.05, 0.1, 0.25, 0.3, 0.2, 0.1]))
    curve, height, slope = rng.normal(0, 0.002), rng.uniform(1.4, 1.9), rng.normal(0, 0.01)
    left = -(n - 1) / 2 * 3.6 + rng.normal(0, 0.5)
    lanes = []
    for k in range(n):
        near = rng.uniform(12, 25) if rng.random() < 0.1 else rng.uniform(2, 8)
        far = rng.uniform(near + 5, 80)
        count = 2 if rng.random() < 0.08 else int(rng.integers(4, 60))
        z = np.linspace(near, far, count)
        x = left + 3.6 * k + curve * z ** 2 + rng.normal(0, 0.01, count)
        y = height - slope * z + rng.normal(0, 0.005, count)
        lanes.append(np.column_stack([x, y, z]))
    return lanes


def _detected(rng: np.random.Generator, truth: list[np.ndarray]) -> list[tuple[np.ndarray, float]]:
    """A detector's lanes and scores: moved sideways, up, or in depth, cut short, missed,
    duplicated or invented, in any order."""
    found = []
    for lane in truth:
        if rng.random() < 0.1:
            continue
        moved = lane.copy()
        moved[:, 0] += rng.choice([rng.normal(0, 0.08), rng.uniform(0.25, 0.35), rng.normal(0, 1.5)],
                                  p=[0.7, 0.15, 0.15])
        moved[:, 1] += rng.choice([0.0, rng.uniform(0.2, 0.4)], p=[0.85, 0.15])
        if rng.random() < 0.1:
            moved[:, 2] *= rng.uniform(1.05, 1.3)  # a depth error: the evaluator does not see it
        if rng.random() < 0.2 and len(moved) > 4:
            moved = moved[: max(2, int(len(moved) * rng.uniform(0.3, 0.9)))]
        found.append((moved[::-1] if rng.random() < 0.1 else moved, _score(rng)))
        if rng.random() < 0.08:
            found.append((moved.copy(), _score(rng)))  # the same lane twice: equal IoUs
    for _ in range(int(rng.poisson(0.4))):
        z = np.linspace(rng.uniform(1, 20), rng.uniform(25, 60), int(rng.integers(2, 15)))
        found.append((np.column_stack([rng.uniform(-12, 12) + 0.01 * z, np.full(len(z), 1.6), z]), _score(rng)))
    if rng.random() < 0.05:
        found.append((np.array([[0.0, 1.6, 5.0]]), 0.05))  # one point, below every threshold: never compared
    order = rng.permutation(len(found))
    return [found[k] for k in order]


def _score(rng: np.random.Generator) -> float:
    return float(rng.choice(SCORES)) if rng.random() < 0.35 else round(float(rng.uniform(0.0, 1.0)), 4)


def _rounded(lane: np.ndarray) -> list:
    return np.round(lane, 5).tolist()


def synth_once3d(out: str | Path, clips: int = 3, frames: int = 4, seed: int = 0, progress=None) -> SynthResult:
    out = Path(out)
    labels, predictions = out / "labels", out / "predictions"
    for index in range(clips):
        segment = f"{index:06d}"
        for k in range(frames):
            rng = np.random.default_rng([seed, index, k, 7])
            name = f"{1616100800000 + 100 * (index * frames + k)}.json"
            truth = _road(rng)
            detected = [] if rng.random() < 0.04 else _detected(rng, truth)
            for root, record in ((labels, {"lanes": [_rounded(lane) for lane in truth]}),
                                 (predictions, {"lanes": [{"points": _rounded(lane), "score": score}
                                                          for lane, score in detected]})):
                target = root / segment / "cam01" / name
                target.parent.mkdir(parents=True, exist_ok=True)
                write_file(target, json.dumps(record) + "\n")
            if progress is not None:
                progress(1)
    command = ("roneld-eval", "score", "once3d", "--labels", str(labels), "--pred-root", str(predictions))
    return SynthResult(labels, predictions, "once3d", "lanes", clips, clips * frames, score_command=command)
