"""Compiling the numba kernels ahead of a run: once, in parallel, and never inside a timed region.

numba compiles a kernel the first time it meets new argument types and keeps the machine code
in its on-disk cache (roneld_eval._numba_cache), so only the first run after an install (or an
upgrade) compiles: about 20 s of CPU time. Left to itself, that happens inside every worker
process at once, in the middle of the first clip. Instead:

- `prepare()` runs once in the main process before the workers start. It looks the kernels up
  in the cache (index files only, ~2 ms); when some are missing it says so through `announce`
  and compiles them, independent groups in parallel processes that share numba's cache (one
  share in this process itself, which workers forked later inherit).
- `warm_up()` runs in every process that evaluates (each worker as it starts, and the main
  process before evaluating in-process): it loads from the cache what the process lacks
  (~0.4 s, the workers in parallel) and runs every extractor's code path once, RONELD's curve
  mode included, so that no compile or first-call import lands in a timed region.

Kernel groups: "roneld" and "baseline" (extract/_kernels.ENTRY_SIGNATURES), "official" and
"paper" (metrics/_kernels/__init__.py ENTRY_SIGNATURES; both bring "tables"), and "maps" (decoding PNG
maps, maps/_kernels.ENTRY_SIGNATURES). `groups_for` says which a run needs. Nothing here
changes a result: it only decides when compiling happens.
The extractors' and the maps' kernels (and their modules) are imported only when one of their
groups is asked for, so `score culane` loads the scoring kernels alone.
"""

from __future__ import annotations

import contextlib
import gc
import time
from types import ModuleType
from typing import Any, Callable, Iterable

from ._numba_cache import cache_dir, compile_now, in_cache
from .metrics import _kernels as metric_kernels
from .metrics.raster import warm_up as warm_up_scoring

GROUPS = ("roneld", "baseline", "official", "paper", "maps")
EXTRACTION = ("roneld", "baseline")
SCORING = ("official", "paper")
LOADING = ("maps",)

# Groups compiled in the same process, because their kernels share callees (the rasteriser),
# and the seconds each unit takes to compile from nothing on one core of the 2-core machine
# this is developed on (scripts/bench_cold.py): to balance processes and announce a duration.
_UNITS = {"roneld": ("roneld",), "baseline": ("baseline",), "scoring": ("tables", "official", "paper"),
          "maps": ("maps",)}
