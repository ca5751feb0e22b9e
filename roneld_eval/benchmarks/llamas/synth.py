"""Synthetic LLAMAS sets: the generator's roads as label JSON files whose lanes are dashed markers
(pixel start below pixel end, world z growing away from the car) that LLAMAS's spline creator turns
into its four lanes, and a detector's `.lines.txt` lanes, for `score llamas`."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from ...errors import ConfigError
from ...output import write_file
from ...synth import Camera, SynthResult, lane_file_scenes, png_bytes
from .reader import IMAGE_HEIGHT, IMAGE_WIDTH

CAMERA = Camera(IMAGE_WIDTH, IMAGE_HEIGHT, vanish_y=(250, 290), lane_width_px=(520, 640), top_margin_px=(10, 30))
DASH_ROWS, GAP_ROWS = 24, 16
NAMES = {-1: "l0", 1: "r0", -2: "l1", 2: "r1", -3: "l2", 3: "r2"}


FOCAL, CAMERA_HEIGHT = 1000.0, 1.5  # the labels' projection matrix and the road 1.5 m below the camera


def _markers(points: np.ndarray, vanish_y: float) -> list[dict]:
    """Dashes along a lane (its points listed from the bottom up, every 10 rows), their world
    points where the label's projection (principal point at the vanishing point) puts the pixels."""
    markers: list[dict] = []
    ys, xs = points[:, 1], points[:, 0]
    y = float(ys.max())
    while y - DASH_ROWS > ys.min():
        start, end = y, y - DASH_ROWS
        x0, x1 = np.interp([start, end], ys[::-1], xs[::-1])
        z0, z1 = (FOCAL * CAMERA_HEIGHT / max(row - vanish_y, 1.0) for row in (start, end))
        markers.append({"lane_marker_id": f"m{len(markers)}",
                        "pixel_start": {"x": int(x0), "y": int(start)}, "pixel_end": {"x": int(x1), "y": int(end)},
                        "world_start": {"x": float(x0 - IMAGE_WIDTH / 2) * z0 / FOCAL, "y": CAMERA_HEIGHT, "z": z0},
                        "world_end": {"x": float(x1 - IMAGE_WIDTH / 2) * z1 / FOCAL, "y": CAMERA_HEIGHT, "z": z1}})
        y -= DASH_ROWS + GAP_ROWS
    return markers


def _named_lanes(scene, truth) -> list[dict]:
    """The label's lanes named as LLAMAS names them (l1, l0, r0, r1: by side and rank from the
    middle, at the image's bottom), each with its markers."""
    bottoms = [points[np.argmax(points[:, 1]), 0] - scene.vanish_x for points in truth]
    left = sorted((b, n) for n, b in enumerate(bottoms) if b < 0)[::-1]
    right = sorted((b, n) for n, b in enumerate(bottoms) if b >= 0)
    lanes = []
    for side, ordered in ((-1, left), (1, right)):
        for rank, (_, n) in enumerate(ordered, start=1):
            if side * rank in NAMES:
                lanes.append({"lane_id": NAMES[side * rank], "markers": _markers(truth[n], scene.vanish_y)})
    return lanes


def synth_llamas(out: str | Path, clips: int = 3, frames: int = 10, seed: int = 0, maps_format: str = "lanes",
                 progress=None) -> SynthResult:
    """labels/<recording>/<frame>.json, and under predictions/ a detector's <frame>.lines.txt
    (maps format "lanes", for `score llamas --pred-root`) or a segmentation model's
    <frame>.json_<c>.png (c = 0..4, "llamas-png": `run --dataset llamas`, `score llamas --maps`)."""
    import cv2

    if maps_format not in ("lanes", "llamas-png"):
        raise ConfigError(f"synth --dataset llamas writes maps as llamas-png or lanes, not {maps_format}")
    out = Path(out)
    labels, predictions = out / "labels", out / "predictions"
    total = 0
    maps = maps_format == "llamas-png"
    for index, k, scene, truth, detected, *rendered in lane_file_scenes(CAMERA, clips, frames, seed, maps=maps):
        recording = f"images-2014-12-22-{12 + index:02d}-35-10_mapping_280S_ramps"
        name = f"{1419283521 + 10 * k}_0004236000"
        label = labels / recording / f"{name}.json"
        label.parent.mkdir(parents=True, exist_ok=True)
        projection = [[FOCAL, 0.0, IMAGE_WIDTH / 2], [0.0, FOCAL, float(scene.vanish_y)], [0.0, 0.0, 1.0]]
        write_file(label, json.dumps({"projection_matrix": projection, "lanes": _named_lanes(scene, truth)}))
        target = predictions / recording / f"{name}.lines.txt"
        target.parent.mkdir(parents=True, exist_ok=True)
        if maps:  # the model's maps at the frame's size, and a background class as the script reads it too
            planes = [cv2.resize(plane, (IMAGE_WIDTH, IMAGE_HEIGHT), interpolation=cv2.INTER_LINEAR)
                      for plane in rendered[0]]
            planes.insert(0, 255 - np.max(planes, axis=0))
            for c, plane in enumerate(planes):
                write_file(target.with_name(f"{name}.json_{c}.png"), png_bytes(plane))
        else:
            write_file(target, "".join(" ".join(f"{x:.2f} {y:.0f}" for x, y in points) + "\n"
                                       for points, _ in detected))
        total += 1
        if progress is not None:
            progress(1)
    if maps:
        return SynthResult(labels, predictions, "llamas", maps_format, clips, total)
    command = ("roneld-eval", "score", "llamas", "--labels", str(labels), "--pred-root", str(predictions))
    return SynthResult(labels, predictions, "llamas", "lanes", clips, total, score_command=command)
