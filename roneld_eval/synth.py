"""A deterministic generator of small, realistic lane datasets with stored maps: the roads, the
maps and the detector's lanes; each benchmark writes them in its own layout (`synthesize`).

A clip is a road seen from a car: lane boundaries converge to a vanishing point, may curve,
and shift when the car changes lanes. Ground truth is the true boundaries in the benchmark's
own format. Maps imitate an SCNN-like model (4 channels: outer left, ego left, ego right,
outer right, 288x800 over the whole frame) with what RONELD is meant to fix, in controlled
amounts: faded and dashed lanes (gaps along a lane), low-confidence noise, false-positive
blobs, ego lanes that vanish for a few frames, curves and a lane change. Same seed, same
bytes: every clip draws from its own generator seeded by (seed, clip index).
"""

from __future__ import annotations

import math
import shlex
from dataclasses import dataclass, replace
from pathlib import Path
from typing import TYPE_CHECKING

import cv2
import numpy as np

from .errors import InputError
from .output import write_file

if TYPE_CHECKING:
    from .benchmarks import Benchmark

CHANNELS = 4
MAP_WIDTH, MAP_HEIGHT = 800, 288


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
class Camera:
    """Where the road lies in a benchmark's frames: ranges the clip's camera is drawn from."""

    width: int
    height: int
    vanish_y: tuple[float, float]  # row of the vanishing point
    lane_width_px: tuple[float, float]  # between two boundaries at the bottom row
    top_margin_px: tuple[float, float]  # highest visible lane row, below the vanishing point


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


def scene_sequence(camera: Camera, n_frames: int, style: ClipStyle, rng: np.random.Generator,
                   frames_apart: int) -> list[Scene]:
    """A clip's scenes; `frames_apart` video frames between two stored frames (30 for CULane)."""
    width, height = camera.width, camera.height
    vanish_x = width / 2 + rng.normal(0, width * 0.02)
    vanish_y = rng.uniform(*camera.vanish_y)
    lane_width = rng.uniform(*camera.lane_width_px)
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
            top_y=vanish_y + rng.uniform(*camera.top_margin_px),
        ))
    return scenes


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


def clip_style(index: int, rng: np.random.Generator, n_frames: int, quality: float = 1.0,
               noise_blobs: float = 3.0, false_positive_rate: float = 0.3,
               vanish_every_other: bool = False) -> tuple[ClipStyle, str]:
    """A varied but deterministic mix: plain, curved, lane change, and vanishing ego lanes; the
    clip's kind as a CULane category name. The keywords set a benchmark's own mix."""
    kind = ("normal", "curve", "lane-change", "vanish")[index % 4]
    vanish: tuple[int, ...] = ()
    if kind == "vanish" or (vanish_every_other and index % 2 == 1):
        start = int(rng.integers(1, max(n_frames - 3, 2)))
        vanish = tuple(range(start, min(start + 3, n_frames)))
    style = ClipStyle(
        quality=quality,
        curved=kind == "curve",
        lane_change=kind == "lane-change",
        vanish_frames=vanish,
        vanish_channel=int(rng.choice([1, 2])),
        noise_blobs=noise_blobs,
        false_positive_rate=false_positive_rate,
    )
    category = {"normal": "normal", "curve": "curve", "lane-change": "crowd", "vanish": "shadow"}[kind]
    return style, category


def write_maps(path: Path, maps: np.ndarray, maps_format: str) -> None:
    """One frame's (C, H, W) uint8 maps at `path` (its suffix replaced) in `maps_format` (npy,
    npz, scnn-png), as a model's test script stores them."""
    path.parent.mkdir(parents=True, exist_ok=True)
    if maps_format == "npy":
        write_file(path.with_suffix(".npy"), npy_bytes(maps))
    elif maps_format == "npz":
        existence = (maps.reshape(CHANNELS, -1).max(axis=1) > 127).astype(np.float32)
        # np.savez_compressed stamps zip entries with the current time; write our own archive
        # with a fixed date so the same seed gives the same bytes.
        _save_npz_deterministic(path.with_suffix(".npz"), probs=maps, exist=existence)
    elif maps_format == "scnn-png":
        for channel in range(CHANNELS):
            write_file(path.with_name(f"{path.name}_{channel + 1}_avg.png"), png_bytes(maps[channel]))
        existence = (maps.reshape(CHANNELS, -1).max(axis=1) > 127).astype(int)
        write_file(path.with_name(path.name + ".exist.txt"), " ".join(map(str, existence)) + " \n")
    else:
        raise InputError(None, f"unknown maps format {maps_format!r}")


def _save_npz_deterministic(path: Path, **arrays: np.ndarray) -> None:
    write_file(path, npz_bytes(arrays, compresslevel=9))


def npy_bytes(array: np.ndarray) -> bytes:
    """What np.save writes, made in memory: written through write_file, a full disk names the file."""
    import io

    buffer = io.BytesIO()
    np.save(buffer, array)
    return buffer.getvalue()


def png_bytes(image: np.ndarray) -> bytes:
    """What cv2.imwrite writes, made in memory: imwrite says nothing of a full disk but libpng's
    own line on stderr, and returns False, leaving the file short or missing."""
    done, encoded = cv2.imencode(".png", image)
    if not done:
        raise ValueError("OpenCV could not encode the image as PNG")
    return encoded.tobytes()


