"""Compiling the numba kernels ahead of a run: once, in parallel, and never inside a timed region.

numba compiles a kernel the first time it meets new argument types and keeps the machine code
in its on-disk cache (roneld_eval._numba_cache), so only the first run after an install (or an
upgrade) compiles: about 60 s of CPU time on the machine this is developed on. Left to itself,
that happens inside every worker process at once, in the middle of the first clip. Instead:

- `prepare()` runs once in the main process before the workers start. It looks the kernels up
  in the cache (index files only, ~2 ms); when some are missing it says so through `announce`
  and compiles them in parallel processes that share numba's cache, in `STEPS` that hand the
  kernels they compiled to the steps that call them through that cache.
- `warm_up()` runs in every process that evaluates (each worker as it starts, and the main
  process before evaluating in-process): it loads from the cache what the process lacks
  (~0.4 s, the workers in parallel) and runs every extractor's code path once, RONELD's curve
  mode included, so that no compile or first-call import lands in a timed region.

Kernel groups: "roneld" and "baseline" (extract/_kernels.ENTRY_SIGNATURES), "official",
"paper", "diagnosis" and "topview" (metrics/_kernels/__init__.py ENTRY_SIGNATURES; each brings
"tables"), and "maps" (decoding PNG maps, maps/_kernels.ENTRY_SIGNATURES). `groups_for` says
which a run needs. Nothing here changes a result: it only decides when compiling happens.
The extractors' and the maps' kernels (and their modules) are imported only when one of their
groups is asked for, so `score culane` loads the scoring kernels alone.
"""

from __future__ import annotations

import contextlib
import gc
import os
import time
from dataclasses import dataclass
from multiprocessing.connection import wait
from types import ModuleType
from typing import Any, Callable, Iterable

from ._numba_cache import cache_dir, compile_now, in_cache
from .metrics import _kernels as metric_kernels
from .metrics.raster import warm_up as warm_up_scoring
from .signals import deferred_signals

GROUPS = ("roneld", "baseline", "official", "paper", "diagnosis", "topview", "maps")
EXTRACTION = ("roneld", "baseline")
SCORING = ("official", "paper", "diagnosis", "topview")
LOADING = ("maps",)

@dataclass(frozen=True)
class Step:
    """Kernels compiled together, in one process, after the steps whose kernels they call: those
    are then loaded from numba's cache, not compiled again, so a long chain of callers and
    callees (the scoring kernels, about 40 s on one core) can spread over processes."""

    name: str
    groups: frozenset[str]  # the kernel groups that need it (a scoring group brings "tables")
    kernels: tuple[str, ...]  # by name: entries of those groups' ENTRY_SIGNATURES, or CALLEE_SIGNATURES
    after: tuple[str, ...] = ()  # steps whose kernels these call
    seconds: float = 1.0  # compiling it from nothing on one core (scripts/bench_cold.py --steps)

    @property
    def callees_only(self) -> bool:
        """Whether it exists only so that later steps need not compile its kernels."""
        return self.groups == _CALLEES


_CALLEES = frozenset({"callees"})
_TABLES = frozenset({"tables"})
# Callees before their callers. The seconds (scripts/bench_cold.py --steps, on the 2-core
# machine this is developed on; the first step of a process includes numba's own start) decide
# the order in which processes take the steps up (in_order).
STEPS = (
    Step("raster tables", _TABLES, ("step_extras", "clip_extras"), seconds=5.3),
    Step("lane runs", _CALLEES, ("polyline_runs",), seconds=7.0),
    Step("lane pixels", _CALLEES, ("official_pixels", "map_spline_pixels"), seconds=2.9),
    Step("lane sets", frozenset({"official", "paper"}), ("lane_set_runs", "lane_set_ious"),
         after=("lane runs", "lane pixels"), seconds=2.4),
    Step("overlaps", _TABLES, ("overlap", "run_overlap"), seconds=0.6),
    Step("matching", frozenset({"official"}), ("matched_ious",), seconds=1.2),
    Step("lane errors", frozenset({"diagnosis"}), ("matched_columns", "lane_error_counts", "swept_true_positives"),
         seconds=1.5),
    Step("roneld", frozenset({"roneld"}), ("frame_lanes", "track_lanes", "choose_active"), seconds=4.6),
    Step("baseline", frozenset({"baseline"}), ("row_argmax",), seconds=0.2),
    Step("maps", frozenset({"maps"}), ("unfilter_grey",), seconds=0.7),
    Step("top view", frozenset({"topview"}), ("short_quad_extras", "rasterise_with_area"), seconds=3.0),
)
_STEP_NAMED = {step.name: step for step in STEPS}


