"""What a run will evaluate, found before any work: the dataset's layout, every frame's maps,
the first map's geometry (`run --dry-run` is this alone)."""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path
from typing import Callable, Sequence

from ..benchmarks import Benchmark, detector_lane_formats
from ..config import EvalConfig
from ..datasets import read_dataset
from ..errors import ConfigError, InputError
from ..lanes_io import check_folder
from ..geometry import EffectiveGeometry, check_map_shape
from ..maps import map_size, required_paths
from ..model import Clip, Dataset
from ..output import refuse_cut_short
from ..wording import counted
from .one_clip import effective_geometry, frame_map_path
from .records import RunContext, lane_files_of


def check_maps(dataset: Dataset, maps_root: Path, config: EvalConfig, benchmark: Benchmark) -> list[tuple[str, Path]]:
    """(clip id, missing file) for every frame whose maps are missing, or cannot even be looked
    at (a folder without permission). A map that is there but unreadable is refused on loading."""
    missing = []
    lane_files = lane_files_of(config, benchmark)
    for clip in dataset.clips:
        for frame in clip.frames:
            for path in required_paths(maps_root, frame.relpath, config.maps, lane_files):
                try:
                    path.stat()
                except (OSError, ValueError):
                    missing.append((clip.clip_id, path))
    return missing


def describe_missing(missing: list[tuple[str, Path]], benchmark: Benchmark) -> str:
    """'maps missing for N frames of K clips: ...' naming the first files, why where it is not
    plain absence, maps found in another format (use --maps-format), and TuSimple's 20 frames."""
    clips = {clip_id for clip_id, _ in missing}
    paths = list(dict.fromkeys(path for _, path in missing))  # frames may share one file (JSON lines)
    listing = "; ".join(_with_notes(path, index == 0) for index, path in enumerate(paths[:3]))
    more = f" and {len(paths) - 3} more" if len(paths) > 3 else ""
    hint = benchmark.missing_maps_hint
    return f"maps missing for {counted(len(missing), 'frame')} of {counted(len(clips), 'clip')}{hint}: {listing}{more}"


def _with_notes(path: Path, first: bool = True) -> str:
    """A missing map's path, with why where it is not plain absence and, for the `first` listed,
    maps in another format beside it (use --maps-format) or PNGs without their .exist.txt."""
    from ..maps import found_in_other_format, missing_reason, pngs_without_existence

    found = [missing_reason(path)] + ([found_in_other_format(path), pngs_without_existence(path)] if first else [])
    notes = [note for note in found if note]
    return f"{path} ({'; '.join(notes)})" if notes else str(path)


def _root_hint(maps_root: Path, dataset: Dataset, config: EvalConfig, benchmark: Benchmark) -> str:
    """'; did you mean --maps-root X (it holds them)?' where the folder one level up, or one
    below, has the first listed frame's maps (as `score` says for prediction roots)."""
    first = dataset.clips[0].frames[0].relpath if dataset.clips and dataset.clips[0].frames else None
    if first is None:
        return ""
    lane_files = lane_files_of(config, benchmark)

    def holds(root: Path) -> bool:
        try:
            return all(path.exists() for path in required_paths(root, first, config.maps, lane_files))
        except (OSError, ValueError):
            return False

    parent = maps_root.parent
    if parent != maps_root and holds(parent):
        return f"; did you mean --maps-root {parent} (it holds them)?"
    try:
        children = sorted(entry.path for entry in os.scandir(maps_root) if entry.is_dir())
    except OSError:
        return ""
    for child in children[:50]:
        if holds(Path(child)):
            return f"; did you mean --maps-root {child} (it holds them)?"
    return ""


def _lane_layout_hint(maps_root: Path, config: EvalConfig, benchmark: Benchmark) -> str:
    """'; it holds X, lane files in the format --dataset B reads a detector's lanes in' where a lanes run's maps
    root holds another benchmark's lane files (predictions.json given to CULane, .lines.txt to
    TuSimple) instead of this one's."""
    from ..maps.lanes import JsonLinesFile, LinesPerFrame

    ours = lane_files_of(config, benchmark)
    if config.maps.format != "lanes" or ours is None:
        return ""

    def layout(files) -> tuple[str, str] | None:
        if isinstance(files, JsonLinesFile):
            return ("file", files.name)
        if isinstance(files, LinesPerFrame):
            return ("suffix", files.suffix)
        return None

    readers: dict[tuple[str, str], list[str]] = {}
    for name, files in detector_lane_formats().items():
        theirs = layout(files)
        if theirs is not None and theirs != layout(ours):
            readers.setdefault(theirs, []).append(name)
    for (kind, value), benchmarks in readers.items():
        found = _lane_file_under(maps_root, kind, value)
        if found is not None:
            named = ", ".join(benchmarks[:-1]) + " or " + benchmarks[-1] if len(benchmarks) > 1 else benchmarks[0]
            # a claim on the format only: ground truth in the same format looks alike
            return f"; it holds {found}, lane files in the format --dataset {named} reads a detector's lanes in"
    return ""


