"""Pictures of chosen frames: each frame's clip is replayed up to it (RONELD's state), drawn on
the camera image (or, without one, on the maps as a heat map), with every method's lanes and
their IoUs. Three steps: `replay`, `background`, `frame_pictures` (drawing)."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path
from typing import Sequence

import numpy as np

from ..benchmarks import Benchmark
from ..config import EvalConfig
from ..datasets import load_labels
from ..errors import ConfigError, InputError
from ..evaluation import FrameOutcome, RunContext, evaluate_clip
from ..evaluation.records import lane_files_of
from ..maps import load_maps
from ..metrics.paper import ego_lanes
from ..model import Clip, Dataset, Frame
from .overlays import FramePicture, Overlays, draw_frame, heat_map, legend_entries
from .tables import display_name


def _roots(config: EvalConfig) -> tuple[Path, Path]:
    """The data root and maps root of a run's configuration (a run needs both)."""
    if config.dataset.data_root is None or config.maps.root is None:
        raise ConfigError("a run needs both a data root and a maps root")
    return Path(config.dataset.data_root), Path(config.maps.root)


def _nearest_frame(wanted: str, relpaths: list[str]) -> str:
    """' (did you mean X?)': a frame of that file name (given without its clip), else the closest
    path of the same clip, else of any; or ''."""
    import posixpath

    from ..presets import nearest

    if "/" not in wanted.strip("/"):
        named = [relpath for relpath in relpaths if posixpath.basename(relpath) == wanted.strip("/")]
        if named:
            more = f", or one of {len(named) - 1} more frames of that name" if len(named) > 1 else ""
            return f" (did you mean {named[0]}{more}? --frame takes the path relative to the dataset root)"
    clip = posixpath.dirname(wanted)
    same_clip = [relpath for relpath in relpaths if posixpath.dirname(relpath) == clip]
    return nearest(wanted, same_clip or relpaths)


def replay(config: EvalConfig, benchmark: Benchmark, dataset: Dataset, frames: Sequence[str],
           methods: Sequence[str]) -> tuple[dict[str, Clip], dict[tuple[str, str], FrameOutcome]]:
    """(frame -> its clip with labels, (frame, method) -> outcome with lanes): each clip is
    evaluated again from its start up to its last wanted frame, as the run saw it."""
    clip_of = {f.relpath: clip for clip in dataset.clips for f in clip.frames}
    missing = [f for f in frames if f not in clip_of]
    if missing:
        raise InputError(dataset.source_file, f"frame {missing[0]} is not in this run's dataset"
                                              f"{_nearest_frame(missing[0], list(clip_of))}")
    wanted_clips = {clip_of[f].clip_id: clip_of[f] for f in frames}
    labelled = {clip_id: load_labels(benchmark, dataset, clip) for clip_id, clip in wanted_clips.items()}
    clip_of = {f: labelled[clip_of[f].clip_id] for f in frames}
    run_config = config.with_overrides(save_lanes=True, methods=tuple(methods), pft_ablation=False)
    _, maps_root = _roots(config)
    context = RunContext(run_config, benchmark, maps_root)
    outcomes = {}
    for clip in labelled.values():
        last = max(i for i, f in enumerate(clip.frames) if f.relpath in frames)
        for outcome in evaluate_clip(replace(clip, frames=clip.frames[:last + 1]), context).outcomes:
            outcomes[(outcome.relpath, outcome.method)] = outcome
    return clip_of, outcomes


def background(config: EvalConfig, benchmark: Benchmark, frame: Frame) -> np.ndarray:
    """The camera image at the benchmark's size, or the frame's maps as a heat map without one."""
    import cv2

    data_root, maps_root = _roots(config)
    image_path = data_root / frame.relpath
    image = cv2.imread(str(image_path)) if image_path.is_file() else None
    geometry = config.geometry_of(frame)
    size = geometry.image_size
    if image is None:
        maps = load_maps(maps_root, frame.relpath, config.maps, geometry, config.roneld.center_ratio,
                         lane_files_of(config, benchmark))
        crop_bottom = geometry.crop_top_px + geometry.crop_height_px
        return heat_map(np.asarray(maps.probabilities), *size, geometry.crop_top_px, crop_bottom)
    if image.shape[:2] != size[::-1]:
        image = cv2.resize(image, size)
    return image


def _picture_of(config: EvalConfig, frame: Frame, outcomes: dict[str, FrameOutcome]) -> FramePicture:
    """A frame's ego lanes and other lanes of its ground truth, and each method's active lanes and IoUs."""
    left, right = ego_lanes(frame.lanes, *config.geometry_of(frame).image_size, config.roneld.center_ratio)
    chosen = {id(left), id(right)}
    return FramePicture(
        relpath=frame.relpath,
        ground_truth=(left, right),
        other_ground_truth=tuple(lane for lane in frame.lanes if id(lane) not in chosen and len(lane) >= 2),
        lanes={m: outcome.active for m, outcome in outcomes.items()},
        ious={m: outcome.ious for m, outcome in outcomes.items()},
    )


def frame_pictures(config: EvalConfig, benchmark: Benchmark, dataset: Dataset, frames: Sequence[str],
                   methods: Sequence[str], protocol: str = "") -> Overlays:
    """(relpath, picture) for each frame, and their legend. `protocol` says in a few words how
    the IoUs written beside the lanes were measured."""
    wanted = list(dict.fromkeys(frames))
    methods = [m for m in methods if m in config.methods] or list(config.methods)
    clip_of, outcomes = replay(config, benchmark, dataset, wanted, methods)
    pictures = []
    for relpath in wanted:
        frame = next(f for f in clip_of[relpath].frames if f.relpath == relpath)
        if not frame.labelled:
            raise InputError(dataset.source_file, f"frame {relpath} has no labels to compare with")
        picture = _picture_of(config, frame, {m: outcomes[(relpath, m)] for m in methods if (relpath, m) in outcomes})
        scores = "  ".join(
            f"{display_name(m, config.model)}: "
            + " ".join(f"{side[0].upper()} {iou:.2f}" for side, iou in ious.items())
            for m, ious in picture.ious.items())
        title = f"{relpath}\n{scores}"
        pictures.append((relpath, draw_frame(picture, background(config, benchmark, frame), title)))
    return Overlays(pictures, legend_entries(methods, config.model, protocol))
