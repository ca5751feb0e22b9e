"""The whole evaluation: read a dataset, load each clip's maps, extract lanes with every method,
score them, and return one `RunResult`. Writes nothing itself (see report.write).

A clip is the unit of state (RONELD's tracking) and of parallel work: `evaluate_clip` runs in
worker processes and returns plain per-frame records; they are merged in clip order, so any
number of workers gives the same result. Lanes to save stream to a `lane_sink` as clips finish,
so memory stays flat in the number of frames.
"""

from __future__ import annotations

import contextlib
import functools
import itertools
import os
import platform
import queue
import signal
import threading
import time
from array import array
from collections import deque
from concurrent.futures import Future, ThreadPoolExecutor
from concurrent.futures.process import BrokenProcessPool
from dataclasses import dataclass, field, replace
from functools import cached_property
from pathlib import Path
from typing import Callable, Iterator, Mapping, Protocol, Sequence, TypeVar

import numpy as np
import pandas as pd

from .version import __version__
from . import kernels
from .benchmarks import Benchmark, OfficialRecord, benchmark_for
from .config import EvalConfig, parse_thresholds
from .datasets import read_dataset, with_labels
from .errors import ConfigError, ExtractorError, InputError
from .extract.protocol import Extractor, Prediction, is_stateless, prediction_problem
from .extract.registry import Method, loaded_code, methods_of
from .geometry import EffectiveGeometry, MapGeometry, check_map_shape
from .maps import load_maps, map_size, map_stem, required_paths
from .maps.scnn_png import scnn_png_paths
from .metrics.bootstrap import paired_bootstrap
from .metrics.paper import ego_masks, side_ious
from .metrics.sweep import sweep_accuracy
from .methods import GAIN_REFERENCES, RONELD
from .model import Clip, Dataset, Frame, FrameMaps, Lane, read_only
from .plugin_calls import PluginCalls
from .signals import TimeLimitExceeded, time_limit
from .wording import counted
from .workers import default_workers, pool_context, process_pool, stopping


@dataclass(frozen=True)
class FrameOutcome:
    """One scored frame of one method: ego-lane IoUs per side, official record, lanes."""

    relpath: str
    method: str
    ious: dict[str, float]
    official: OfficialRecord  # as the dataset's benchmark scores a frame
    lanes: tuple[Lane, ...]
    active: tuple[Lane | None, Lane | None] = (None, None)  # the scored left and right lanes

    def without_lanes(self) -> "FrameOutcome":
        """The scores alone: what the main process keeps once lanes are written (or not wanted)."""
        return replace(self, lanes=(), active=(None, None))


@dataclass
class ClipResult:
    """What a worker sends back for one clip (plain data, cheap to pickle)."""

    clip_id: str
    outcomes: list[FrameOutcome] = field(default_factory=list)
    extract_ms: dict[str, list[float]] = field(default_factory=dict)
    load_ms: list[float] = field(default_factory=list)
    n_frames: int = 0  # frames evaluated (skipped ones not counted)
    n_scored: int = 0
    n_gt_lanes: int = 0
    skipped: list[str] = field(default_factory=list)
    map_size: tuple[int, int] | None = None  # (width, height) of the clip's maps as found
    # Source files of the plug-ins as loaded when the clip finished: path -> SHA-256 (resume).
    plugin_code: dict[str, str] = field(default_factory=dict)


@dataclass(frozen=True)
class RunContext:
    """Everything a worker needs besides the clip."""

    config: EvalConfig
    maps_root: Path
    labels_root: Path | None = None  # dataset root when clips come without their labels
    data_root: Path | None = None  # where the labels lie (CULane: a .lines.txt per frame)
    label_file: Path | None = None  # one file holding every label (TuSimple)

    @cached_property
    def methods(self) -> tuple[Method, ...]:
        return methods_of(self.config)

    @cached_property
    def benchmark(self) -> Benchmark:
        return benchmark_for(self.config.dataset.name)

    def load(self, frame: Frame) -> FrameMaps:
        """One frame's maps (lane files are drawn into maps with the configured geometry)."""
        config = self.config
        return load_maps(self.maps_root, frame.relpath, config.maps, config.geometry, config.roneld.center_ratio)

    def kernel_groups(self) -> tuple[str, ...]:
        """The numba kernel groups this run executes (see roneld_eval.kernels)."""
        return kernels.groups_for(self.methods, self.benchmark, self.config.maps.format)


