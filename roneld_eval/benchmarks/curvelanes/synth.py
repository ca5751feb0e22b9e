"""Synthetic CurveLanes sets: the generator's roads, strongly curved, as `<name>.lines.json` labels
and a detector's scored lanes (`{"points": [...], "score": s}`) for `score curvelanes`, with each
image written (blank) at one of CurveLanes' sizes, from which the metric takes its scale."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from ...output import write_file
from ...synth import Camera, SynthResult, lane_file_scenes, png_bytes

SIZES = ((2560, 1440), (1570, 660), (1280, 720))  # CurveLanes ships several sizes


def _lane(points: np.ndarray) -> list[dict]:
    return [{"x": f"{x:.3f}", "y": f"{y:.3f}"} for x, y in points]


def synth_curvelanes(out: str | Path, clips: int = 3, frames: int = 1, seed: int = 0, progress=None) -> SynthResult:
    out = Path(out)
    labels, predictions, images = out / "labels", out / "predictions", out / "images"
    for folder in (labels, predictions, images):
        folder.mkdir(parents=True, exist_ok=True)
    total = 0
    for index in range(clips):
        width, height = SIZES[index % len(SIZES)]
        camera = Camera(width, height, vanish_y=(0.3 * height, 0.4 * height), lane_width_px=(0.3 * width, 0.4 * width),
                        top_margin_px=(0.02 * height, 0.05 * height))
        for _, k, _, truth, detected in lane_file_scenes(camera, 1, frames, seed + 1000 * index):
            name = f"{seed:02d}{index:04d}{k:04d}"
            write_file(labels / f"{name}.lines.json", json.dumps({"Lines": [_lane(points) for points in truth]}))
            write_file(predictions / f"{name}.lines.json", json.dumps(
                {"Lines": [{"points": _lane(points), "score": round(score, 3)} for points, score in detected]}))
            write_file(images / f"{name}.png", png_bytes(np.zeros((height, width), np.uint8)))
            total += 1
            if progress is not None:
                progress(1)
    command = ("roneld-eval", "score", "curvelanes", "--labels", str(labels), "--pred-root", str(predictions),
               "--image-root", str(images), "--best-of", "0.3,0.5,0.7")
    return SynthResult(labels, predictions, "curvelanes", "lanes", clips, total, score_command=command)