def _lane_file_under(root: Path, kind: str, value: str, most: int = 2000) -> str | None:
    """The name (relative to `root`) of a file `value` (kind "file") or the first file ending in
    `value` (kind "suffix") found among the first `most` entries under `root`, breadth first
    (no recursion: a root nested 1,500 folders deep made os.walk raise RecursionError), else None."""
    if kind == "file":
        return value if (root / value).is_file() else None
    folders, seen = [root], 0
    while folders and seen < most:
        folder = folders.pop(0)
        try:
            with os.scandir(folder) as entries:
                for entry in entries:
                    seen += 1
                    if entry.is_dir(follow_symlinks=False):
                        folders.append(Path(entry.path))
                    elif entry.name.endswith(value) and entry.is_file():
                        return str(Path(entry.path).relative_to(root))
                    if seen >= most:
                        break
        except OSError:
            continue
    return None


@dataclass(frozen=True)
class RunPlan:
    """What a run will evaluate, found before any work: the clips with all their maps, where
    everything lies, what is left out, and the first map's geometry (None without clips)."""

    dataset: Dataset
    clips: tuple[Clip, ...]
    context: RunContext
    skipped: tuple[str, ...]
    geometry: EffectiveGeometry | None


def plan(config: EvalConfig, benchmark: Benchmark, dataset: Dataset | None = None,
         announce: Callable[[str], None] | None = None, shard=None) -> RunPlan:
    """Read the dataset's layout and check every frame's maps are there (the first map is
    read for its size): the checks a run makes before it starts, and `run --dry-run` alone.
    With a `shard` (shards.Shard) only its share of the dataset's clips is planned; the plan's
    dataset stays whole."""
    maps_root = _maps_root(config, benchmark)
    assert config.dataset.data_root is not None  # _maps_root refuses a run without one
    refuse_cut_short(config.dataset.data_root, config.dataset.list_file, maps_root)
    skipped: list[str] = []
    if dataset is None:
        dataset = _read(config, benchmark, skipped)
    if (dataset.image_width, dataset.image_height) != (config.dataset.image_width, config.dataset.image_height):
        raise ConfigError(
            f"the configuration's image size {config.dataset.image_width}x{config.dataset.image_height} does not "
            f"match {dataset.name}'s {dataset.image_width}x{dataset.image_height}"
        )
    clips = _clips_with_maps(_share(dataset, shard), maps_root, config, benchmark, skipped)
    context = RunContext(config, benchmark, maps_root, None if dataset.labels_loaded else dataset.root,
                         data_root=Path(dataset.root),
                         label_file=None if dataset.source_file is None else Path(dataset.source_file))
    say = announce or (lambda message: None)
    if context.lane_files is not None:
        context.lane_files.check_coverage(maps_root, [f.relpath for clip in clips for f in clip.frames if f.labelled],
                                          say)
    geometry = _first_geometry(clips, context, dataset.frame_sizes)
    if geometry is not None:
        say(f"geometry: {geometry.describe()}")
    return RunPlan(dataset, tuple(clips), context, tuple(skipped), geometry)


def _maps_root(config: EvalConfig, benchmark: Benchmark) -> Path:
    """The configured maps root, which must be a folder (and a data root configured)."""
    if config.dataset.data_root is None or config.maps.root is None:
        raise ConfigError("a run needs both a data root and a maps root")
    maps_root = Path(config.maps.root)
    check_folder(maps_root, "maps root not found")
    if config.maps.format == "lanes" and lane_files_of(config, benchmark) is None:
        raise ConfigError(f"--maps-format lanes: benchmark {config.dataset.name!r} declares no format for a "
                          "detector's lane files")
    return maps_root


