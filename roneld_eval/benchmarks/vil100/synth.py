"""Synthetic VIL-100 sets: the generator's roads as videos of several native sizes (as VIL-100
ships them), every third video frame stored, ground truth as MMA-Net's anno_txt, the videos'
sizes in sizes.json (there are no images), and maps or a detector's lane files (MMA-Net's
pred_txt layout) under the maps root."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from ...output import write_file
from ...synth import (Camera, SynthResult, write_maps, clip_style, detector_lanes, render_maps, scene_lines_txt,
                     scene_sequence, write_lines_txt)
from .reader import LABELS_FOLDER, SIZES_FILE

# VIL-100's sizes, most common first (the test set: 14 videos at 1920x1080, 2 at 1280x720, 2 at
# 960x480, one at 960x474 and one at 672x378), and names led by scenario codes as its own.
SIZES = ((1920, 1080), (960, 480), (1280, 720), (672, 378), (960, 474))
SCENARIO_CODES = ("0", "1", "25", "4", "1269", "8")
FRAMES_APART = 3  # VIL-100 keeps every third frame of its videos: 00000, 00003, ...


def _camera(width: int, height: int) -> Camera:
    return Camera(width, height, vanish_y=(0.42 * height, 0.5 * height),
                  lane_width_px=(0.5 * width, 0.6 * width), top_margin_px=(0.02 * height, 0.06 * height))


def synth_vil100(out: str | Path, clips: int = 3, frames: int = 100, seed: int = 0, maps_format: str = "npy",
                 progress=None) -> SynthResult:
    """Write `out/data` (anno_txt/<video>/<frame>.lines.txt and sizes.json) and `out/maps`."""
    out = Path(out)
    data_root, maps_root = out / "data", out / "maps"
    labels = data_root / LABELS_FOLDER
    sizes = {}
    total = 0
    for index in range(clips):
        width, height = SIZES[index % len(SIZES)]
        name = f"{SCENARIO_CODES[index % len(SCENARIO_CODES)]}_Road{index + 1:03d}_Trim{(index % 9) + 1:03d}_frames"
        sizes[name] = {"width": width, "height": height}
        rng = np.random.default_rng([seed, index])
        style, _ = clip_style(index, rng, frames)
        scenes = scene_sequence(_camera(width, height), frames, style, rng, frames_apart=FRAMES_APART)
        detector = np.random.default_rng([seed, index, 1])
        rows = np.arange(height - 1, 0, -max(1, height // 54))[::-1]  # about 54 points a lane, as VIL-100's
        for k, scene in enumerate(scenes):
            stem = f"{name}/{FRAMES_APART * k:05d}"
            path = labels / f"{stem}.lines.txt"
            path.parent.mkdir(parents=True, exist_ok=True)
            write_file(path, scene_lines_txt(scene, inside=True))
            if maps_format == "lanes":
                write_lines_txt(maps_root / stem, detector_lanes(scene, style, k, detector, rows))
            else:
                write_maps(maps_root / stem, render_maps(scene, style, k, rng), maps_format)
            total += 1
            if progress is not None:
                progress(1)
    write_file(data_root / SIZES_FILE, json.dumps(sizes, indent=1) + "\n")
    return SynthResult(data_root, maps_root, "vil100", maps_format, clips, total)