def _kernel_modules(groups: Iterable[str] | None = None) -> tuple[ModuleType, ...]:
    """The kernel modules holding these groups (default: all), the extractors' and the maps'
    imported only here."""
    wanted = set(GROUPS if groups is None else groups)
    modules: list[ModuleType] = []
    if wanted & set(EXTRACTION):
        from .extract import _kernels as extract_kernels

        modules.append(extract_kernels)
    modules.append(metric_kernels)
    if wanted & set(LOADING):
        from .maps import _kernels as map_kernels

        modules.append(map_kernels)
    return tuple(modules)


def groups_for(methods, benchmark, maps_format: str | None = None) -> tuple[str, ...]:
    """The kernel groups a run needs: its methods' (extract.registry.Method.kernel_groups), its
    benchmark's official scoring, the paper's protocol, which every run scores with, and for
    maps their format decodes with numba (maps.formats.MapFormat.kernel_groups)."""
    needed = [group for method in methods for group in method.kernel_groups]
    needed += list(benchmark.kernel_groups) + ["paper"]
    from .maps.formats import LANE_FILES, map_format

    if maps_format is not None and maps_format != LANE_FILES:
        needed += list(map_format(maps_format).kernel_groups)
    return tuple(dict.fromkeys(needed))


def _groups(needed: Iterable[str] | None) -> tuple[str, ...]:
    needed = GROUPS if needed is None else tuple(needed)
    unknown = set(needed) - set(GROUPS)
    if unknown:
        raise ValueError(f"unknown kernel groups {sorted(unknown)}; known: {', '.join(GROUPS)}")
    return tuple(group for group in GROUPS if group in needed)


def _entries(groups: Iterable[str]) -> list[tuple[object, tuple]]:
    """(kernel, argument types) of these groups (including "tables" for a scoring group)."""
    groups = set(groups)
    if groups & set(SCORING):
        groups.add("tables")
    entries: list[tuple[object, tuple]] = []
    for module in _kernel_modules(groups):
        for group, listed in module.ENTRY_SIGNATURES.items():
            if group in groups:
                entries += listed
    return entries


def _step_entries(step: Step) -> list[tuple[object, tuple]]:
    """(kernel, argument types) of a step, each once."""
    listed = metric_kernels.CALLEE_SIGNATURES if step.callees_only else _entries(step.groups)
    entries: list[tuple[object, tuple]] = []
    for kernel, signature in listed:
        if getattr(kernel, "__name__", "") in step.kernels and (kernel, signature) not in entries:
            entries.append((kernel, signature))
    return entries


def _steps(groups: Iterable[str]) -> list[Step]:
    """The steps that compile these kernel groups, callees first (a scoring group brings "tables")."""
    groups = set(groups)
    if groups & set(SCORING):
        groups.add("tables")
    wanted = [step for step in STEPS if step.groups & groups]
    needed_first = {name for step in wanted for name in step.after}
    return [step for step in STEPS if step in wanted or step.name in needed_first]


def missing_steps(needed: Iterable[str] | None = None) -> list[Step]:
    """The compile steps of `needed` groups that neither this process nor numba's cache holds.
    A step of callees only is missing only while a step that calls them is.

    A kernel whose presence cannot be told (see `_numba_cache.in_cache`) counts as present:
    it is then compiled where it is loaded, without an announcement.
    """
    steps = _steps(_groups(needed))
    missing = [step for step in steps if not step.callees_only
               and any(in_cache(kernel, signature) is False for kernel, signature in _step_entries(step))]
    called = {name for step in missing for name in step.after}
    return [step for step in steps if step in missing or step.name in called]


def in_order(steps: list[Step]) -> list[Step]:
    """The steps in the order processes take them up: the longest chain of steps still to follow
    first (by their measured seconds), so a step always comes before the steps that call its kernels."""
    names = {step.name for step in steps}

    def chain(step: Step) -> float:
        return step.seconds + max((chain(other) for other in steps if step.name in other.after), default=0.0)

    assert all(name in names for step in steps for name in step.after), "a step without the steps it calls"
    return sorted(steps, key=lambda step: (-chain(step), STEPS.index(step)))