def _share(dataset: Dataset, shard) -> Dataset:
    """The dataset with a shard's share of its clips (all without a shard), cut from the list
    alone, before any clip is left out."""
    if shard is None:
        return dataset
    from dataclasses import replace

    from ..shards import shard_range

    share = shard_range([len(clip.frames) for clip in dataset.clips], shard)
    return replace(dataset, clips=dataset.clips[share.start:share.stop])


def _read(config: EvalConfig, benchmark: Benchmark, skipped: list[str]) -> Dataset:
    """The configured dataset; its bad labels listed in `skipped` under on_error = "skip"."""
    assert config.dataset.data_root is not None
    errors: list[InputError] | None = [] if config.on_error == "skip" else None
    # A benchmark may leave each clip's labels to the workers, read clip by clip in parallel.
    try:
        dataset = read_dataset(benchmark, config.dataset.data_root, config.dataset.list_file,
                               config.dataset.limit, errors, labels=False)
    except InputError as error:
        hint = "" if config.dataset.list_file is not None else _data_root_hint(Path(config.dataset.data_root),
                                                                               benchmark)
        if not hint:
            raise
        raise InputError(error.path, error.problem + hint, error.line) from None
    skipped += [f"{error} (labels skipped)" for error in errors or ()]
    return dataset


def _data_root_hint(data_root: Path, benchmark: Benchmark) -> str:
    """'; did you mean --data-root X (it holds the dataset)?' where a folder one below the root
    given (a synth set's parent: its data/) or the one above reads as this benchmark's dataset."""
    from ..benchmarks import origin

    if origin(benchmark.name) != "built in":  # another package's read is not timed: not tried on a guess
        return ""

    def reads(root: Path) -> bool:
        try:
            read_dataset(benchmark, root, None, 1, None, labels=False)
        except (InputError, ConfigError, OSError, ValueError):
            return False
        return True

    try:
        children = sorted(entry.path for entry in os.scandir(data_root) if entry.is_dir())[:20]
    except OSError:
        children = []
    for candidate in [Path(child) for child in children] + [data_root.parent]:
        if candidate != data_root and reads(candidate):
            return f"; did you mean --data-root {candidate} (it holds the dataset)?"
    return ""


def _clips_with_maps(dataset: Dataset, maps_root: Path, config: EvalConfig, benchmark: Benchmark,
                     skipped: list[str]) -> list[Clip]:
    """The clips whose every frame has its maps; the others stop the run, or are listed in
    `skipped` and left out under on_error = "skip"."""
    missing = check_maps(dataset, maps_root, config, benchmark)
    if not missing:
        return list(dataset.clips)
    if config.on_error != "skip":
        hints = _root_hint(maps_root, dataset, config, benchmark) + _lane_layout_hint(maps_root, config, benchmark)
        raise InputError(maps_root, describe_missing(missing, benchmark) + hints)
    by_clip: dict[str, list[Path]] = {}
    for clip_id, path in missing:
        by_clip.setdefault(clip_id, []).append(path)
    for clip_id, paths in by_clip.items():
        skipped.append(f"{clip_id}: maps missing for {counted(len(paths), 'frame')}, first {_with_notes(paths[0])} "
                       "(clip skipped)")
    return [clip for clip in dataset.clips if clip.clip_id not in by_clip]


def _first_geometry(clips: Sequence[Clip], context: RunContext,
                    frame_sizes: tuple[tuple[int, int], ...]) -> EffectiveGeometry | None:
    """The geometry of the first clip's maps, checked before any work starts (None if unreadable)."""
    for clip in clips[:1]:
        for frame in clip.frames[:1]:
            config = context.config
            where = str(frame_map_path(context, frame))
            try:
                width, height = map_size(context.maps_root, frame.relpath, config.maps, config.geometry_of(frame),
                                         config.roneld.center_ratio, context.lane_files)
                check_map_shape(config.geometry, width, height, where)
            except InputError:
                return None  # reported, or skipped, where the clip is evaluated
            except ConfigError:
                # A header alone does not stop the run: its file may not decode at all, and then
                # the frame is reported (or, with on_error = "skip", skipped) as unreadable.
                try:
                    maps = context.load(frame)
                except InputError:
                    return None
                width, height = maps.width, maps.height
                check_map_shape(config.geometry, width, height, where)
            return effective_geometry(config, width, height, frame_sizes)
    return None