@dataclass
class RunResult:
    """A finished evaluation: the tables of every report, and where they came from."""

    config: EvalConfig
    dataset: Dataset
    per_frame: pd.DataFrame
    accuracy: pd.DataFrame
    official: pd.DataFrame
    runtime: pd.DataFrame
    counts: dict
    wall_time_s: float
    skipped: list[str]
    versions: dict
    fixture: str | None = None  # the bundled fixture's dataset when that is what ran
    # What was really drawn (map size as found, thicknesses); None when no clip was evaluated.
    geometry: EffectiveGeometry | None = None
    # Each method's accuracy gain over RONELD and over the baseline, with bootstrap intervals.
    gains: pd.DataFrame | None = None


_T = TypeVar("_T")


# ---- one clip ------------------------------------------------------------------------------


def _geometry_for(context: RunContext, maps: FrameMaps, where: Path) -> MapGeometry:
    geometry = context.config.geometry
    check_map_shape(geometry, maps.width, maps.height, str(where))
    return geometry.with_map_size(maps.width, maps.height)


def effective_geometry(config: EvalConfig, map_width: int, map_height: int) -> EffectiveGeometry:
    """The geometry and thicknesses a run really uses for maps of this size."""
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
        official_iou_threshold=config.official.iou_threshold,
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
        clip = with_labels(config.dataset.name, clip, context.labels_root, errors)
        result.skipped = [f"{error} (labels skipped)" for error in errors or ()]
        result.n_frames = len(clip.frames)
    result.extract_ms = {method.name: [] for method in context.methods}
    skip = config.on_error == "skip"
    extractors: list[tuple[Method, Extractor, bool]] | None = None
    map_shape: tuple[int, ...] | None = None
    geometry: MapGeometry | None = None
    for frame, loaded, load_ms in _told(_prefetched(clip.frames, context), advance):
        try:
            if isinstance(loaded, InputError):
                raise loaded
            maps = loaded
            if map_shape is not None and maps.probabilities.shape != map_shape:
                raise InputError(
                    frame_map_path(context, frame),
                    f"maps of shape {maps.probabilities.shape} differ from the clip's first frame {map_shape}",
                )
        except InputError as error:
            if not skip:
                raise
            _leave_out(result, error)  # neither scored nor seen by RONELD (as a dropped frame)
            continue
        result.load_ms.append(load_ms)
        if extractors is None:
            map_shape = maps.probabilities.shape
            geometry = _geometry_for(context, maps, frame_map_path(context, frame))
            extractors = [_built(method, geometry, frame) for method in context.methods]
            result.map_size = (maps.width, maps.height)
        try:
            predictions = _predictions(extractors, maps, frame, result.extract_ms, config)
        except ExtractorError as error:
            if not skip:
                raise
            _leave_out(result, error)  # for every method, so that all are scored on the same frames
            continue
        if frame.labelled:
            assert geometry is not None
            outcomes = _score_frame(frame, predictions, geometry, context)
            # Lanes travel back to the main process only when they are to be saved.
            result.outcomes += outcomes if config.save_lanes else [outcome.without_lanes() for outcome in outcomes]
            result.n_scored += 1
            result.n_gt_lanes += len(frame.lanes)
    if advance is not None and listed > len(clip.frames):
        advance(listed - len(clip.frames))  # frames whose labels were left out
    result.plugin_code = loaded_code(context.methods)
    return result


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
            with _plugin_call(method, frame):  # its factory may end the process too
                extractor = method.build(geometry)
        except (Exception, SystemExit) as error:  # a plug-in's own bug: name it, not the runner's frames
            problem = f"building the extractor raised {_raised(error)}"
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
            start = time.perf_counter()
            prediction = extractor(maps)
            extract_ms[method.name].append((time.perf_counter() - start) * 1e3)
        else:
            prediction = _plugin_prediction(method, extractor, maps, frame, extract_ms, config)
        predictions[method.name] = prediction
    return predictions


