"""Synthetic Apollo 3D Synthetic sets: a split's label file (test.json: JSON lines of raw_file, the
camera's height and pitch, laneLines and centerLines of [x, y, z] in ground coordinates with each
point's visibility) and a detector's predictions (pred.json: the lanes with a probability each),
for `score apollo3d`.

The roads are made to meet every rule of the evaluator: lanes reaching beyond x +/-10 m and +/-30 m,
beyond y 3-103 m, stretches of invisible points, two-point lanes, lanes listed far to near (a label's
may then be dropped, as the evaluator checks its first and last points as listed), [x, y] points,
offsets around the 1.5 m distance and the 75% ratio, duplicated lanes (matchings of equal cost),
probabilities exactly at the sweep's thresholds (0.05, 0.5, 0.95) and on either side of them, frames
without lanes and frames whose every prediction is below the lowest threshold."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from ...output import write_file
from ...synth import SynthResult

# probabilities on, just below and just above the thresholds np.linspace(0.05, 0.95, 19) compares with
EDGES = (0.05, 0.5, 0.95, 0.3, 0.7, 0.04999999, 0.50000001, 0.94999999)


def _lines(rng: np.random.Generator, n: int) -> list[np.ndarray]:
    """n lane lines (N x 3, y near to far), about 3.6 m apart, curving and climbing together."""
    curve, slope, bump = rng.normal(0, 0.002), rng.normal(0, 0.02), rng.normal(0, 0.0004)
    left = -(n - 1) / 2 * 3.6 + rng.normal(0, 0.8)
    lanes = []
    for k in range(n):
        near, far = rng.uniform(0, 15), rng.uniform(30, 160)
        count = 2 if rng.random() < 0.08 else int(rng.integers(5, 120))
        y = np.linspace(near, far, count)
        x = left + 3.6 * k + curve * y ** 2 + rng.normal(0, 0.02, count)
        z = slope * y + bump * y ** 2 + rng.normal(0, 0.01, count)
        lanes.append(np.column_stack([x, y, z]))
    return lanes


def _seen(rng: np.random.Generator, count: int) -> list[float]:
    """Each point's visibility: all seen, an occluded stretch, or nothing seen."""
    seen = np.ones(count)
    roll = rng.random()
    if roll < 0.25:
        start = int(rng.integers(0, count))
        seen[start:start + int(rng.integers(1, count + 1))] = 0.0
    elif roll < 0.3:
        seen[:] = 0.0
    return seen.tolist()


def _centres(lines: list[np.ndarray]) -> list[np.ndarray]:
    """The centre line between each two neighbouring lines, over the stretch both cover."""
    centres = []
    for a, b in zip(lines, lines[1:]):
        low, high = max(a[0, 1], b[0, 1]), min(a[-1, 1], b[-1, 1])
        if high - low < 1:
            continue
        y = np.linspace(low, high, max(2, int((high - low) // 2)))
        centres.append(np.column_stack([(np.interp(y, a[:, 1], a[:, 0]) + np.interp(y, b[:, 1], b[:, 0])) / 2, y,
                                        (np.interp(y, a[:, 1], a[:, 2]) + np.interp(y, b[:, 1], b[:, 2])) / 2]))
    return centres


def _guessed(rng: np.random.Generator, truth: list[np.ndarray]) -> tuple[list[np.ndarray], list[float]]:
    """A detector's lanes for these and their probabilities: moved, cut short, some missed,
    duplicated or invented, in any order."""
    lanes: list[np.ndarray] = []
    for lane in truth:
        if rng.random() < 0.12:
            continue
        lanes.append(_moved(rng, lane))
        if rng.random() < 0.08:
            lanes.append(lanes[-1].copy())  # the same lane twice: two matchings of one cost
    for _ in range(int(rng.poisson(0.5))):
        y = np.linspace(rng.uniform(3, 40), rng.uniform(45, 110), int(rng.integers(2, 20)))
        lanes.append(np.column_stack([rng.uniform(-25, 25) + 0.01 * y, y, 0.01 * y]))
        if rng.random() < 0.2:
            lanes.append(lanes[-1].copy())  # an invented lane twice
    probabilities = [float(rng.choice(EDGES)) if rng.random() < 0.3 else float(np.round(rng.uniform(0.0, 1.0), 4))
                     for _ in lanes]
    if rng.random() < 0.05:
        probabilities = [0.01 for _ in lanes]
    order = rng.permutation(len(lanes))
    return [lanes[k] for k in order], [probabilities[k] for k in order]


def _moved(rng: np.random.Generator, lane: np.ndarray) -> np.ndarray:
    """A detected lane: shifted sideways (within, around or beyond 1.5 m) and up, perhaps cut short,
    without z, or listed far to near."""
    moved = lane.copy()
    moved[:, 0] += rng.choice([rng.normal(0, 0.25), rng.uniform(1.3, 1.7), rng.normal(0, 2.5)], p=[0.7, 0.15, 0.15])
    moved[:, 2] += rng.normal(0, 0.15)
    if rng.random() < 0.25 and len(moved) > 4:
        moved = moved[: max(2, int(len(moved) * rng.uniform(0.2, 0.9)))]
    if rng.random() < 0.05:
        moved = moved[:, :2]  # [x, y]: z is 0 to the evaluator
    return moved[::-1] if rng.random() < 0.15 else moved


def _rounded(lanes: list[np.ndarray]) -> list:
    return [np.round(lane, 5).tolist() for lane in lanes]


def synth_apollo3d(out: str | Path, clips: int = 3, frames: int = 4, seed: int = 0, progress=None) -> SynthResult:
    out = Path(out)
    labels, predictions = [], []
    for scene in range(clips):
        for k in range(frames):
            rng = np.random.default_rng([seed, scene, k, 5])
            raw_file = f"images/{scene:02d}/{k:07d}.jpg"
            lines = _lines(rng, int(rng.choice([0, 1, 2, 3, 4, 5], p=[0.05, 0.05, 0.2, 0.3, 0.25, 0.15])))
            centres = _centres(lines)
            lines = [lane[::-1] if rng.random() < 0.05 else lane for lane in lines]  # far to near: may be dropped
            labels.append({"raw_file": raw_file, "cam_height": round(float(rng.uniform(1.4, 1.9)), 4),
                           "cam_pitch": round(float(rng.uniform(0.0, 0.1)), 4), "laneLines": _rounded(lines),
                           "laneLines_visibility": [_seen(rng, len(lane)) for lane in lines],
                           "centerLines": _rounded(centres),
                           "centerLines_visibility": [_seen(rng, len(lane)) for lane in centres]})
            guessed_lines, line_probabilities = _guessed(rng, lines)
            guessed_centres, centre_probabilities = _guessed(rng, centres)
            predictions.append({"raw_file": raw_file, "laneLines": _rounded(guessed_lines),
                                "laneLines_prob": line_probabilities, "centerLines": _rounded(guessed_centres),
                                "centerLines_prob": centre_probabilities})
            if progress is not None:
                progress(1)
    order = np.random.default_rng([seed, 6]).permutation(len(predictions))  # the evaluator follows this order
    out.mkdir(parents=True, exist_ok=True)
    write_file(out / "test.json", "".join(json.dumps(record) + "\n" for record in labels))
    write_file(out / "pred.json", "".join(json.dumps(predictions[k]) + "\n" for k in order))
    command = ("roneld-eval", "score", "apollo3d", "--labels", str(out / "test.json"), "--pred", str(out / "pred.json"))
    return SynthResult(out / "test.json", out / "pred.json", "apollo3d", "lanes", clips, len(labels),
                       score_command=command)
