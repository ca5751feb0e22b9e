"""Many clips: in-process for one worker, else in a process pool whose results are handed out
in clip order (so any --workers gives the same bytes), cached ones first (--resume); a worker
that dies, or a plug-in past its time limit, ends the run with one line instead of a hang.
By default a small run starts fewer workers than cores (`pool_size`)."""

from __future__ import annotations

import contextlib
import functools
import multiprocessing
import os
import queue
import signal
from collections import deque
from concurrent.futures import Future
from concurrent.futures.process import BrokenProcessPool
from pathlib import Path
from typing import Callable, Iterator, Protocol, Sequence

from .. import kernels
from ..config import FRAMES_PER_DEFAULT_WORKER
from ..benchmarks.plugins import plugin_of, plugin_slot
from ..errors import ExtractorError, PluginError, RoneldEvalError
from ..maps import required_paths
from ..model import Clip
from ..plugin_calls import PluginCalls
from ..signals import deferred_signals, interruptions_unwrapped
from ..workers import exit_codes, pool_context, process_pool, stopping, worker_count
from . import one_clip, plugin_call
from .plugin_call import OVERDUE_GRACE_S, exit_text, too_slow_text
from .records import ClipResult, RunContext

# ---- many clips ----------------------------------------------------------------------------

_WORKER_CONTEXT: RunContext | None = None


def _init_worker(context: RunContext, calls: PluginCalls | None = None) -> None:
    global _WORKER_CONTEXT
    _WORKER_CONTEXT = context
    if calls is not None:
        calls.claim()
        plugin_call.SLOTS = calls
    kernels.warm_up(context.kernel_groups())  # loaded already (prepared before the fork): runs each path once


def _evaluate_in_worker(clip: Clip) -> ClipResult:
    assert _WORKER_CONTEXT is not None
    return one_clip.evaluate_clip(clip, _WORKER_CONTEXT)


class ClipCache(Protocol):
    """Where finished clips are kept so an interrupted run can resume (see roneld_eval.cache)."""

    def load(self, clip: Clip, inputs: Callable[[], Sequence[Path]]) -> ClipResult | None: ...

    def store(self, clip: Clip, inputs: Sequence[Path], result: ClipResult) -> None: ...


def clip_inputs(clip: Clip, context: RunContext) -> list[Path]:
    """Every file evaluating this clip reads: its maps and its labels (what resume must check)."""
    paths = []
    for frame in clip.frames:
        paths += required_paths(context.maps_root, frame.relpath, context.config.maps, context.lane_files)
    return paths + context.benchmark.label_paths(clip, context.data_root, context.label_file)