def prepare(announce: Callable[[str], None] | None = None, needed: Iterable[str] | None = None,
            processes: int | None = None) -> None:
    """Make sure numba's cache holds every kernel of the `needed` groups (default: all).

    Call once in the main process before worker processes start. When the cache lacks some
    (the first run after an install or an upgrade), `announce` (if given) receives one line
    saying so, and they are compiled in up to `processes` (default: the usable cores) processes
    at once, with a line on how far it is every PROGRESS_EVERY_S. Nothing else happens when the
    cache is warm. Each evaluating process then calls `warm_up`.
    """
    steps = missing_steps(needed)
    if steps:
        from .workers import worker_count

        parallel = worker_count(None if processes is None else max(1, processes))
        if cache_dir() is None:
            parallel = 1  # without a cache other processes cannot hand their work over
        parallel = min(parallel, len(steps))
        # Counted: what is compiled, not the callees a missing step only loads from the cache.
        total = sum(in_cache(kernel, signature) is not True for step in steps
                    for kernel, signature in _step_entries(step))
        if announce is not None:
            announce(f"compiling {total} numba kernels for this installation in {parallel} "
                     f"process{'es' if parallel > 1 else ''} (once: later runs and installs of this version "
                     f"load them from the cache); progress every {PROGRESS_EVERY_S:g} s")
        _compile_in_parallel(in_order(steps), parallel, announce, total)


# How often a compile says how far it is: a first run must never look hung.
PROGRESS_EVERY_S = 5.0


_TO_DO, _TAKEN, _DONE = 0, 1, 2  # a step's state in a compile shared between processes


def _take(order: list[Step], state: Any) -> tuple[Step | None, bool]:
    """(the first step of `order` still to do whose callees are done, taken now; whether any
    step is not done yet: one taken may come back, should its process end)."""
    with state.get_lock():
        for step in order:
            if state[STEPS.index(step)] == _TO_DO and all(
                    state[STEPS.index(_STEP_NAMED[name])] == _DONE for name in step.after):
                state[STEPS.index(step)] = _TAKEN
                return step, True
        return None, any(state[STEPS.index(step)] != _DONE for step in order)


def _compile_step(step: Step, done: Any = None) -> None:
    """Compile (or load) every kernel of this step; in a compiling process, into the cache.
    `done`: a shared counter of compiled kernels (not those loaded), for the progress lines."""
    for kernel, signature in _step_entries(step):
        compiled = done is not None and in_cache(kernel, signature) is not True
        compile_now(kernel, signature)
        if compiled:
            with done.get_lock():
                done.value += 1


def _compile_in_child(order: list[Step], done: Any, state: Any, parent: int, taken: Any, index: int) -> None:
    """A compiling process: takes up steps until none is left (the parent alone decides about
    Ctrl-C and termination; killed with it, so a first run killed while compiling leaves nothing
    behind). `taken[index]`: the step it is compiling, so that the parent can hand it to another
    process should this one end."""
    from .workers import die_with_parent, leave_signals_to_parent

    leave_signals_to_parent()
    die_with_parent(parent)
    while True:
        step, more = _take(order, state)
        if step is None:
            if not more:
                return
            time.sleep(0.02)  # what is left calls kernels another process is compiling
            continue
        taken[index] = STEPS.index(step)
        _compile_step(step, done)
        with state.get_lock():
            state[STEPS.index(step)] = _DONE


def _compile_in_parallel(order: list[Step], processes: int, announce: Callable[[str], None] | None = None,
                         total: int = 0) -> None:
    """The steps in `processes` processes, each taking up the next step it can (`_take`); the
    results reach this process and the workers through numba's cache (`warm_up` loads them, and
    compiles whatever a failed one left).

    This process only waits, so Ctrl-C or SIGTERM ends the wait at once and cleanly: an
    interrupted compile inside numba itself would surface as numba's own RuntimeError. The step
    of a process that ends (killed, out of memory) goes back to the others; when none is left,
    what remains compiles where it is first needed.
    Without a cache folder the steps are compiled here, as nothing could hand them over.
    """
    if cache_dir() is None:
        for step in order:
            with deferred_signals():  # as in warm_up: numba must not be interrupted half way
                _compile_step(step)
        return
    from .workers import pool_context

    context = pool_context()
    done = context.Value("i", 0)
    state = context.Array("b", [_TO_DO if step in order else _DONE for step in STEPS])
    taken = context.Array("i", [-1] * processes, lock=False)
    helpers = [context.Process(target=_compile_in_child, args=(order, done, state, os.getpid(), taken, index),
                               daemon=True)
               for index in range(processes)]
    start = time.monotonic()
    try:
        for helper in helpers:
            helper.start()
        alive = helpers
        while alive:
            alive = _watch(helpers, alive, time.monotonic() + PROGRESS_EVERY_S, state, taken, announce)
            if announce is not None and (alive or done.value):  # the last line says it is over
                announce(f"compiling kernels: {done.value} of {total} done, {time.monotonic() - start:.0f} s")
    finally:
        for helper in helpers:
            if helper.is_alive():
                helper.kill()
                helper.join()


