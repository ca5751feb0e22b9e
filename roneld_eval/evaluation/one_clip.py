"""One clip through every method in frame order: its maps read ahead in a thread, each
method's extractor built once for the clip (RONELD's tracking state inside), its labelled frames
scored. Runs in a worker process, or in the main one with --workers 1."""

from __future__ import annotations

import itertools
import time
from collections import deque
from concurrent.futures import Future, ThreadPoolExecutor
from pathlib import Path
from typing import Callable, Iterator, Sequence, TypeVar

from ..config import EvalConfig
from ..errors import ExtractorError, InputError
from ..extract.protocol import Extractor, Prediction, is_stateless, one_time_seconds
from ..extract.registry import Method, loaded_code
from ..geometry import EffectiveGeometry, MapGeometry, check_map_shape
from ..maps import map_stem, required_paths
from ..maps.formats import LANE_FILES, map_format
from ..metrics.paper import ego_masks, side_ious
from ..model import Clip, Frame, FrameMaps
from .plugin_call import in_plugin_call, plugin_prediction, raised_text
from .records import ClipResult, FrameOutcome, RunContext

_T = TypeVar("_T")


# ---- one clip ------------------------------------------------------------------------------


def _geometry_for(context: RunContext, frame: Frame, maps: FrameMaps, where: Path) -> MapGeometry:
    geometry = context.config.geometry_of(frame)
    check_map_shape(geometry, maps.width, maps.height, str(where))
    return geometry.with_map_size(maps.width, maps.height)


def effective_geometry(config: EvalConfig, map_width: int, map_height: int,
                       frame_sizes: tuple[tuple[int, int], ...] = ()) -> EffectiveGeometry:
    """The geometry and thicknesses a run really uses for maps of this size (`frame_sizes`: the
    frames' own sizes, where they have them)."""
    geometry = config.geometry.with_map_size(map_width, map_height)
    paper = config.paper
    return EffectiveGeometry(
        image_width=geometry.image_width, image_height=geometry.image_height,
        map_width=map_width, map_height=map_height,
        crop_top_px=geometry.crop_top_px, crop_bottom_px=geometry.crop_top_px + geometry.crop_height_px,
        rescaled=(map_width, map_height) != (config.maps.width, config.maps.height),
        gt_thickness_px=paper.thickness(paper.gt_thickness_px, map_width, map_height),
        pred_thickness_px=paper.thickness(paper.pred_thickness_px, map_width, map_height),
        official_lane_width_px=config.official.lane_width_px,
        official_iou_threshold=config.official.iou_threshold, frame_sizes=frame_sizes,
    )


def evaluate_clip(clip: Clip, context: RunContext,
                  advance: Callable[[int], object] | None = None) -> ClipResult:
    """Run every method over one clip in frame order (RONELD's tracking carries from frame to
    frame) and score its labelled frames."""
    config = context.config
    result = ClipResult(clip_id=clip.clip_id, n_frames=len(clip.frames))
    listed = len(clip.frames)
    if context.labels_root is not None:
        errors: list[InputError] | None = [] if config.on_error == "skip" else None
        clip = context.benchmark.with_labels(clip, context.labels_root, errors)
        result.skipped = [f"{error} (labels skipped)" for error in errors or ()]
        result.n_frames = len(clip.frames)
    result.extract_ms = {method.name: [] for method in context.methods}
    run = _ClipRun(context, result)
    for frame, loaded, load_ms in _told(_prefetched(clip.frames, context), advance):
        try:
            run.frame(frame, loaded, load_ms)
        except (InputError, ExtractorError) as error:
            if config.on_error != "skip":
                raise
            # Neither scored nor seen by RONELD (as a dropped frame), and for every method, so
            # that all are scored on the same frames.
            _leave_out(result, error)
    if advance is not None and listed > len(clip.frames):
        advance(listed - len(clip.frames))  # frames whose labels were left out
    result.plugin_code = loaded_code(context.methods)
    return result


class _ClipRun:
    """One clip's state from frame to frame: each method's extractor (built on the first frame
    with maps, for their geometry), the clip's map shape, and its result so far."""

    def __init__(self, context: RunContext, result: ClipResult):
        self.context, self.result = context, result
        self.extractors: list[tuple[Method, Extractor, bool]] | None = None
        self.map_shape: tuple[int, ...] | None = None
        self.geometry: MapGeometry | None = None

    def frame(self, frame: Frame, loaded: FrameMaps | InputError, load_ms: float) -> None:
        """Extract one frame with every method and score it if labelled; raises the frame's
        InputError or ExtractorError (the caller skips it or stops)."""
        if isinstance(loaded, InputError):
            raise loaded
        maps = loaded
        if self.map_shape is not None and maps.probabilities.shape != self.map_shape:
            raise InputError(frame_map_path(self.context, frame), f"maps of shape {maps.probabilities.shape} "
                             f"differ from the clip's first frame {self.map_shape}")
        self.result.load_ms.append(load_ms)
        if self.extractors is None:
            self.map_shape = maps.probabilities.shape
            self.geometry = _geometry_for(self.context, frame, maps, frame_map_path(self.context, frame))
            self.extractors = [_built(method, self.geometry, frame) for method in self.context.methods]
            self.result.map_size = (maps.width, maps.height)
        config = self.context.config
        predictions = _predictions(self.extractors, maps, frame, self.result.extract_ms, config)
        if frame.labelled:
            assert self.geometry is not None
            outcomes = _score_frame(frame, predictions, self.geometry, self.context)
            # Lanes travel back to the main process only when they are to be saved.
            self.result.outcomes += outcomes if config.save_lanes else [o.without_lanes() for o in outcomes]
            self.result.n_scored += 1
            self.result.n_gt_lanes += len(frame.lanes)