_UNIT_COMPILE_S = {"roneld": 9.0, "baseline": 1.0, "scoring": 32.0, "maps": 1.0}


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
    PNG maps ("scnn-png") their decoding."""
    needed = [group for method in methods for group in method.kernel_groups]
    needed += list(benchmark.kernel_groups) + ["paper"]
    if maps_format == "scnn-png":
        needed.append("maps")
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


def _compile_units(units: tuple[str, ...], done: Any = None) -> None:
    """Compile (or load) every kernel of these units; in a compiling process, into the cache.
    `done`: a shared counter of compiled kernels, for the progress lines."""
    for unit in units:
        for kernel, signature in _entries(_UNITS[unit]):
            compile_now(kernel, signature)
            if done is not None:
                with done.get_lock():
                    done.value += 1


def _schedule(units: list[str], processes: int) -> list[list[str]]:
    """Units in at most `processes` bins of about equal compile time, heaviest bin first."""
    bins: list[list[str]] = [[] for _ in range(max(1, min(processes, len(units))))]
    for unit in sorted(units, key=lambda name: -_UNIT_COMPILE_S[name]):
        min(bins, key=lambda b: sum(_UNIT_COMPILE_S[name] for name in b)).append(unit)
    return sorted(bins, key=lambda b: -sum(_UNIT_COMPILE_S[name] for name in b))


def missing_units(needed: Iterable[str] | None = None) -> list[str]:
    """The compile units of `needed` groups that neither this process nor numba's cache holds.

    A kernel whose presence cannot be told (see `_numba_cache.in_cache`) counts as present:
    it is then compiled where it is loaded, without an announcement.
    """
    groups = set(_groups(needed))
    units = []
    for unit, members in _UNITS.items():
        if not groups & set(members):
            continue
        wanted = [group for group in members if group in groups or group == "tables"]
        if any(in_cache(kernel, signature) is False for kernel, signature in _entries(wanted)):
            units.append(unit)
    return units


def prepare(announce: Callable[[str], None] | None = None, needed: Iterable[str] | None = None,
            processes: int | None = None) -> None:
    """Make sure numba's cache holds every kernel of the `needed` groups (default: all).

    Call once in the main process before worker processes start. When the cache lacks some
    (the first run after an install or an upgrade), `announce` (if given) receives one line,
    "compiling kernels for this installation (once; about N s)", and they are compiled in up to
    `processes` (default: the usable cores) processes at once. Nothing else happens when the
    cache is warm. Each evaluating process then calls `warm_up`.
    """
    groups = _groups(needed)
    units = missing_units(groups)
    if units:
        from .workers import worker_count

        parallel = worker_count(None if processes is None else max(1, processes))
        if cache_dir() is None:
            parallel = 1  # without a cache other processes cannot hand their work over
        bins = _schedule(units, parallel)
        total = sum(len(_entries(_UNITS[unit])) for unit in units)
        if announce is not None:
            announce(f"compiling {total} numba kernels for this installation in {len(bins)} "
                     f"process{'es' if len(bins) > 1 else ''} (once: later runs and installs of this version "
                     f"load them from the cache); progress every {PROGRESS_EVERY_S:g} s")
        _compile_in_parallel(bins, announce, total)


# How often a compile says how far it is: a first run must never look hung.
PROGRESS_EVERY_S = 5.0


def _compile_in_child(units: tuple[str, ...], done: Any = None) -> None:
    """A compiling process: the parent alone decides about Ctrl-C and termination."""
    from .workers import leave_signals_to_parent

    leave_signals_to_parent()
    _compile_units(units, done)


def _compile_in_parallel(bins: list[list[str]], announce: Callable[[str], None] | None = None,
                         total: int = 0) -> None:
    """Each bin in a process of its own; the results reach this process and the workers through
    numba's cache (`warm_up` loads them, and compiles whatever a failed one left).

    This process only waits, so Ctrl-C or SIGTERM ends the wait at once and cleanly: an
    interrupted compile inside numba itself would surface as numba's own RuntimeError.
    Without a cache folder the single bin is compiled here, as nothing could hand it over.
    """
    if cache_dir() is None:
        for units in bins:
            _compile_units(tuple(units))
        return
    from .workers import pool_context

    context = pool_context()
    done = context.Value("i", 0)
    helpers = [context.Process(target=_compile_in_child, args=(tuple(b), done), daemon=True) for b in bins]
    start = time.monotonic()
    try:
        for helper in helpers:
            helper.start()
        while any(helper.is_alive() for helper in helpers):
            deadline = time.monotonic() + PROGRESS_EVERY_S
            for helper in helpers:
                helper.join(max(0.0, deadline - time.monotonic()))
            if announce is not None and any(helper.is_alive() for helper in helpers):
                announce(f"compiling kernels: {done.value} of {total} done, {time.monotonic() - start:.0f} s")
    finally:
        for helper in helpers:
            if helper.is_alive():
                helper.kill()
                helper.join()


def warm_up(needed: Iterable[str] | None = None) -> None:
    """Load the `needed` kernel groups (default: all) and run each code path once, here.

    Call in every process that evaluates, before anything is timed: each worker process as
    it starts, and the main process before evaluating in-process. Compiles only what neither
    this process nor numba's cache holds (nothing after `prepare`). About 0.6 s loading from
    the cache (scipy's spline import included), 10 ms when the process has everything.
    """
    groups = _groups(needed)
    extraction = tuple(group for group in groups if group in EXTRACTION)
    scoring = tuple(group for group in groups if group in SCORING)
    with _collector_paused():
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