def _plugin_prediction(method: Method, extractor: Extractor, maps: FrameMaps, frame: Frame,
                       extract_ms: dict[str, list[float]], config: EvalConfig) -> Prediction:
    """A plug-in's prediction, checked: whatever goes wrong is one ExtractorError naming the
    method, the frame and the problem, never a traceback from deep inside the runner."""
    problem = None
    too_slow = too_slow_text(method.name, method.time_limit_s)
    # A read-only view: a plug-in that writes into the maps would change what the methods after
    # it see (npy maps are read-only memory maps already; the other formats are arrays).
    maps = replace(maps, probabilities=read_only(maps.probabilities),
                   existence=None if maps.existence is None else read_only(maps.existence))
    try:
        with _plugin_call(method, frame), time_limit(method.time_limit_s):
            start = time.perf_counter()
            prediction = extractor(maps)
            elapsed = time.perf_counter() - start
    except TimeLimitExceeded:
        problem = too_slow
    except (Exception, SystemExit) as error:  # sys.exit() in a plug-in must not end the run silently
        problem = f"raised {_raised(error)}"
    else:
        if method.time_limit_s is not None and elapsed > method.time_limit_s:
            problem = too_slow  # it caught or blocked the alarm
        else:
            problem = prediction_problem(prediction, config.dataset.image_width, config.dataset.image_height)
    if problem is not None:
        raise ExtractorError(method.name, frame.relpath, problem)
    extract_ms[method.name].append(elapsed * 1e3)
    return prediction


@contextlib.contextmanager
def _plugin_call(method: Method, frame: Frame) -> Iterator[None]:
    """Within the block, this worker's shared slot names the plug-in call (plugin_calls), so the
    main process can name it if the process ends inside."""
    if _PLUGIN_CALLS is None:
        yield
        return
    _PLUGIN_CALLS.enter(method.name, frame.relpath)
    try:
        yield
    finally:
        _PLUGIN_CALLS.leave()


def too_slow_text(method: str, limit_s: float | None) -> str:
    return f"took longer than {limit_s or 0:g} s (time_limit_s in [methods.{method}])"


# How long past its time limit a plug-in call may run before the main process ends its worker:
# SIGALRM stops it inside the worker, unless the plug-in blocks or ignores that signal.
OVERDUE_GRACE_S = 2.0


def _raised(error: BaseException) -> str:
    text = str(error).strip().splitlines()
    return f"{type(error).__name__}: {text[0]}" if text else type(error).__name__


def frame_map_path(context: RunContext, frame: Frame) -> Path:
    """The file to name when a frame's maps are wrong: the first map image where there are several."""
    path = required_paths(context.maps_root, frame.relpath, context.config.maps)[0]
    if context.config.maps.format == "scnn-png":  # path is the .exist.txt beside the PNGs
        images, _ = scnn_png_paths(map_stem(context.maps_root, frame.relpath), context.config.maps.lane_channels)
        path = next((image for image in images if image.is_file()), path)
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


# ---- many clips ----------------------------------------------------------------------------

_WORKER_CONTEXT: RunContext | None = None
_PLUGIN_CALLS: PluginCalls | None = None  # in a worker of a run with plug-ins


def _init_worker(context: RunContext, calls: PluginCalls | None = None) -> None:
    global _WORKER_CONTEXT, _PLUGIN_CALLS
    _WORKER_CONTEXT = context
    if calls is not None:
        calls.claim()
        _PLUGIN_CALLS = calls
    kernels.warm_up(context.kernel_groups())  # loaded already (prepared before the fork): runs each path once


def _evaluate_in_worker(clip: Clip) -> ClipResult:
    assert _WORKER_CONTEXT is not None
    return evaluate_clip(clip, _WORKER_CONTEXT)


class ClipCache(Protocol):
    """Where finished clips are kept so an interrupted run can resume (see roneld_eval.cache)."""

    def load(self, clip: Clip, inputs: Callable[[], Sequence[Path]]) -> ClipResult | None: ...

    def store(self, clip: Clip, inputs: Sequence[Path], result: ClipResult) -> None: ...


def clip_inputs(clip: Clip, context: RunContext) -> list[Path]:
    """Every file evaluating this clip reads: its maps and its labels (what resume must check)."""
    paths = []
    for frame in clip.frames:
        paths += required_paths(context.maps_root, frame.relpath, context.config.maps)
    return paths + context.benchmark.label_paths(clip, context.data_root, context.label_file)