def pool_size(asked: int | None, clips: Sequence[Clip]) -> int:
    """Worker processes to evaluate `clips` in; 0: in this process, for one worker asked, one core
    or one clip (whose progress is then shown frame by frame, not at its end).

    `asked` (--workers) is kept as given, up to one worker per clip. The default (None: all
    usable cores) also starts at most one worker per FRAMES_PER_DEFAULT_WORKER frames, so a small
    run does not wait for workers it cannot keep busy; even one worker is then a process of its
    own, so that this one prepares the report while it warms up.
    """
    processes = worker_count(asked)
    if processes <= 1 or len(clips) <= 1:
        return 0
    if asked is None:
        frames = sum(len(clip.frames) for clip in clips)
        processes = min(processes, -(-frames // FRAMES_PER_DEFAULT_WORKER))
    return min(processes, len(clips))


def _clip_results(clips: Sequence[Clip], context: RunContext, asked: int | None,
                  cache: ClipCache | None = None,
                  advance: Callable[[int], object] | None = None,
                  meanwhile: Callable[[], object] | None = None) -> Iterator[ClipResult]:
    """Results in clip order: cached ones, then from `pool_size(asked, ...)` processes.

    Each finished clip is stored in the cache before it is yielded; `advance(frames)` is told
    of every frame as its clip finishes (in-process: as it is done). `meanwhile()` is called
    once the workers have started, while they warm up (not when evaluating in this process).
    A worker that dies (killed, out of memory) ends the run with RunInterrupted instead of a hang.
    """
    cached = _cached(clips, context, cache)
    todo = [index for index in range(len(clips)) if index not in cached]
    advance = advance or (lambda frames: None)
    workers = pool_size(asked, [clips[index] for index in todo])

    def keep(index: int, result: ClipResult) -> ClipResult:
        if cache is not None:
            cache.store(clips[index], clip_inputs(clips[index], context), result)
        return result

    # A plug-in (a method's, or a benchmark's scoring) always runs in a worker process, so that one
    # which ends its process (os._exit, a crash) ends a worker the run can name, not the run
    # itself with exit status 0; but in a daemonic process (a Dask worker's shard), which may start
    # none: there its calls are guarded in the process itself.
    plugins = not all(method.built_in for method in context.methods) or plugin_of(context.benchmark) is not None
    plugins = plugins and not multiprocessing.current_process().daemon
    if not todo or (not plugins and workers == 0):
        with interruptions_unwrapped():  # numba's kernels run in this process
            if todo:
                kernels.warm_up(context.kernel_groups())
            for index, clip in enumerate(clips):
                result = cached.get(index)
                if result is None:
                    result = keep(index, one_clip.evaluate_clip(clip, context, advance))
                else:
                    advance(len(clip.frames))
                yield result
        return
    yield from _pooled(clips, context, max(workers, 1), cached, todo, keep, advance, plugins, meanwhile)


def _cached(clips: Sequence[Clip], context: RunContext, cache: ClipCache | None) -> dict[int, ClipResult]:
    """The clips (by index) whose results the cache holds and still match their inputs."""
    cached: dict[int, ClipResult] = {}
    if cache is not None:
        # Input files are listed only where an entry is there to check, and for a finished clip
        # as it is kept: not all at once before any work starts (0.1 s per 6,000 frames).
        for index, clip in enumerate(clips):
            found = cache.load(clip, functools.partial(clip_inputs, clip, context))
            if found is not None:
                cached[index] = found
    return cached


def _pooled(clips: Sequence[Clip], context: RunContext, workers: int, cached: dict[int, ClipResult],
            todo: Sequence[int], keep: Callable[[int, ClipResult], ClipResult],
            advance: Callable[[int], object], plugins: bool,
            meanwhile: Callable[[], object] | None) -> Iterator[ClipResult]:
    """_clip_results in a process pool of `workers`."""
    calls = PluginCalls(workers, pool_context()) if plugins else None
    pool = process_pool(workers, initializer=_init_worker, initargs=(context, calls))
    schedule = _Schedule(pool, clips, todo, context, workers, advance)
    guard = _PoolGuard(pool, calls, context, schedule)
    schedule.watch = guard.watch if calls is not None else None
    with stopping(schedule.executor, guard.died):
        schedule.start_more()
        if meanwhile is not None:  # the workers exist (process_pool forks them all) and warm up
            # This process hands out no clip while it imports: the workers get twice as many
            # first, or they wait for it once they have warmed up and done their first ones.
            schedule.start_more(extra=schedule.limit)
            # Its imports are not cut by a signal, which is acted on once they are done: an
            # import cut by a signal's exception can leave its module's lock taken (the pool's
            # thread then hung unpickling a result), a half-made module, or the exception dropped.
            with deferred_signals():
                meanwhile()
        for index, clip in enumerate(clips):
            if index in cached:
                yield cached[index]
                advance(len(clip.frames))
                continue
            schedule.start_more()
            yield keep(index, schedule.result(index))


class _PoolGuard:
    """What ends a pooled run early: a plug-in call past its time limit (its worker is killed)
    and a worker that ended; and the one line that says which."""

    def __init__(self, pool, calls: PluginCalls | None, context: RunContext, schedule: "_Schedule"):
        self.processes = dict(getattr(pool, "_processes", None) or {})  # pid -> Process: their exit codes tell
        self.calls = calls
        self.schedule = schedule
        self.limits = {method.name: method.time_limit_s for method in context.methods}
        self.benchmark = plugin_of(context.benchmark)  # a third party's, whose calls are plug-in calls too
        if self.benchmark is not None:
            self.limits[plugin_slot(self.benchmark.plugin_name)] = self.benchmark.time_limit_s
        self.stopped: dict[int, tuple[str, str]] = {}  # workers ended here for a plug-in past its limit

    def watch(self) -> None:
        assert self.calls is not None
        for pid, call in self.calls.overdue(self.limits, OVERDUE_GRACE_S).items():
            self.stopped[pid] = call
            with contextlib.suppress(OSError):
                os.kill(pid, signal.SIGKILL)
        # A worker that ended while a process it forked holds its pipes open: the pool would
        # wait for that process, so the worker's end is looked for here (exitcode reaps it).
        if any(process.exitcode is not None for process in self.processes.values()):
            raise BrokenProcessPool("a worker process ended")

    def died(self) -> str | RoneldEvalError:
        codes = exit_codes(self.processes)
        if self.stopped:
            pid, (method, frame) = next(iter(self.stopped.items()))
            return self._failed(method, frame, None)
        inside = None if self.calls is None else self.calls.died_in(codes)
        if inside is not None:
            method, frame, code = inside
            return self._failed(method, frame, f"its process ended inside the plug-in{exit_text(code)}")
        return f"a worker process died (killed, or out of memory) while evaluating clip {self.schedule.current}"

    def _failed(self, plugin: str, frame: str, problem: str | None) -> RoneldEvalError:
        """The error of a plug-in call, a method's or the benchmark's (named by its slot): its
        process ended (`problem`), or it was ended here past its time limit (None)."""
        benchmark = self.benchmark
        if benchmark is not None and plugin == plugin_slot(benchmark.plugin_name):
            return PluginError(benchmark.failed(frame, problem or f"took longer than {benchmark.time_limit_s:g} s"))
        return ExtractorError(plugin, frame, problem or too_slow_text(plugin, self.limits[plugin]))


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

    def start_more(self, extra: int = 0) -> None:
        failed = min((index for index, done in self.done.items() if isinstance(done, BaseException)), default=None)
        limit = self.limit + extra
        while self.waiting and len(self.started) < limit and len(self.tasks) < limit:
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
