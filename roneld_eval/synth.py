"""A deterministic generator of small, realistic CULane and TuSimple datasets with stored maps.

A clip is a road seen from a car: lane boundaries converge to a vanishing point, may curve,
and shift when the car changes lanes. Ground truth is the true boundaries in the benchmark's
own format. Maps imitate an SCNN-like model (4 channels: outer left, ego left, ego right,
outer right, 288x800 over the whole frame) with what RONELD is meant to fix, in controlled
amounts: faded and dashed lanes (gaps along a lane), low-confidence noise, false-positive
blobs, ego lanes that vanish for a few frames, curves and a lane change. Same seed, same
bytes: every clip draws from its own generator seeded by (seed, clip index).
"""

from __future__ import annotations

import json
import math
import posixpath
from dataclasses import dataclass
from pathlib import Path
from typing import Iterable

import cv2
import numpy as np

from .config import IMAGE_SIZES
from .errors import InputError
from .model import image_stem

CHANNELS = 4
MAP_WIDTH, MAP_HEIGHT = 800, 288
CULANE_SIZE = IMAGE_SIZES["culane"]
TUSIMPLE_SIZE = IMAGE_SIZES["tusimple"]
TUSIMPLE_ROWS = tuple(range(160, 720, 10))
CULANE_CATEGORIES = ("normal", "crowd", "hlight", "shadow", "noline", "arrow", "curve", "cross", "night")


@dataclass(frozen=True)
class Scene:
    """One frame's road: boundaries as (lateral offset in lane widths, dashed) and the camera."""

    width: int
    height: int
    vanish_x: float
    vanish_y: float
    lane_width_px: float  # between two boundaries at the bottom row
    offset: float  # car position in lane widths (0 = centred in its lane)
    curvature_px: float  # horizontal bend at the vanishing point
    top_y: float  # highest visible row of the lanes

    def boundary_x(self, lateral: float, ys: np.ndarray) -> np.ndarray:
        """Image x of a boundary at rows ys (lateral position in lane widths, car at 0)."""
        t = (ys - self.vanish_y) / (self.height - self.vanish_y)
        return self.vanish_x + t * lateral * self.lane_width_px + self.curvature_px * (1 - t) ** 2


@dataclass(frozen=True)
class ClipStyle:
    """How a clip misbehaves; quality < 1 imitates a model on a dataset it was not trained on."""

    quality: float = 1.0
    curved: bool = False
    lane_change: bool = False
    vanish_frames: tuple[int, ...] = ()  # frames where an ego lane all but disappears
    vanish_channel: int = 1
    noise_blobs: float = 3.0  # mean low-confidence blobs per channel and frame
    false_positive_rate: float = 0.3  # chance per frame of a strong false blob
    dashed_ego: bool = True


def _boundaries(scene: Scene) -> list[float]:
    """Lateral positions of the boundaries around the car, relative to the car."""
    first = math.floor(-scene.offset - 2.5)
    return [k + 0.5 - scene.offset for k in range(first, first + 7)]


def channel_lanes(scene: Scene) -> dict[int, float]:
    """The boundary each model channel sees: 0 outer left .. 3 outer right (lateral positions)."""
    lateral = sorted(_boundaries(scene))
    left = [u for u in lateral if u < 0]
    right = [u for u in lateral if u >= 0]
    out = {}
    if left:
        out[1] = left[-1]
    if len(left) > 1:
        out[0] = left[-2]
    if right:
        out[2] = right[0]
    if len(right) > 1:
        out[3] = right[1]
    return out


def _dash_mask(scene: Scene, ys: np.ndarray, phase: float, period: float = 1.0, duty: float = 0.45) -> np.ndarray:
    """1 on the painted parts of a dashed line, 0 in its gaps (periodic in road distance)."""
    depth = (scene.height - scene.vanish_y) / np.maximum(ys - scene.vanish_y, 1.0)
    return ((depth / period * 0.9 + phase) % 1.0) < duty


def _gaussian_blob(plane: np.ndarray, cx: float, cy: float, sigma_x: float, sigma_y: float, peak: float) -> None:
    height, width = plane.shape
    x0, x1 = int(max(cx - 3 * sigma_x, 0)), int(min(cx + 3 * sigma_x + 1, width))
    y0, y1 = int(max(cy - 3 * sigma_y, 0)), int(min(cy + 3 * sigma_y + 1, height))
    if x1 <= x0 or y1 <= y0:
        return
    xs = np.arange(x0, x1) - cx
    ys = np.arange(y0, y1)[:, None] - cy
    patch = peak * np.exp(-(xs**2) / (2 * sigma_x**2) - (ys**2) / (2 * sigma_y**2))
    np.maximum(plane[y0:y1, x0:x1], patch, out=plane[y0:y1, x0:x1])


