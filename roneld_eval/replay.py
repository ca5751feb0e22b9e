"""`roneld-eval replay`: one recorded clip through `RoneldTracker.update`, frame by frame, as a
vehicle would run it: the latency of every call, the paper's ego-lane accuracy where the clip has
ground truth (the run's own metric: metrics.paper, metrics.sweep), and an MP4 to watch the drive.

The clip is a folder of one clip's maps (frames in name order, no ground truth), or a clip of a
dataset tree (`data_root`: its frames in the dataset's order and its labels), maps read by the
run's loader in any format, a detector's lane files included. Nothing else is written.
"""

from __future__ import annotations

import contextlib
import os
import posixpath
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Callable, Iterator

import numpy as np

from .benchmarks import Benchmark
from .config import EvalConfig
from .datasets import load_labels, read_dataset
from .resolve import configured
from .datasets._paths import under_root
from .errors import ConfigError, InputError
from .evaluation.one_clip import frame_map_path
from .evaluation.records import RunContext
from .extract.online import FrameRefused, Latency, warm_up
from .methods import PAPER
from .extract.protocol import Prediction
from .extract.roneld import RoneldTracker
from .geometry import MapGeometry, check_map_shape
from .maps import frames_in_folder
from .metrics.paper import ego_lanes, ego_masks, side_ious
from .metrics.sweep import sweep_accuracy
from .model import Clip, Dataset, Frame, image_stem
from .presets import nearest
from .progress import progress_bar
from .thresholds import parse_thresholds

if TYPE_CHECKING:
    import pandas as pd

# Frames per second of the video: CULane's clips keep one frame in 30 (1 s of driving), VIL-100's one in 3.
DEFAULT_FPS = 10
IMAGE_SUFFIXES = (".jpg", ".png", ".jpeg")
BLANK_BGR = (40, 40, 40)  # where a frame has no camera image


@dataclass(frozen=True)
class ReplayResult:
    """What a replay measured: `latency` of `update` over every frame (loading the maps apart),
    `accuracy` (method, threshold, n_tp, n_gt, accuracy: the run's accuracy table) over the
    labelled frames, None without ground truth; `video` where the MP4 was written."""

    clip_id: str
    method: str
    frames: int
    scored_frames: int
    map_size: tuple[int, int]
    latency: Latency
    accuracy: pd.DataFrame | None
    video: Path | None
    without_image: tuple[str, ...] = ()  # frames the --images folder had no picture of (a blank canvas)


def replay_clip(config: EvalConfig, clip_id: str | None = None, video: str | Path | None = None,
           images: str | Path | None = None, image_size: tuple[int, int] | None = None, pft: bool = True,
           fps: float = DEFAULT_FPS, progress: bool = False) -> ReplayResult:
    """Replay one clip: `config.maps.root` is a folder of one clip's maps, or with
    `config.dataset.data_root` the dataset's maps root and `clip_id` its clip (needed where the
    dataset holds several). `image_size` (width, height): the camera's, for a folder (default the
    configuration's). `images`: camera frames for the video, `<images>/<frame>` (default the data
    root). `progress`: a bar on stderr where it is a terminal."""
    if config.maps.root is None:
        raise ConfigError("replay needs the clip's maps (--maps-root)")
    maps_root = Path(config.maps.root)
    config, benchmark = configured(config)
    clip = _clip(config, benchmark, clip_id, image_size)
    context = RunContext(config, benchmark, maps_root)
    method = PAPER.ours if pft else PAPER.without_tracking
    tracker = RoneldTracker(config.roneld, config.geometry_of(clip.frames[0]), pft=pft,
                            lane_channels=config.maps.lane_channels, latency_frames=len(clip.frames))
    warm_up()
    scoring = _Scoring(config, method)
    if images is not None and not Path(images).is_dir():
        raise InputError(images, "no such folder of camera frames (--images)")
    image_root = images if images is not None else config.dataset.data_root
    without_image: list[str] = []
    with _video_file(video, fps) as write, progress_bar(len(clip.frames), "frame", "replaying",
                                                        wanted=progress) as bar:
        geometry: MapGeometry | None = None
        for index, frame in enumerate(clip.frames, start=1):
            maps = context.load(frame)
            if geometry is None:  # as the run, at the clip's first frame (the tracker keeps its size)
                geometry = _checked_geometry(config, frame, maps.width, maps.height, context)
            try:
                prediction = tracker.update(maps.probabilities)
            except FrameRefused as error:  # the run names the map file; so does replay
                raise InputError(frame_map_path(context, frame), error.problem) from None
            ious = scoring.add(frame, prediction, geometry)
            if write is not None:
                background = _background(frame, geometry, image_root)
                if background is None:
                    without_image.append(frame.relpath)
                    background = np.full((*geometry.image_size[::-1], 3), BLANK_BGR, np.uint8)
                write(_picture(frame, prediction, ious, geometry, method, config, background,
                               tracker.latency(), f"{index}/{len(clip.frames)}"))
            bar.update(1)
    name = clip.clip_id or (Path(config.dataset.data_root) if config.dataset.data_root else maps_root).resolve().name
    return ReplayResult(name, method, len(clip.frames), scoring.frames, (maps.width, maps.height),
                        tracker.latency(), scoring.accuracy(), None if video is None else Path(video),
                        tuple(without_image) if images is not None else ())


