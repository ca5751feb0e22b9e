"""Synthetic LLAMAS sets: the generator's roads as label JSON files whose lanes are dashed markers
(pixel start below pixel end, world z growing away from the car) that LLAMAS's spline creator turns
into its four lanes, and a detector's `.lines.txt` lanes, for `score llamas`."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from ..synth import Camera, SynthResult, lane_file_scenes
from .llamas import IMAGE_HEIGHT, IMAGE_WIDTH

CAMERA = Camera(IMAGE_WIDTH, IMAGE_HEIGHT, vanish_y=(250, 290), lane_width_px=(520, 640), top_margin_px=(10, 30))
DASH_ROWS, GAP_ROWS = 24, 16
NAMES = {-1: "l0", 1: "r0", -2: "l1", 2: "r1", -3: "l2", 3: "r2"}


def _markers(points: np.ndarray, vanish_y: float) -> list[dict]:
    """Dashes along a lane (its points listed from the bottom up, every 10 rows)."""
    markers: list[dict] = []
    ys, xs = points[:, 1], points[:, 0]
    y = float(ys.max())
    while y - DASH_ROWS > ys.min():
        start, end = y, y - DASH_ROWS
        x0, x1 = np.interp([start, end], ys[::-1], xs[::-1])
        z0, z1 = (400.0 / max(row - vanish_y, 1.0) for row in (start, end))
        markers.append({"lane_marker_id": f"m{len(markers)}",
                        "pixel_start": {"x": int(x0), "y": int(start)}, "pixel_end": {"x": int(x1), "y": int(end)},
                        "world_start": {"x": float(x0) / 100, "y": 1.5, "z": z0},
                        "world_end": {"x": float(x1) / 100, "y": 1.5, "z": z1}})
        y -= DASH_ROWS + GAP_ROWS
    return markers


def synth_llamas(out: str | Path, clips: int = 3, frames: int = 10, seed: int = 0, progress=None) -> SynthResult:
    out = Path(out)
    labels, predictions = out / "labels", out / "predictions"
    total = 0
    for index, k, scene, truth, detected in lane_file_scenes(CAMERA, clips, frames, seed):
        recording = f"images-2014-12-22-{12 + index:02d}-35-10_mapping_280S_ramps"
        name = f"{1419283521 + 10 * k}_0004236000"
        centre = scene.vanish_x
        bottoms = [points[np.argmax(points[:, 1]), 0] - centre for points in truth]
        left = sorted((b, n) for n, b in enumerate(bottoms) if b < 0)[::-1]
        right = sorted((b, n) for n, b in enumerate(bottoms) if b >= 0)
        lanes = []
        for side, ordered in ((-1, left), (1, right)):
            for rank, (_, n) in enumerate(ordered, start=1):
                if side * rank in NAMES:
                    lanes.append({"lane_id": NAMES[side * rank], "markers": _markers(truth[n], scene.vanish_y)})
        label = labels / recording / f"{name}.json"
        label.parent.mkdir(parents=True, exist_ok=True)
        label.write_text(json.dumps({"projection_matrix": [[1000.0, 0.0, 638.0], [0.0, 1000.0, 358.0],
                                                           [0.0, 0.0, 1.0]], "lanes": lanes}))
        target = predictions / recording / f"{name}.lines.txt"
        target.parent.mkdir(parents=True, exist_ok=True)
        target.write_text("".join(" ".join(f"{x:.2f} {y:.0f}" for x, y in points) + "\n" for points, _ in detected))
        total += 1
        if progress is not None:
            progress(1)
    command = f"roneld-eval score llamas --labels {labels} --pred-root {predictions}"
    return SynthResult(labels, predictions, "llamas", "lanes", clips, total, score_command=command)