def render_maps(scene: Scene, style: ClipStyle, frame_index: int, rng: np.random.Generator) -> np.ndarray:
    """(4, 288, 800) uint8 probability maps of one frame."""
    maps = np.zeros((CHANNELS, MAP_HEIGHT, MAP_WIDTH), np.float32)
    rows = np.arange(MAP_HEIGHT)
    ys = (rows + 0.5) * scene.height / MAP_HEIGHT
    visible = ys >= scene.top_y
    t = np.clip((ys - scene.vanish_y) / (scene.height - scene.vanish_y), 0, 1)
    for channel, lateral in channel_lanes(scene).items():
        xs_map = scene.boundary_x(lateral, ys) * MAP_WIDTH / scene.width
        # A stripe of constant width across the lane is wider along a row the flatter it runs.
        slope = np.gradient(xs_map)  # map columns per map row
        sigma = (1.6 + 1.6 * t) * np.sqrt(1 + slope**2)
        reach = int(min(np.ceil(3.5 * sigma.max()), 120))
        offsets = np.arange(-reach, reach + 1)
        peak = rng.uniform(0.75, 1.0) * style.quality * (0.45 + 0.55 * t)
        ego = channel in (1, 2)
        if ego and style.dashed_ego or not ego and rng.random() < 0.3:
            gaps = ~_dash_mask(scene, ys, rng.random())
            peak = np.where(gaps, peak * rng.uniform(0.0, 0.25), peak)
        # Faded stretches: a few rows where the model is unsure.
        for _ in range(rng.poisson(1.0 if style.quality >= 1 else 2.0)):
            centre, length = rng.uniform(0, MAP_HEIGHT), rng.uniform(8, 40)
            peak = np.where(np.abs(rows - centre) < length / 2, peak * rng.uniform(0.15, 0.5), peak)
        if frame_index in style.vanish_frames and channel == style.vanish_channel:
            peak = peak * rng.uniform(0.03, 0.12)
        peak = np.where(visible, peak, 0.0)
        columns = np.rint(xs_map).astype(np.int64)[:, None] + offsets[None, :]
        values = peak[:, None] * np.exp(-((columns - xs_map[:, None]) ** 2) / (2 * sigma[:, None] ** 2))
        inside = (columns >= 0) & (columns < MAP_WIDTH) & (values > 0.004)
        row_index = np.broadcast_to(rows[:, None], columns.shape)
        plane = maps[channel]
        np.maximum.at(plane, (row_index[inside], columns[inside]), values[inside].astype(np.float32))
    for channel in range(CHANNELS):
        for _ in range(rng.poisson(style.noise_blobs / max(style.quality, 0.3))):
            _gaussian_blob(
                maps[channel], rng.uniform(0, MAP_WIDTH), rng.uniform(MAP_HEIGHT * 0.35, MAP_HEIGHT),
                rng.uniform(2, 8), rng.uniform(2, 6), rng.uniform(0.04, 0.28),
            )
    if rng.random() < style.false_positive_rate:
        channel = int(rng.integers(0, CHANNELS))
        cx, cy = rng.uniform(0, MAP_WIDTH), rng.uniform(MAP_HEIGHT * 0.45, MAP_HEIGHT)
        _gaussian_blob(maps[channel], cx, cy, rng.uniform(3, 10), rng.uniform(4, 16), rng.uniform(0.45, 0.9))
    return np.rint(np.clip(maps, 0, 1) * 255).astype(np.uint8)