def _clip(config: EvalConfig, benchmark: Benchmark, clip_id: str | None, image_size: tuple[int, int] | None) -> Clip:
    """The clip to replay, its frames in order (and, from a dataset, with their labels)."""
    maps_root = Path(config.maps.root or ".")
    if config.dataset.data_root is None:
        if clip_id is not None:
            raise ConfigError("--clip chooses a clip of a dataset: give its --data-root too (a folder of maps "
                              "is one clip)")
        from .evaluation.records import lane_files_of

        relpaths = frames_in_folder(maps_root, config.maps, lane_files_of(config, benchmark))
        return Clip(maps_root.name or str(maps_root), tuple(
            Frame(relpath, labelled=False, image_size=image_size) for relpath in relpaths))
    if image_size is not None:
        raise ConfigError("--image-size is for a folder of maps: a dataset's frames have their benchmark's sizes")
    dataset = read_dataset(benchmark, config.dataset.data_root, config.dataset.list_file, labels=False)
    return load_labels(benchmark, dataset, _chosen_clip(dataset, clip_id))


def _chosen_clip(dataset: Dataset, clip_id: str | None) -> Clip:
    """The dataset's clip `clip_id` (None: its only clip), which must have frames."""
    clips = {clip.clip_id: clip for clip in dataset.clips}
    where = dataset.source_file or dataset.root
    if clip_id is None:
        if len(clips) != 1:
            listed = ", ".join(list(clips)[:3]) + (", ..." if len(clips) > 3 else "")
            raise InputError(where, f"the dataset holds {len(clips)} clips: choose one with --clip ({listed})")
        clip_id = next(iter(clips))
    if clip_id not in clips:
        raise InputError(where, f"no clip {clip_id!r} in the dataset{nearest(clip_id, clips)}")
    if not clips[clip_id].frames:
        raise InputError(where, f"clip {clip_id!r} has no frames")
    return clips[clip_id]


def _checked_geometry(config: EvalConfig, frame: Frame, width: int, height: int, context: RunContext) -> MapGeometry:
    """The frame's geometry as the run places its maps (their aspect checked as the run checks it)."""
    geometry = config.geometry_of(frame)
    check_map_shape(geometry, width, height, str(frame_map_path(context, frame)))
    return geometry.with_map_size(width, height)


class _Scoring:
    """The paper's ego-lane IoUs of the labelled frames, as the run measures them (one_clip), and
    the run's accuracy table over them."""

    def __init__(self, config: EvalConfig, method: str):
        self.config, self.method = config, method
        self.rows: list[tuple[str, str, str, float]] = []
        self.frames = 0

    def add(self, frame: Frame, prediction: Prediction, geometry: MapGeometry) -> dict[str, float]:
        if not frame.labelled:
            return {}
        config = self.config
        gt_masks = ego_masks(frame.lanes, geometry, config.paper, config.roneld.center_ratio)
        ious = side_ious(gt_masks, prediction.active, geometry, config.paper, spline=prediction.spline)
        self.rows += [(frame.relpath, side, self.method, iou) for side, iou in ious.items()]
        self.frames += 1
        return ious

    def accuracy(self) -> pd.DataFrame | None:
        if not self.frames:
            return None
        import pandas as pd

        per_frame = pd.DataFrame(self.rows, columns=["frame", "side", "method", "iou"])
        return sweep_accuracy(per_frame, parse_thresholds(self.config.paper.thresholds), methods=[self.method])


