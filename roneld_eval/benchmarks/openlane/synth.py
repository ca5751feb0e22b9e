"""Synthetic OpenLane 2D sets: the generator's roads as lane2d annotations (`<segment>/<frame>.json`,
`lane_lines[{category, uv}]`, 1920x1280) and a detector's lanes in the same format, for `score
openlane`. Ego boundaries are white dashed (category 1), the others white solid (2); now and then a
predicted lane carries the other category, which only the category-blind matching forgives."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from ...output import write_file
from ...synth import Camera, SynthResult, lane_file_scenes
from .reader import IMAGE_HEIGHT, IMAGE_WIDTH

CAMERA = Camera(IMAGE_WIDTH, IMAGE_HEIGHT, vanish_y=(560, 620), lane_width_px=(1000, 1200), top_margin_px=(20, 60))


def _record(path: str, lanes, categories) -> str:
    lines = [{"category": int(category), "uv": [[round(float(x), 2) for x in points[:, 0]],
                                                [round(float(y), 2) for y in points[:, 1]]]}
             for points, category in zip(lanes, categories)]
    return json.dumps({"file_path": path, "lane_lines": lines}) + "\n"


def _category(points: np.ndarray, centre: float) -> int:
    bottom = points[np.argmax(points[:, 1]), 0]
    return 1 if abs(bottom - centre) < 0.35 * IMAGE_WIDTH else 2


def synth_openlane(out: str | Path, clips: int = 3, frames: int = 4, seed: int = 0, progress=None) -> SynthResult:
    out = Path(out)
    labels, predictions = out / "labels", out / "predictions"
    total = 0
    for index, k, scene, truth, detected in lane_file_scenes(CAMERA, clips, frames, seed):
        relpath = f"segment-{1000 + index:05d}/{155000000000 + 100000 * k}"
        for root, lanes, confusion in ((labels, truth, 0.0), (predictions, [p for p, _ in detected], 0.15)):
            rng = np.random.default_rng([seed, index, k, 7])
            categories = [_category(points, scene.vanish_x) for points in lanes]
            categories = [3 - c if rng.random() < confusion else c for c in categories]
            target = root / f"{relpath}.json"
            target.parent.mkdir(parents=True, exist_ok=True)
            write_file(target, _record(f"validation/{relpath}.jpg", lanes, categories))
        total += 1
        if progress is not None:
            progress(1)
    command = ("roneld-eval", "score", "openlane", "--labels", str(labels), "--pred-root", str(predictions))
    return SynthResult(labels, predictions, "openlane", "lanes", clips, total, score_command=command)