def _clip_results(clips: Sequence[Clip], context: RunContext, workers: int,
                  cache: ClipCache | None = None,
                  advance: Callable[[int], object] | None = None) -> Iterator[ClipResult]:
    """Results in clip order: cached ones, then from `workers` processes (in-process for 1).

    Each finished clip is stored in the cache before it is yielded; `advance(frames)` is told
    of every frame as its clip finishes (in-process: as it is done). A worker that dies (killed, out of
    memory) ends the run with RunInterrupted instead of a hang.
    """
    cached: dict[int, ClipResult] = {}
    if cache is not None:
        # Input files are listed only where an entry is there to check, and for a finished clip
        # as it is kept: not all at once before any work starts (0.1 s per 6,000 frames).
        for index, clip in enumerate(clips):
            found = cache.load(clip, functools.partial(clip_inputs, clip, context))
            if found is not None:
                cached[index] = found
    todo = [index for index in range(len(clips)) if index not in cached]
    advance = advance or (lambda frames: None)

    def keep(index: int, result: ClipResult) -> ClipResult:
        if cache is not None:
            cache.store(clips[index], clip_inputs(clips[index], context), result)
        return result

    # A plug-in always runs in a worker process, so that one which ends its process (os._exit,
    # a crash) ends a worker the run can name, not the run itself with exit status 0.
    plugins = not all(method.built_in for method in context.methods)
    if not todo or (not plugins and (workers <= 1 or len(todo) <= 1)):
        if todo:
            kernels.warm_up(context.kernel_groups())
        for index, clip in enumerate(clips):
            result = cached.get(index)
            if result is None:
                result = keep(index, evaluate_clip(clip, context, advance))
            else:
                advance(len(clip.frames))
            yield result
        return
    plotting: threading.Thread | None = None
    workers = max(workers, 1)
    calls = PluginCalls(workers, pool_context()) if plugins else None
    pool = process_pool(workers, initializer=_init_worker, initargs=(context, calls))
    processes = dict(getattr(pool, "_processes", None) or {})  # pid -> Process: their exit codes tell
    schedule = _Schedule(pool, clips, todo, context, workers, advance)

    limits = {method.name: method.time_limit_s for method in context.methods}
    stopped: dict[int, tuple[str, str]] = {}  # workers ended here for a plug-in past its limit

    def watch() -> None:
        assert calls is not None
        for pid, call in calls.overdue(limits, OVERDUE_GRACE_S).items():
            stopped[pid] = call
            with contextlib.suppress(OSError):
                os.kill(pid, signal.SIGKILL)
        # A worker that ended while a process it forked holds its pipes open: the pool would
        # wait for that process, so the worker's end is looked for here (exitcode reaps it).
        if any(process.exitcode is not None for process in processes.values()):
            raise BrokenProcessPool("a worker process ended")

    schedule.watch = watch if calls is not None else None

    def died() -> str | ExtractorError:
        # Ended by now; the pool's own thread may be reaping one (its exit code is then None here
        # until that thread has set it).
        deadline = time.monotonic() + 2.0
        while any(process.exitcode is None for process in processes.values()) and time.monotonic() < deadline:
            time.sleep(0.01)
        if stopped:
            pid, (method, frame) = next(iter(stopped.items()))
            return ExtractorError(method, frame, too_slow_text(method, limits[method]))
        inside = None if calls is None else calls.died_in({pid: process.exitcode
                                                            for pid, process in processes.items()})
        if inside is not None:
            method, frame, code = inside
            how = "" if code is None else f" (exit status {code})" if code >= 0 else f" (signal {-code})"
            return ExtractorError(method, frame, f"its process ended inside the plug-in{how}")
        return f"a worker process died (killed, or out of memory) while evaluating clip {schedule.current}"

    with stopping(schedule.executor, died):
        for index, clip in enumerate(clips):
            if index in cached:
                yield cached[index]
                advance(len(clip.frames))
                continue
            schedule.start_more()
            if plotting is None:
                # The workers exist now (none forks later); the idle main process meanwhile
                # imports the plotting library the report needs.
                plotting = threading.Thread(target=_import_plotting, daemon=True)
                plotting.start()
            yield keep(index, schedule.result(index))
    if plotting is not None:
        plotting.join()  # the report must not use matplotlib while that thread is still importing it