# ---- the video ------------------------------------------------------------------------------------


@contextlib.contextmanager
def _video_file(video: str | Path | None, fps: float) -> Iterator[Callable[[np.ndarray], None] | None]:
    """A function writing one BGR picture a frame into an MP4 at `video`, or None without one. The
    file is written beside its place under a temporary name and moved there when the clip is done:
    a replay that fails or is interrupted leaves no half-written video."""
    if video is None:
        yield None
        return
    import cv2

    path = Path(video)
    if path.suffix.lower() != ".mp4":
        raise ConfigError(f"{path}: the video is an MP4: name it <something>.mp4")
    if not path.parent.is_dir():
        raise InputError(path.parent, "no such folder for the video")
    if path.is_dir():
        raise InputError(path, "is a folder: name the video file")
    partial = path.with_name(f".{path.stem}.{os.getpid()}.partial.mp4")
    writer: list = []
    frames_written = [0]

    def write(picture: np.ndarray) -> None:
        if not writer:
            height, width = picture.shape[:2]
            opened = cv2.VideoWriter(str(partial), cv2.VideoWriter.fourcc(*"mp4v"), fps, (width, height))
            if not opened.isOpened():
                raise InputError(path, "cannot write an MP4 here (OpenCV could not open the file or has no MP4 "
                                       "encoder)")
            writer.append(opened)
            writer.append((width, height))
        if picture.shape[1::-1] != writer[1]:
            picture = cv2.resize(picture, writer[1])
        writer[0].write(picture)
        frames_written[0] += 1

    try:
        yield write
        if writer:
            writer[0].release()
            _check_video(partial, path, written=frames_written[0])
            os.replace(partial, path)
    finally:
        if writer:
            writer[0].release()
        with contextlib.suppress(FileNotFoundError):
            partial.unlink()


def _check_video(partial: Path, path: Path, written: int) -> None:
    """OpenCV's writer says nothing when a frame cannot be written (a full disk: the file ends
    without its index): the finished file is read back and must hold every frame written."""
    import cv2

    capture = cv2.VideoCapture(str(partial))
    try:
        frames = int(capture.get(cv2.CAP_PROP_FRAME_COUNT)) if capture.isOpened() else 0
    finally:
        capture.release()
    if frames != written:
        raise InputError(path, f"the video could not be written whole ({frames} of {written} frames readable; "
                               "is the disk full?)")


def _picture(frame: Frame, prediction: Prediction, ious: dict[str, float], geometry: MapGeometry, method: str,
             config: EvalConfig, background: np.ndarray, latency: Latency, position: str) -> np.ndarray:
    """One frame of the video (`position`: 'k/n' in its clip): the camera image (a blank canvas
    without one) with the active lanes, the ground truth's ego lanes and other lanes where
    labelled, IoUs beside the lanes."""
    from .report.overlays import FramePicture, draw_frame

    ground_truth: tuple = (None, None)
    others: tuple = ()
    if frame.labelled:
        ground_truth = ego_lanes(frame.lanes, *geometry.image_size, config.roneld.center_ratio)
        chosen = {id(lane) for lane in ground_truth}
        others = tuple(lane for lane in frame.lanes if id(lane) not in chosen and len(lane) >= 2)
    picture = FramePicture(frame.relpath, ground_truth, {method: prediction.active}, {method: ious}, others)
    scores = "  ".join(f"{side} IoU {iou:.2f}" for side, iou in ious.items()) or (
        "no ground truth" if not frame.labelled else "no ego lane in the ground truth")
    caption = (f"{posixpath.basename(image_stem(frame.relpath))}  {position}  {scores}  "
               f"update p50 {latency.p50_ms:.2f} ms")
    return draw_frame(picture, background, caption)


def _background(frame: Frame, geometry: MapGeometry, image_root: str | Path | None) -> np.ndarray | None:
    """The frame's camera image at the image size, or None where `image_root` has none."""
    import cv2

    width, height = geometry.image_size
    if image_root is not None:
        stem = under_root(image_root, image_stem(frame.relpath))
        for path in [under_root(image_root, frame.relpath)] + [stem.with_name(stem.name + s) for s in IMAGE_SUFFIXES]:
            if path.is_file():
                image = cv2.imread(str(path), cv2.IMREAD_COLOR)
                if image is None:
                    raise InputError(path, "not a readable image")
                return image if image.shape[:2] == (height, width) else cv2.resize(image, (width, height))
    return None