def _told(items: Iterator[_T], advance: Callable[[int], object] | None) -> Iterator[_T]:
    """The items, telling `advance` of each once the caller is done with it (skipped or not)."""
    for item in items:
        yield item
        if advance is not None:
            advance(1)


# Frames whose maps are read ahead of the one being extracted and scored, in a thread of the
# same process: decoders (OpenCV, zlib) release the GIL, so reading overlaps the work.
PREFETCH_FRAMES = 3


def _prefetched(frames: Sequence[Frame], context: RunContext) -> Iterator[tuple[Frame, FrameMaps | InputError, float]]:
    """(frame, its maps or the InputError loading raised, ms spent loading) in frame order."""

    def load(frame: Frame) -> tuple[Frame, FrameMaps | InputError, float]:
        start = time.perf_counter()
        try:
            maps: FrameMaps | InputError = context.load(frame)
        except InputError as error:
            maps = error
        return frame, maps, (time.perf_counter() - start) * 1e3

    if len(frames) <= 1:
        yield from map(load, frames)
        return
    with ThreadPoolExecutor(1, thread_name_prefix="roneld-eval-load") as reader:
        pending: deque[Future] = deque()
        upcoming = iter(frames)
        try:
            for frame in itertools.islice(upcoming, PREFETCH_FRAMES):
                pending.append(reader.submit(load, frame))
            while pending:
                done = pending.popleft().result()
                following = next(upcoming, None)
                if following is not None:
                    pending.append(reader.submit(load, following))
                yield done
        finally:
            for future in pending:
                future.cancel()


def _leave_out(result: ClipResult, error: Exception) -> None:
    """A frame skipped under --on-error skip: listed, and not counted as evaluated."""
    result.skipped.append(f"{error} (frame skipped)")
    result.n_frames -= 1


def _built(method: Method, geometry: MapGeometry, frame: Frame) -> tuple[Method, Extractor, bool]:
    """(method, its extractor for this clip, whether it is stateless)."""
    if method.built_in:
        extractor = method.build(geometry)
    else:
        try:
            with in_plugin_call(method.name, frame.relpath):  # its factory may end the process too
                extractor = method.build(geometry)
        except (Exception, SystemExit) as error:  # a plug-in's own bug: name it, not the runner's frames
            problem = f"building the extractor raised {raised_text(error)}"
            raise ExtractorError(method.name, frame.relpath, problem) from None
        if not callable(extractor):
            raise ExtractorError(method.name, frame.relpath,
                                 f"the factory returned {type(extractor).__name__}, not a callable extractor")
    return method, extractor, is_stateless(extractor)


def _predictions(extractors: list[tuple[Method, Extractor, bool]], maps: FrameMaps, frame: Frame,
                 extract_ms: dict[str, list[float]], config: EvalConfig) -> dict[str, Prediction]:
    """Every method's prediction for one frame (stateless methods only where it is scored)."""
    predictions = {}
    for method, extractor, stateless in extractors:
        if stateless and not frame.labelled:
            continue
        if method.built_in:
            once = one_time_seconds()
            start = time.perf_counter()
            prediction = extractor(maps)
            elapsed = time.perf_counter() - start - (one_time_seconds() - once)
            extract_ms[method.name].append(elapsed * 1e3)
        else:
            prediction = plugin_prediction(method, extractor, maps, frame, extract_ms, config)
        predictions[method.name] = prediction
    return predictions



def frame_map_path(context: RunContext, frame: Frame) -> Path:
    """The file to name when a frame's maps are wrong: the first map image where there are several."""
    maps = context.config.maps
    path = required_paths(context.maps_root, frame.relpath, maps, context.lane_files)[0]
    images = None if maps.format == LANE_FILES else map_format(maps.format).images
    if images is not None:  # path may be a file beside the images (SCNN's .exist.txt)
        path = next((image for image in images(map_stem(context.maps_root, frame.relpath), maps.lane_channels)
                     if image.is_file()), path)
    return path


def _score_frame(frame: Frame, predictions: dict[str, Prediction], geometry: MapGeometry,
                 context: RunContext) -> list[FrameOutcome]:
    """Every method's paper-protocol IoUs and official record for one labelled frame."""
    config = context.config
    gt_masks = ego_masks(frame.lanes, geometry, config.paper, config.roneld.center_ratio)
    truth = context.benchmark.prepare(frame, config)
    outcomes = []
    for method, prediction in predictions.items():
        ious = side_ious(gt_masks, prediction.active, geometry, config.paper, spline=prediction.spline)
        official = context.benchmark.score(truth, prediction, config)
        outcomes.append(FrameOutcome(frame.relpath, method, ious, official, prediction.lanes, prediction.active))
    return outcomes
