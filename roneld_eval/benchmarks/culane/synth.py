"""Synthetic CULane sets: the generator's roads as a CULane tree (list, categories, .lines.txt),
with maps or a detector's lane files mirrored under the maps root; and lane-file pairs for
checking and timing the official scorer."""

from __future__ import annotations

from pathlib import Path
from typing import Iterable

import numpy as np

from ...model import image_stem
from ...output import write_file
from ...synth import (Camera, SynthResult, write_maps, clip_style, detector_lanes, render_maps, scene_lines_txt,
                     scene_sequence, write_lines_txt)
from .reader import IMAGE_HEIGHT, IMAGE_WIDTH

CAMERA = Camera(IMAGE_WIDTH, IMAGE_HEIGHT, vanish_y=(245, 275), lane_width_px=(820, 980), top_margin_px=(12, 45))
CATEGORIES = ("normal", "crowd", "hlight", "shadow", "noline", "arrow", "curve", "cross", "night")


def synth_culane(out: str | Path, clips: int = 3, frames: int = 12, seed: int = 0, maps_format: str = "npy",
                 structure: Iterable[tuple[str, list[str]]] | None = None, progress=None) -> SynthResult:
    """Write a CULane-layout dataset (`out/data`) and its maps (`out/maps`).

    `structure` gives (clip id, frame relpaths) to imitate a real list (e.g. the official
    test list); else clips are named like CULane's and hold `frames` frames 30 apart.
    """
    out = Path(out)
    data_root, maps_root = out / "data", out / "maps"
    if structure is not None:
        structure = list(structure)
    else:
        clip_ids = [f"driver_{100 + k}_30frame/{5181432 + 317 * k:08d}_{203 + k:04d}.MP4" for k in range(clips)]
        structure = [(clip, [f"{clip}/{30 * i:05d}.jpg" for i in range(frames)]) for clip in clip_ids]
    listing: list[str] = []
    categories: dict[str, list[str]] = {name: [] for name in CATEGORIES}
    total = 0
    for index, (_clip_id, relpaths) in enumerate(structure):
        rng = np.random.default_rng([seed, index])
        style, category = clip_style(index, rng, len(relpaths))
        scenes = scene_sequence(CAMERA, len(relpaths), style, rng, frames_apart=30)
        detector = np.random.default_rng([seed, index, 1])  # lane files: the detector's own noise
        for k, (relpath, scene) in enumerate(zip(relpaths, scenes)):
            stem = image_stem(relpath)
            label_path = data_root / f"{stem}.lines.txt"
            label_path.parent.mkdir(parents=True, exist_ok=True)
            write_file(label_path, scene_lines_txt(scene))
            if maps_format == "lanes":
                rows = np.arange(scene.height - 1, 0, -10)[::-1]
                write_lines_txt(maps_root / stem, detector_lanes(scene, style, k, detector, rows))
            else:
                write_maps(maps_root / stem, render_maps(scene, style, k, rng), maps_format)
            listing.append("/" + relpath)
            categories[category].append(relpath)
            total += 1
            if progress is not None:
                progress(1)
    (data_root / "list" / "test_split").mkdir(parents=True, exist_ok=True)
    write_file(data_root / "list" / "test.txt", "".join(line + "\n" for line in listing))
    for number, name in enumerate(CATEGORIES):
        if categories[name]:
            write_file(data_root / "list" / "test_split" / f"test{number}_{name}.txt",
                       "".join(line + "\n" for line in categories[name]))
    return SynthResult(data_root, maps_root, "culane", maps_format, len(structure), total)


def _awkward_copy(points: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    """A ground-truth lane as a detector might give it: shifted with drifting noise, and at
    random every second point, reversed, its ends only, one point, or a point repeated."""
    points = points.copy()
    points[:, 0] += rng.normal(0, rng.choice([2, 8, 20, 40]), len(points)).cumsum() * 0.3 + rng.normal(0, 15)
    if rng.random() < 0.5:
        points = points[::2]
    if rng.random() < 0.3:
        points = points[::-1]
    if rng.random() < 0.1:
        points = points[[0, -1]]
    if rng.random() < 0.05:
        points = points[:1]
    if rng.random() < 0.03 and len(points) > 3:
        points[2] = points[1]
    return points


def synth_lane_files(out: str | Path, frames: int = 2000, seed: int = 0) -> tuple[Path, Path]:
    """Ground-truth and predicted `.lines.txt` trees for checking and timing a CULane scorer.

    `out/gt` is a CULane root (with list/test.txt), `out/pred` mirrors it. Predictions are
    noisy copies of the ground truth with the awkward cases the official evaluator must
    handle: missed and extra lanes, 2-point, 1-point and empty lanes, repeated points,
    reversed point order, lanes outside the image and missing files. Returns (gt, pred).
    """
    rng = np.random.default_rng([seed, 590])
    out = Path(out)
    gt_root, pred_root = out / "gt", out / "pred"
    width, height = IMAGE_WIDTH, IMAGE_HEIGHT
    listing = []

    def lane(x_bottom: float, step: int = 10) -> np.ndarray:
        top = rng.integers(255, 330)
        ys = np.arange(height, top, -step, dtype=float)
        t = (height - ys) / (height - 250)
        xs = x_bottom + (width / 2 - x_bottom) * t + rng.normal(0, 60) * t**2
        return np.stack([xs, ys], 1)

    def text(lanes: list[np.ndarray]) -> str:
        return "".join(" ".join(f"{v:.3f}" for v in points.ravel()) + " \n" for points in lanes)

    for index in range(frames):
        relpath = f"driver_x_30frame/{index // 50:05d}.MP4/{(index % 50) * 30:05d}.jpg"
        listing.append("/" + relpath)
        truth = [lane(x) for x in np.sort(rng.uniform(-300, width + 260, int(rng.integers(0, 5))))]
        predicted = [_awkward_copy(points, rng) for points in truth if not rng.random() < 0.15]
        if rng.random() < 0.2:
            predicted.append(lane(rng.uniform(0, width), step=20))
        if rng.random() < 0.03:
            predicted.append(np.zeros((0, 2)))
        if rng.random() < 0.02:
            predicted.append(np.array([[-900.0, 700.0], [-500.0, 800.0]]))
        stem = image_stem(relpath)
        for root, lanes in ((gt_root, truth), (pred_root, predicted)):
            path = root / f"{stem}.lines.txt"
            path.parent.mkdir(parents=True, exist_ok=True)
            if root is pred_root and rng.random() < 0.04:
                continue
            write_file(path, text(lanes))
    (gt_root / "list").mkdir(parents=True, exist_ok=True)
    write_file(gt_root / "list" / "test.txt", "".join(line + "\n" for line in listing))
    return gt_root, pred_root