def scene_sequence(size: tuple[int, int], n_frames: int, style: ClipStyle, rng: np.random.Generator,
                   frames_apart: int) -> list[Scene]:
    """A clip's scenes; `frames_apart` video frames between two stored frames (30 for CULane)."""
    width, height = size
    tusimple = height == TUSIMPLE_SIZE[1]
    vanish_x = width / 2 + rng.normal(0, width * 0.02)
    vanish_y = rng.uniform(265, 300) if tusimple else rng.uniform(245, 275)
    lane_width = rng.uniform(620, 780) if tusimple else rng.uniform(820, 980)
    bend = rng.uniform(150, 320) * rng.choice([-1, 1]) if style.curved else rng.normal(0, 15)
    drift = rng.normal(0, 0.06)
    change_start = int(rng.integers(1, max(n_frames // 3, 2)))
    change_length = max(3, n_frames // 3)
    direction = rng.choice([-1, 1])
    scenes = []
    for k in range(n_frames):
        if style.lane_change:
            progress = np.clip((k - change_start) / change_length, 0, 1)
            offset = direction * progress * 1.0 + drift
        else:
            offset = drift * math.sin(k * frames_apart / 60.0)
        curvature = bend * (0.8 + 0.2 * math.sin(k * frames_apart / 90.0))
        scenes.append(Scene(
            width=width, height=height,
            vanish_x=vanish_x + 10 * math.sin(k * frames_apart / 120.0),
            vanish_y=vanish_y, lane_width_px=lane_width, offset=float(offset), curvature_px=float(curvature),
            top_y=vanish_y + (rng.uniform(10, 25) if tusimple else rng.uniform(12, 45)),
        ))
    return scenes


def culane_lines(scene: Scene) -> str:
    """The frame's ground truth as a raw CULane `.lines.txt`: up to 4 lanes, left to right.

    Points every 10 px from the bottom row up, x may leave the image a little (as in CULane).
    """
    ys = np.arange(scene.height, scene.top_y, -10.0)
    lines = []
    for _, lateral in sorted(channel_lanes(scene).items()):
        xs = scene.boundary_x(lateral, ys)
        keep = (xs > -60) & (xs < scene.width + 60)
        if keep.sum() < 4:
            continue
        lines.append("".join(f"{x:.3f} {int(y)} " for x, y in zip(xs[keep], ys[keep])))
    return "".join(line + "\n" for line in lines)


def tusimple_lanes(scene: Scene, rng: np.random.Generator) -> list[list[int]]:
    """The frame's ground truth as TuSimple lanes: x per h_samples row, -2 outside; unordered."""
    ys = np.array(TUSIMPLE_ROWS, np.float64)
    lanes = []
    for _, lateral in sorted(channel_lanes(scene).items()):
        xs = scene.boundary_x(lateral, ys)
        valid = (ys >= scene.top_y) & (xs >= 0) & (xs < scene.width)
        if valid.sum() < 4:
            continue
        lanes.append([int(round(x)) if ok else -2 for x, ok in zip(xs, valid)])
    order = rng.permutation(len(lanes))
    return [lanes[i] for i in order]


def detector_lanes(scene: Scene, style: ClipStyle, frame_index: int, rng: np.random.Generator,
                   rows: np.ndarray) -> list[tuple[np.ndarray, float]]:
    """A lane detector's output for one frame, as (points (N, 2) in image pixels, score) per lane:
    the true boundaries sampled at `rows`, with a per-lane offset and per-point jitter, shorter
    at the top, an ego lane missed where the style makes it vanish, now and then a false lane."""
    out = []
    for channel, lateral in sorted(channel_lanes(scene).items()):
        if frame_index in style.vanish_frames and channel == style.vanish_channel:
            continue
        top = scene.top_y + rng.uniform(0, 0.25) * (scene.height - scene.top_y)
        ys = rows[(rows >= top) & (rows < scene.height)].astype(np.float64)
        xs = scene.boundary_x(lateral, ys) + rng.normal(0, 6 / style.quality) + rng.normal(0, 1.5, ys.size)
        keep = (xs >= 0) & (xs < scene.width)
        if keep.sum() >= 4:
            out.append((np.stack([xs[keep], ys[keep]], axis=1), float(rng.uniform(0.55, 1.0))))
    if rng.random() < style.false_positive_rate / 2:  # a short false lane somewhere in the road
        ys = rows[(rows >= scene.vanish_y + 0.4 * (scene.height - scene.vanish_y)) & (rows < scene.height)]
        x0 = rng.uniform(0.1, 0.9) * scene.width
        xs = x0 + rng.uniform(-0.6, 0.6) * (ys - ys[0])
        keep = (xs >= 0) & (xs < scene.width)
        if keep.sum() >= 4:
            out.append((np.stack([xs[keep], ys[keep].astype(np.float64)], axis=1), float(rng.uniform(0.3, 0.6))))
    return out


def _write_lane_files(stem: Path, lanes: list[tuple[np.ndarray, float]]) -> None:
    """A detector's CULane output: <stem>.lines.txt, and <stem>.scores.txt with its lane scores."""
    stem.parent.mkdir(parents=True, exist_ok=True)
    stem.with_name(stem.name + ".lines.txt").write_text(
        "".join(" ".join(f"{x:.2f} {int(y)}" for x, y in points[::-1]) + "\n" for points, _ in lanes))
    stem.with_name(stem.name + ".scores.txt").write_text("".join(f"{score:.3f}\n" for _, score in lanes))


def _clip_style(dataset: str, index: int, rng: np.random.Generator, n_frames: int) -> tuple[ClipStyle, str]:
    """A varied but deterministic mix: plain, curved, lane change, and vanishing ego lanes."""
    kind = ("normal", "curve", "lane-change", "vanish")[index % 4]
    quality = 1.0 if dataset == "culane" else 0.8
    vanish: tuple[int, ...] = ()
    if kind == "vanish" or (dataset == "tusimple" and index % 2 == 1):
        start = int(rng.integers(1, max(n_frames - 3, 2)))
        vanish = tuple(range(start, min(start + 3, n_frames)))
    style = ClipStyle(
        quality=quality,
        curved=kind == "curve",
        lane_change=kind == "lane-change",
        vanish_frames=vanish,
        vanish_channel=int(rng.choice([1, 2])),
        noise_blobs=3.0 if dataset == "culane" else 5.0,
        false_positive_rate=0.3 if dataset == "culane" else 0.4,
    )
    category = {"normal": "normal", "curve": "curve", "lane-change": "crowd", "vanish": "shadow"}[kind]
    return style, category


def _write_maps(path: Path, maps: np.ndarray, maps_format: str) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    if maps_format == "npy":
        np.save(path.with_suffix(".npy"), maps)
    elif maps_format == "npz":
        existence = (maps.reshape(CHANNELS, -1).max(axis=1) > 127).astype(np.float32)
        # np.savez_compressed stamps zip entries with the current time; write our own archive
        # with a fixed date so the same seed gives the same bytes.
        _save_npz_deterministic(path.with_suffix(".npz"), probs=maps, exist=existence)
    elif maps_format == "scnn-png":
        for channel in range(CHANNELS):
            cv2.imwrite(str(path.with_name(f"{path.name}_{channel + 1}_avg.png")), maps[channel])
        existence = (maps.reshape(CHANNELS, -1).max(axis=1) > 127).astype(int)
        path.with_name(path.name + ".exist.txt").write_text(" ".join(map(str, existence)) + " \n")
    else:
        raise InputError(None, f"unknown maps format {maps_format!r}")


def _save_npz_deterministic(path: Path, **arrays: np.ndarray) -> None:
    import io
    import zipfile

    with zipfile.ZipFile(path, "w", compression=zipfile.ZIP_DEFLATED) as archive:
        for name, array in arrays.items():
            buffer = io.BytesIO()
            np.lib.format.write_array(buffer, np.ascontiguousarray(array), allow_pickle=False)
            info = zipfile.ZipInfo(f"{name}.npy", date_time=(1980, 1, 1, 0, 0, 0))
            info.compress_type = zipfile.ZIP_DEFLATED
            archive.writestr(info, buffer.getvalue(), compresslevel=9)


@dataclass(frozen=True)
class SynthResult:
    """Where a generated dataset lies and the command that evaluates it."""

    data_root: Path
    maps_root: Path
    dataset: str
    maps_format: str
    n_clips: int
    n_frames: int

    @property
    def command(self) -> str:
        return (
            f"roneld-eval run --dataset {self.dataset} --data-root {self.data_root} "
            f"--maps-root {self.maps_root} --maps-format {self.maps_format}"
        )


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
    categories: dict[str, list[str]] = {name: [] for name in CULANE_CATEGORIES}
    total = 0
    for index, (_clip_id, relpaths) in enumerate(structure):
        rng = np.random.default_rng([seed, index])
        style, category = _clip_style("culane", index, rng, len(relpaths))
        scenes = scene_sequence(CULANE_SIZE, len(relpaths), style, rng, frames_apart=30)
        detector = np.random.default_rng([seed, index, 1])  # lane files: the detector's own noise
        for k, (relpath, scene) in enumerate(zip(relpaths, scenes)):
            stem = image_stem(relpath)
            label_path = data_root / f"{stem}.lines.txt"
            label_path.parent.mkdir(parents=True, exist_ok=True)
            label_path.write_text(culane_lines(scene))
            if maps_format == "lanes":
                rows = np.arange(scene.height - 1, 0, -10)[::-1]
                _write_lane_files(maps_root / stem, detector_lanes(scene, style, k, detector, rows))
            else:
                _write_maps(maps_root / stem, render_maps(scene, style, k, rng), maps_format)
            listing.append("/" + relpath)
            categories[category].append(relpath)
            total += 1
            if progress is not None:
                progress(1)
    (data_root / "list" / "test_split").mkdir(parents=True, exist_ok=True)
    (data_root / "list" / "test.txt").write_text("".join(line + "\n" for line in listing))
    for number, name in enumerate(CULANE_CATEGORIES):
        if categories[name]:
            (data_root / "list" / "test_split" / f"test{number}_{name}.txt").write_text(
                "".join(line + "\n" for line in categories[name])
            )
    return SynthResult(data_root, maps_root, "culane", maps_format, len(structure), total)


def synth_tusimple(out: str | Path, clips: int = 3, frames: int = 20, seed: int = 0, maps_format: str = "npy",
                   progress=None) -> SynthResult:
    """Write a TuSimple-layout dataset (`out/data/test_label.json`) and its maps (`out/maps`)."""
    out = Path(out)
    data_root, maps_root = out / "data", out / "maps"
    data_root.mkdir(parents=True, exist_ok=True)
    records, predictions = [], []
    rows = np.array(TUSIMPLE_ROWS)
    total = 0
    for index in range(clips):
        rng = np.random.default_rng([seed, index])
        style, _ = _clip_style("tusimple", index, rng, frames)
        scenes = scene_sequence(TUSIMPLE_SIZE, frames, style, rng, frames_apart=1)
        clip_id = posixpath.join("clips", f"05{30 + index % 2:02d}", f"{1492626760788443246 + 7919 * index}_0")
        detector = np.random.default_rng([seed, index, 1])  # lane files: the detector's own noise
        for k, scene in enumerate(scenes):
            if maps_format == "lanes":
                predictions.append(_tusimple_prediction(posixpath.join(clip_id, f"{k + 1}.jpg"),
                                                        detector_lanes(scene, style, k, detector, rows)))
            else:
                _write_maps(maps_root / clip_id / str(k + 1), render_maps(scene, style, k, rng), maps_format)
            total += 1
            if progress is not None:
                progress(1)
        # The key order and spacing of TuSimple's own label files.
        records.append(json.dumps({
            "lanes": tusimple_lanes(scenes[-1], rng),
            "h_samples": list(TUSIMPLE_ROWS),
            "raw_file": posixpath.join(clip_id, f"{frames}.jpg"),
        }))
    (data_root / "test_label.json").write_text("".join(record + "\n" for record in records))
    if maps_format == "lanes":
        maps_root.mkdir(parents=True, exist_ok=True)
        (maps_root / "predictions.json").write_text("".join(line + "\n" for line in predictions))
    return SynthResult(data_root, maps_root, "tusimple", maps_format, clips, total)


def _tusimple_prediction(raw_file: str, lanes: list[tuple[np.ndarray, float]]) -> str:
    """A detector's TuSimple output line: x per h_samples row (-2 where the lane is not), scores."""
    lanes_xs = []
    for points, _ in lanes:
        at_row = {int(y): x for x, y in points}
        lanes_xs.append([round(float(at_row[y]), 2) if y in at_row else -2 for y in TUSIMPLE_ROWS])
    return json.dumps({"raw_file": raw_file, "lanes": lanes_xs, "h_samples": list(TUSIMPLE_ROWS), "run_time": 0,
                       "scores": [round(score, 3) for _, score in lanes]})


def synthesize(dataset: str, out: str | Path, clips: int = 3, frames: int | None = None, seed: int = 0,
               maps_format: str = "npy", progress=None) -> SynthResult:
    """Generate a dataset by name (the library twin of `roneld-eval synth`)."""
    if dataset == "culane":
        return synth_culane(out, clips, frames or 12, seed, maps_format, progress=progress)
    if dataset == "tusimple":
        return synth_tusimple(out, clips, frames or 20, seed, maps_format, progress=progress)
    raise InputError(None, f"unknown dataset {dataset!r}")


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
    width, height = CULANE_SIZE
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
        predicted = []
        for points in truth:
            if rng.random() < 0.15:
                continue
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
            predicted.append(points)
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
            path.write_text(text(lanes))
    (gt_root / "list").mkdir(parents=True, exist_ok=True)
    (gt_root / "list" / "test.txt").write_text("".join(line + "\n" for line in listing))
    return gt_root, pred_root
