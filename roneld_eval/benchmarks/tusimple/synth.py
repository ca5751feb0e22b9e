"""Synthetic TuSimple sets: the generator's roads as test_label.json (frame 20 of each clip
labelled), with maps of all 20 frames or a detector's predictions.json."""

from __future__ import annotations

import json
import posixpath
from pathlib import Path

import numpy as np

from ...output import write_file
from ...synth import (Camera, Scene, SynthResult, write_maps, channel_lanes, clip_style, detector_lanes,
                     render_maps, scene_sequence)
from .reader import IMAGE_HEIGHT, IMAGE_WIDTH

CAMERA = Camera(IMAGE_WIDTH, IMAGE_HEIGHT, vanish_y=(265, 300), lane_width_px=(620, 780), top_margin_px=(10, 25))
ROWS = tuple(range(160, 720, 10))  # the label files' h_samples


def tusimple_lanes(scene: Scene, rng: np.random.Generator) -> list[list[int]]:
    """The frame's ground truth as TuSimple lanes: x per h_samples row, -2 outside; unordered."""
    ys = np.array(ROWS, np.float64)
    lanes = []
    for _, lateral in sorted(channel_lanes(scene).items()):
        xs = scene.boundary_x(lateral, ys)
        valid = (ys >= scene.top_y) & (xs >= 0) & (xs < scene.width)
        if valid.sum() < 4:
            continue
        lanes.append([int(round(x)) if ok else -2 for x, ok in zip(xs, valid)])
    order = rng.permutation(len(lanes))
    return [lanes[i] for i in order]


def synth_tusimple(out: str | Path, clips: int = 3, frames: int = 20, seed: int = 0, maps_format: str = "npy",
                   progress=None) -> SynthResult:
    """Write a TuSimple-layout dataset (`out/data/test_label.json`) and its maps (`out/maps`)."""
    out = Path(out)
    data_root, maps_root = out / "data", out / "maps"
    data_root.mkdir(parents=True, exist_ok=True)
    records, predictions = [], []
    rows = np.array(ROWS)
    total = 0
    for index in range(clips):
        rng = np.random.default_rng([seed, index])
        style, _ = clip_style(index, rng, frames, quality=0.8, noise_blobs=5.0, false_positive_rate=0.4,
                              vanish_every_other=True)
        scenes = scene_sequence(CAMERA, frames, style, rng, frames_apart=1)
        clip_id = posixpath.join("clips", f"05{30 + index % 2:02d}", f"{1492626760788443246 + 7919 * index}_0")
        detector = np.random.default_rng([seed, index, 1])  # lane files: the detector's own noise
        for k, scene in enumerate(scenes):
            if maps_format == "lanes":
                predictions.append(_tusimple_prediction(posixpath.join(clip_id, f"{k + 1}.jpg"),
                                                        detector_lanes(scene, style, k, detector, rows)))
            else:
                write_maps(maps_root / clip_id / str(k + 1), render_maps(scene, style, k, rng), maps_format)
            total += 1
            if progress is not None:
                progress(1)
        # The key order and spacing of TuSimple's own label files.
        records.append(json.dumps({
            "lanes": tusimple_lanes(scenes[-1], rng),
            "h_samples": list(ROWS),
            "raw_file": posixpath.join(clip_id, f"{frames}.jpg"),
        }))
    write_file(data_root / "test_label.json", "".join(record + "\n" for record in records))
    if maps_format == "lanes":
        maps_root.mkdir(parents=True, exist_ok=True)
        write_file(maps_root / "predictions.json", "".join(line + "\n" for line in predictions))
    return SynthResult(data_root, maps_root, "tusimple", maps_format, clips, total)


def _tusimple_prediction(raw_file: str, lanes: list[tuple[np.ndarray, float]]) -> str:
    """A detector's TuSimple output line: x per h_samples row (-2 where the lane is not), scores."""
    lanes_xs = []
    for points, _ in lanes:
        at_row = {int(y): x for x, y in points}
        lanes_xs.append([round(float(at_row[y]), 2) if y in at_row else -2 for y in ROWS])
    return json.dumps({"raw_file": raw_file, "lanes": lanes_xs, "h_samples": list(ROWS), "run_time": 0,
                       "scores": [round(score, 3) for _, score in lanes]})