def _watch(helpers: list, alive: list, deadline: float, state: Any, taken: Any,
           announce: Callable[[str], None] | None) -> list:
    """Wait until `deadline` or until no compiling process is left; the step of each that ends
    badly goes back to the others (`_hand_back`). Returns the processes still alive."""
    while alive and time.monotonic() < deadline:
        wait([helper.sentinel for helper in alive], max(0.0, deadline - time.monotonic()))
        # Each exit status read once: a process that ends between two reads must not leave the
        # living ones without being handed back.
        statuses = [(index, helper, helper.exitcode) for index, helper in enumerate(helpers) if helper in alive]
        alive = [helper for _, helper, status in statuses if status is None]
        for index, _, status in statuses:
            if status not in (None, 0):
                _hand_back(state, taken[index])
                if announce is not None:
                    announce(f"a compiling process ended (exit status {status}): "
                             + (f"its work goes to the other{'s' if len(alive) > 1 else ''}" if alive else
                                "what is left compiles where it is first needed, without progress lines"))
    return alive


def _hand_back(state: Any, step: int) -> None:
    """A step whose process ended before it was done: to do again, by another process."""
    if step < 0:
        return
    with state.get_lock():
        if state[step] == _TAKEN:
            state[step] = _TO_DO


def warm_up(needed: Iterable[str] | None = None) -> None:
    """Load the `needed` kernel groups (default: all) and run each code path once, here.

    Call in every process that evaluates, before anything is timed: each worker process as
    it starts, and the main process before evaluating in-process. Compiles only what neither
    this process nor numba's cache holds (nothing after `prepare`). About 0.3 s loading from
    the cache, 10 ms when the process has everything.
    """
    groups = _groups(needed)
    extraction = tuple(group for group in groups if group in EXTRACTION)
    scoring = tuple(group for group in groups if group in SCORING)
    # A signal waits for the end (signals.deferred_signals): raised inside numba's loading or a
    # kernel's first call (which unpickles its constants), its exception left half-made objects
    # behind: the next call into them crashed (SIGSEGV in 2 of 100 `score openlane` signalled in
    # their last second), or llvmlite freed one twice at exit (SIGABRT).
    with deferred_signals(), _collector_paused():
        if extraction:
            from .extract import warm_up as warm_up_extraction

            warm_up_extraction(extraction)
        if scoring:
            warm_up_scoring(("tables",) + scoring)
        for kernel, signature in _entries(group for group in groups if group in LOADING):
            compile_now(kernel, signature)  # one kernel, no callees: loaded, it runs at full speed


@contextlib.contextmanager
def _collector_paused():
    """The cyclic garbage collector off, then as it was. numba's first load from its cache
    builds its registries, ~56,000 objects that live as long as the process: collecting
    among them meanwhile finds nothing, and cost 0.06-0.09 s of a one-frame `score culane`."""
    was_enabled = gc.isenabled()
    gc.disable()
    try:
        yield
    finally:
        if was_enabled:
            gc.enable()


def dispatchers() -> dict[str, object]:
    """Every numba kernel of the package by qualified name ("roneld_eval.extract._kernels.frame_lanes"),
    each with `.signatures` (the argument types compiled in this process)."""
    found = {}
    for package in _kernel_modules():
        for module in getattr(package, "MODULES", (package,)):
            for name, value in vars(module).items():
                if hasattr(value, "signatures") and hasattr(value, "py_func") and value.__module__ == module.__name__:
                    found[f"{module.__name__}.{name}"] = value
    return found