class _Schedule:
    """Clips in flight in a process pool: they finish in any
    order and are handed out in clip order. Work is started only while few clips wait to be
    handed out, so results wait in memory briefly; a clip's error is raised when its turn
    comes, so which error a run reports does not depend on the number of workers."""

    def __init__(self, executor, clips: Sequence[Clip], todo: Sequence[int], context: RunContext,
                 workers: int, advance: Callable[[int], object]):
        self.executor = executor
        self.clips = clips
        self.waiting = deque(todo)
        self.context = context
        self.limit = 2 * workers
        self.advance = advance
        self.tasks: dict[Future, Callable[[Future], None]] = {}  # what to do when each finishes
        # Finished futures, put by their done-callbacks. A C queue: Ctrl-C (twice) while the main
        # process waits on it cannot leave a lock of threading's Python code taken or released
        # twice, as it can within concurrent.futures.wait (RuntimeError, or a hang at exit).
        self.finished: queue.SimpleQueue[Future] = queue.SimpleQueue()
        self.started: set[int] = set()  # clips started and not yet handed out
        self.done: dict[int, ClipResult | BaseException] = {}
        self.current = clips[todo[0]].clip_id if todo else ""
        self.watch: Callable[[], None] | None = None  # called while waiting (plug-ins' time limits)

    def start_more(self) -> None:
        failed = min((index for index, done in self.done.items() if isinstance(done, BaseException)), default=None)
        while self.waiting and len(self.started) < self.limit and len(self.tasks) < self.limit:
            index = self.waiting[0]
            if failed is not None and index > failed:
                break  # the run stops at that clip's error: nothing after it is wanted
            self.waiting.popleft()
            self.started.add(index)
            self._submit(functools.partial(self._clip_done, index), _evaluate_in_worker, self.clips[index])

    def result(self, index: int) -> ClipResult:
        """Clip `index`'s result, waiting for it while the other work goes on."""
        self.current = self.clips[index].clip_id
        while index not in self.done:
            self.start_more()
            if not self.tasks:  # cannot happen: clips start in order, so this one is under way
                raise RuntimeError(f"clip {self.current} was never started")
            future = self._next_finished()
            self.tasks.pop(future)(future)
        self.started.discard(index)
        done = self.done.pop(index)
        if isinstance(done, BaseException):
            raise done
        return done

    def _next_finished(self) -> Future:
        if self.watch is None:
            return self.finished.get()
        while True:
            try:
                return self.finished.get(timeout=0.25)
            except queue.Empty:
                self.watch()

    def _submit(self, then: Callable[[Future], None], function, *args) -> None:
        future = self.executor.submit(function, *args)
        self.tasks[future] = then
        future.add_done_callback(self.finished.put)

    def _clip_done(self, index: int, future: Future) -> None:
        try:
            self.done[index] = future.result()
        except BaseException as error:
            self.done[index] = error
            return
        self.advance(len(self.clips[index].frames))


def _import_plotting() -> None:
    try:
        import matplotlib.pyplot  # noqa: F401
    except Exception:  # pragma: no cover - the report raises it properly later
        pass


def check_maps(dataset: Dataset, maps_root: Path, config: EvalConfig) -> list[tuple[str, Path]]:
    """(clip id, missing file) for every frame whose maps are missing, or cannot even be looked
    at (a folder without permission). A map that is there but unreadable is refused on loading."""
    missing = []
    for clip in dataset.clips:
        for frame in clip.frames:
            for path in required_paths(maps_root, frame.relpath, config.maps):
                try:
                    path.stat()
                except (OSError, ValueError):
                    missing.append((clip.clip_id, path))
    return missing


def describe_missing(missing: list[tuple[str, Path]], dataset: Dataset) -> str:
    """'maps missing for N frames of K clips: ...' naming the first files, why where it is not
    plain absence, maps found in another format (use --maps-format), and TuSimple's 20 frames."""
    from .maps import found_in_other_format, missing_reason, pngs_without_existence

    clips = {clip_id for clip_id, _ in missing}
    shown = []
    for index, (_, path) in enumerate(missing[:3]):
        found = [missing_reason(path)] + ([found_in_other_format(path), pngs_without_existence(path)]
                                          if index == 0 else [])
        notes = [note for note in found if note]
        shown.append(f"{path} ({'; '.join(notes)})" if notes else str(path))
    listing = "; ".join(shown)
    more = f" and {len(missing) - 3} more" if len(missing) > 3 else ""
    hint = benchmark_for(dataset.name).missing_maps_hint
    return f"maps missing for {counted(len(missing), 'frame')} of {counted(len(clips), 'clip')}{hint}: {listing}{more}"