def npz_bytes(arrays: dict[str, np.ndarray], compresslevel: int | None = None) -> bytes:
    """An .npz archive of these arrays (no pickles) whose bytes depend on them alone: np.savez
    stamps its members with the time, these have a fixed date."""
    import io
    import zipfile

    out = io.BytesIO()
    with zipfile.ZipFile(out, "w", compression=zipfile.ZIP_DEFLATED) as archive:
        for name, array in arrays.items():
            buffer = io.BytesIO()
            np.lib.format.write_array(buffer, np.ascontiguousarray(array), allow_pickle=False)
            info = zipfile.ZipInfo(f"{name}.npy", date_time=(1980, 1, 1, 0, 0, 0))
            info.compress_type = zipfile.ZIP_DEFLATED
            archive.writestr(info, buffer.getvalue(), compresslevel=compresslevel)
    return out.getvalue()


@dataclass(frozen=True)
class SynthResult:
    """Where a generated dataset lies and the command that evaluates it."""

    data_root: Path
    maps_root: Path
    dataset: str
    maps_format: str
    n_clips: int
    n_frames: int
    # a benchmark scored from lane files only: data_root holds the labels, maps_root a detector's
    # predictions, and these words score them
    score_command: tuple[str, ...] | None = None

    @property
    def command(self) -> str:
        """The command line that evaluates the set, quoted for a POSIX shell (a path may hold spaces)."""
        if self.score_command is not None:
            return shlex.join(self.score_command)
        return shlex.join(["roneld-eval", "run", "--dataset", self.dataset, "--data-root", str(self.data_root),
                           "--maps-root", str(self.maps_root), "--maps-format", self.maps_format])


def lane_file_scenes(camera: Camera, clips: int, frames: int, seed: int, maps: bool = False):
    """For a benchmark scored from lane files: per clip and frame, (clip, frame index, its scene,
    the ground-truth lanes as (N, 2) image points every 10 rows from the bottom, a detector's
    lanes as (points, score)), deterministic in `seed`; with `maps`, a sixth item: the frame's
    (4, 288, 800) probability maps (drawn after the scenes, so the rest is the same either way)."""
    for index in range(clips):
        rng = np.random.default_rng([seed, index])
        style, _ = clip_style(index, rng, frames)
        detector = np.random.default_rng([seed, index, 1])
        rows = np.arange(camera.height - 1, 0, -10)[::-1]
        for k, scene in enumerate(scene_sequence(camera, frames, style, rng, frames_apart=30)):
            ys = np.arange(scene.height - 1, scene.top_y, -10.0)
            truth = []
            for _, lateral in sorted(channel_lanes(scene).items()):
                xs = scene.boundary_x(lateral, ys)
                keep = (xs >= 0) & (xs < scene.width)
                if keep.sum() >= 4:
                    truth.append(np.stack([xs[keep], ys[keep]], axis=1))
            detected = detector_lanes(scene, style, k, detector, rows)
            if maps:
                yield index, k, scene, truth, detected, render_maps(scene, style, k, rng)
            else:
                yield index, k, scene, truth, detected


def synthesize(dataset: "str | Benchmark", out: str | Path, clips: int = 3, frames: int | None = None, seed: int = 0,
               maps_format: str | None = None, progress=None) -> SynthResult:
    """Generate a dataset of a registered benchmark (the library twin of `roneld-eval synth`).

    `out` is an output folder as a run's is (roneld_eval.output): a new or empty folder, or one an
    earlier `synth` wrote, whose set this one replaces whole; a folder holding anything else is
    refused before anything is written (`synth --out /etc` wrote data/ and maps/ into it)."""
    from .output import OutputFolder
    from .resolve import benchmark_of

    benchmark = benchmark_of(dataset)
    maps_format = maps_format or str(getattr(benchmark, "synth_maps_format", "npy"))
    out = Path(out)
    with OutputFolder(out, "synth") as folder:
        staging = folder.staging()
        made = benchmark.synthesize(staging, clips, frames or benchmark.frames_per_clip, seed, maps_format, progress)
        folder.commit()
    return _moved(made, staging, out)


def _moved(made: SynthResult, staging: Path, out: Path) -> SynthResult:
    """The set as it lies after the commit: its roots and command under `out`, not the staging
    folder it was written into (a name made unique by tempfile, so replacing it is exact)."""
    command = made.score_command
    return replace(made, data_root=out / Path(made.data_root).relative_to(staging),
                   maps_root=out / Path(made.maps_root).relative_to(staging),
                   score_command=None if command is None else
                   tuple(word.replace(str(staging), str(out), 1) for word in command))


def scene_lines_txt(scene: Scene, inside: bool = False) -> str:
    """The frame's ground truth as a raw `.lines.txt` (CULane's label format): up to 4 lanes, left to right.

    Points every 10 px from the bottom row up, x may leave the image a little (as in CULane);
    with `inside`, every point within the image (as VIL-100's labels: a label reaching past its
    video's size is what `score vil100`'s size warning looks for).
    """
    ys = np.arange(scene.height - 1 if inside else scene.height, scene.top_y, -10.0)
    lines = []
    for _, lateral in sorted(channel_lanes(scene).items()):
        xs = scene.boundary_x(lateral, ys)
        keep = (xs >= 0) & (xs <= scene.width - 1) if inside else (xs > -60) & (xs < scene.width + 60)
        if keep.sum() < 4:
            continue
        lines.append("".join(f"{x:.3f} {int(y)} " for x, y in zip(xs[keep], ys[keep])))
    return "".join(line + "\n" for line in lines)


def write_lines_txt(stem: Path, lanes: list[tuple[np.ndarray, float]]) -> None:
    """A detector's `.lines.txt` output: <stem>.lines.txt, and <stem>.scores.txt with its lane scores."""
    stem.parent.mkdir(parents=True, exist_ok=True)
    write_file(stem.with_name(stem.name + ".lines.txt"),
               "".join(" ".join(f"{x:.2f} {int(y)}" for x, y in points[::-1]) + "\n" for points, _ in lanes))
    write_file(stem.with_name(stem.name + ".scores.txt"), "".join(f"{score:.3f}\n" for _, score in lanes))