@dataclass(frozen=True)
class RunPlan:
    """What a run will evaluate, found before any work: the clips with all their maps, where
    everything lies, what is left out, and the first map's geometry (None without clips)."""

    dataset: Dataset
    clips: tuple[Clip, ...]
    context: RunContext
    skipped: tuple[str, ...]
    geometry: EffectiveGeometry | None


def plan(config: EvalConfig, dataset: Dataset | None = None,
         announce: Callable[[str], None] | None = None) -> RunPlan:
    """Read the dataset's layout and check every frame's maps are there (the first map is
    read for its size): the checks a run makes before it starts, and `run --dry-run` alone."""
    if config.dataset.data_root is None or config.maps.root is None:
        raise ConfigError("a run needs both a data root and a maps root")
    maps_root = Path(config.maps.root)
    if not maps_root.is_dir():
        raise InputError(maps_root, "maps root not found")
    skipped: list[str] = []
    if dataset is None:
        errors: list[InputError] | None = [] if config.on_error == "skip" else None
        # CULane labels are read by the workers, clip by clip, in parallel.
        dataset = read_dataset(config.dataset.name, config.dataset.data_root, config.dataset.list_file,
                               config.dataset.limit, errors, labels=False)
        skipped += [f"{error} (labels skipped)" for error in errors or ()]
    if (dataset.image_width, dataset.image_height) != (config.dataset.image_width, config.dataset.image_height):
        raise ConfigError(
            f"the configuration's image size {config.dataset.image_width}x{config.dataset.image_height} does not "
            f"match {dataset.name}'s {dataset.image_width}x{dataset.image_height}"
        )
    missing = check_maps(dataset, maps_root, config)
    clips = list(dataset.clips)
    if missing:
        if config.on_error != "skip":
            raise InputError(maps_root, describe_missing(missing, dataset))
        by_clip: dict[str, list[Path]] = {}
        for clip_id, path in missing:
            by_clip.setdefault(clip_id, []).append(path)
        for clip_id, paths in by_clip.items():
            frames = counted(len(paths), "frame")
            skipped.append(f"{clip_id}: maps missing for {frames}, first {paths[0]} (clip skipped)")
        clips = [clip for clip in clips if clip.clip_id not in by_clip]

    context = RunContext(config, maps_root, None if dataset.labels_loaded else dataset.root,
                         data_root=Path(dataset.root),
                         label_file=None if dataset.source_file is None else Path(dataset.source_file))
    say = announce or (lambda message: None)
    if config.maps.format == "lanes":
        from .maps.lanes import check_coverage

        check_coverage(maps_root, [f.relpath for clip in clips for f in clip.frames if f.labelled], say)
    geometry = _first_geometry(clips, context)
    if geometry is not None:
        say(f"geometry: {geometry.describe()}")
    return RunPlan(dataset, tuple(clips), context, tuple(skipped), geometry)


def evaluate(
    config: EvalConfig,
    progress: bool = True,
    lane_sink: Callable[[FrameOutcome, Frame], None] | None = None,
    dataset: Dataset | None = None,
    cache: ClipCache | None = None,
    announce: Callable[[str], None] | None = None,
) -> RunResult:
    """Evaluate every configured method on a dataset's stored maps (the library `run`).

    With on_error = "skip", bad label lines, bad map files and clips with missing maps are
    left out and listed in `RunResult.skipped`; otherwise the first one raises InputError
    before anything is computed (maps' contents are checked as they load).
    """
    started = time.perf_counter()
    planned = plan(config, dataset, announce)
    dataset, clips, context, skipped, geometry = (planned.dataset, list(planned.clips), planned.context,
                                                  list(planned.skipped), planned.geometry)
    say = announce or (lambda message: None)
    workers = min(config.workers or default_workers(), max(len(clips), 1))
    # Compiled once here, before the workers fork, instead of in every worker at once.
    kernels.prepare(announce=say, needed=context.kernel_groups())
    # Kept compact, not as the workers' records: the main process stays small however long the run.
    rows = PerFrameRows()
    tally = context.benchmark.tally(config.methods, dataset, config)
    extract_ms = {method: array("d") for method in config.methods}
    load_ms = array("d")
    totals = dict(clips=0, frames=0, labelled_frames=0, gt_lanes=0)
    bar = _progress_bar(sum(len(clip.frames) for clip in clips), progress)
    map_sizes: dict[tuple[int, int], str] = {}
    try:
        results = _clip_results(clips, context, workers, cache, advance=bar.update)
        for clip, result in zip(clips, results, strict=True):  # strict: runs the generator to its end
            if result.map_size is not None:
                map_sizes.setdefault(result.map_size, result.clip_id)
            totals["clips"] += 1
            totals["frames"] += result.n_frames
            totals["labelled_frames"] += result.n_scored
            totals["gt_lanes"] += result.n_gt_lanes
            for method, values in result.extract_ms.items():
                extract_ms[method].extend(values)
            load_ms.extend(result.load_ms)
            skipped.extend(result.skipped)
            # The frames as read here: what a lane file needs of its frame (TuSimple's h_samples),
            # and the relpath strings kept (not the workers' copies, which would each stay).
            listed = {frame.relpath: frame for frame in clip.frames}
            for outcome in result.outcomes:
                frame = listed[outcome.relpath]
                if lane_sink is not None:
                    lane_sink(outcome, frame)
                rows.add(frame.relpath, outcome)
                tally.add(outcome.method, frame.relpath, outcome.official)
            tally.end_clip(clip.clip_id)
            del result, listed
    finally:
        bar.close()

    per_frame = rows.take_table()
    del rows
    thresholds = parse_thresholds(config.paper.thresholds)
    paired = PairedGains(per_frame, thresholds)
    accuracy = with_intervals(sweep_accuracy(per_frame, thresholds, methods=config.methods), paired)
    gains = pairwise_gains(paired, config.methods)
    official = tally.table()
    runtime = _runtime_table(extract_ms, load_ms)
    totals["ego_lanes"] = int(len(per_frame) // max(len(config.methods), 1))
    if map_sizes:
        first = next(iter(map_sizes))
        geometry = effective_geometry(config, *first)
        if len(map_sizes) > 1:
            skipped.append("maps differ in size between clips (each clip is rescaled by its own): "
                           + ", ".join(f"{w}x{h} from clip {clip_id}" for (w, h), clip_id in map_sizes.items()))
    return RunResult(
        config=config,
        dataset=dataset,
        per_frame=per_frame,
        accuracy=accuracy,
        official=official,
        runtime=runtime,
        counts=totals,
        wall_time_s=time.perf_counter() - started,
        skipped=skipped,
        versions=versions(),
        geometry=geometry,
        gains=gains,
    )


def _first_geometry(clips: Sequence[Clip], context: RunContext) -> EffectiveGeometry | None:
    """The geometry of the first clip's maps, checked before any work starts (None if unreadable)."""
    for clip in clips[:1]:
        for frame in clip.frames[:1]:
            config = context.config
            where = str(frame_map_path(context, frame))
            try:
                width, height = map_size(context.maps_root, frame.relpath, config.maps, config.geometry,
                                         config.roneld.center_ratio)
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
            return effective_geometry(config, width, height)
    return None


class PairedGains:
    """Accuracy gains with their 95% paired-bootstrap intervals over clips, each pair bootstrapped
    once however many tables show it (accuracy.csv's RONELD gain and gains.csv share some)."""

    def __init__(self, per_frame: pd.DataFrame, thresholds):
        self.per_frame, self.thresholds = per_frame, thresholds
        self._done: dict[tuple[str, str], pd.DataFrame] = {}

    def of(self, method: str, over: str) -> pd.DataFrame:
        """threshold, difference (`method` - `over` accuracy), ci_low, ci_high."""
        key = (method, over)
        if key not in self._done:
            self._done[key] = paired_bootstrap(self.per_frame, self.thresholds, over, reference=method)
        return self._done[key]


def with_intervals(accuracy: pd.DataFrame, gains: PairedGains) -> pd.DataFrame:
    """Add RONELD's gain over each other method with its 95% paired-bootstrap interval over clips."""
    accuracy = accuracy.copy()
    for column in ("roneld_gain", "roneld_gain_ci_low", "roneld_gain_ci_high"):
        accuracy[column] = np.nan
    methods = set(accuracy["method"])
    if RONELD.name not in methods or gains.per_frame.empty:
        return accuracy
    for method in sorted(methods - {RONELD.name}):
        gain = gains.of(RONELD.name, over=method)
        rows = (accuracy["method"] == method).to_numpy()
        accuracy.loc[rows, "roneld_gain"] = gain["difference"].to_numpy()
        accuracy.loc[rows, "roneld_gain_ci_low"] = gain["ci_low"].to_numpy()
        accuracy.loc[rows, "roneld_gain_ci_high"] = gain["ci_high"].to_numpy()
    return accuracy


def pairwise_gains(gains: PairedGains, methods: Sequence[str]) -> pd.DataFrame:
    """method, reference, threshold, gain (method - reference accuracy), ci_low, ci_high: every
    method against each of GAIN_REFERENCES the run has."""
    tables = []
    for reference in GAIN_REFERENCES:
        if reference not in methods or gains.per_frame.empty:
            continue
        for method in methods:
            if method == reference:
                continue
            table = gains.of(method, over=reference).rename(columns={"difference": "gain"})
            table.insert(0, "reference", reference)
            table.insert(0, "method", method)
            tables.append(table)
    columns = ["method", "reference", "threshold", "gain", "ci_low", "ci_high"]
    return pd.concat(tables, ignore_index=True)[columns] if tables else pd.DataFrame(columns=columns)


class PerFrameRows:
    """The rows of `RunResult.per_frame` (frame, side, method, IoU) gathered outcome by outcome
    as compact columns: a frame's rows share one string, sides and methods are small codes."""

    COLUMNS = ["frame", "side", "method", "iou"]

    def __init__(self) -> None:
        self._empty()

    def _empty(self) -> None:
        self.frames: list[str] = []
        self.sides, self.methods = array("B"), array("B")
        self.ious = array("d")
        self.names: dict[str, int] = {}  # side and method names, coded

    def add(self, relpath: str, outcome: FrameOutcome) -> None:
        """Add an outcome's rows under `relpath` (one string shared by the frame's rows)."""
        method = self._code(outcome.method)
        for side, iou in outcome.ious.items():
            self.frames.append(relpath)
            self.sides.append(self._code(side))
            self.methods.append(method)
            self.ious.append(iou)

    def _code(self, name: str) -> int:
        return self.names.setdefault(name, len(self.names))

    def take_table(self) -> pd.DataFrame:
        """The rows as a DataFrame, handed over: the gatherer is empty afterwards, as new (so that
        its lists are freed as the table is built, at a run's largest size)."""
        frames, sides, methods, ious, names = self.frames, self.sides, self.methods, self.ious, list(self.names)
        self._empty()
        if not frames:
            return pd.DataFrame([], columns=self.COLUMNS)
        column = np.array(frames, dtype=object)
        del frames  # the strings stay, shared with the dataset's frames
        coded = np.array(names, dtype=object)
        # Arrays, not lists, and not copied again.
        return pd.DataFrame({
            "frame": column,
            "side": coded[np.frombuffer(sides, np.uint8)],
            "method": coded[np.frombuffer(methods, np.uint8)],
            "iou": np.frombuffer(ious, np.float64).copy(),
        }, columns=self.COLUMNS, copy=False)


def _runtime_table(extract_ms: Mapping[str, Sequence[float]], load_ms: Sequence[float]) -> pd.DataFrame:
    rows = []
    for name, times in list(extract_ms.items()) + [("map loading", load_ms)]:
        values = np.asarray(times, np.float64)
        if values.size == 0:
            continue
        rows.append(dict(
            method=name, frames=int(values.size), mean_ms=float(values.mean()),
            median_ms=float(np.median(values)), p95_ms=float(np.percentile(values, 95)),
        ))
    return pd.DataFrame(rows, columns=["method", "frames", "mean_ms", "median_ms", "p95_ms"])


def _progress_bar(total: int, enabled: bool):
    from tqdm import tqdm

    # None: no bar where stderr is not a terminal (CI logs), as tqdm documents.
    return tqdm(total=total, unit="frame", desc="evaluating", disable=None if enabled else True, dynamic_ncols=True)


def versions() -> dict:
    """Versions of the tool, Python and the libraries that shape the numbers."""
    import importlib.metadata as metadata

    out: dict[str, str | None] = {"roneld-eval": __version__, "python": platform.python_version(),
                                  "platform": platform.platform()}
    packages = ("numpy", "numba", "llvmlite", "scipy", "opencv-python-headless", "pandas", "matplotlib", "click",
                "tqdm")
    for package in packages:
        try:
            out[package] = metadata.version(package)
        except metadata.PackageNotFoundError:
            out[package] = None
    return out
