"""A benchmark another package registers is a plug-in, guarded as plug-in methods are: its module
is imported first in a worker process (one that exits, ends its process, raises or hangs there is
one line naming it and its entry point), then here under the plug-ins' time limit; every call the
tool makes to it or to its tally goes through `PluginObject` (what it raises, a SystemExit
included, or the time limit is one line naming it; what it returns is checked), and a run scores
its frames in worker processes whose shared slot names it (evaluation.plugin_call), so that one
which ends its process there is named too. This package's own benchmarks are trusted as the
built-in methods are: none of this, and no cost.
"""

from __future__ import annotations

import functools
import importlib.metadata
import json
import math
import re
import time
from typing import Any, Callable

from ..errors import ConfigError, PluginError, RoneldEvalError
from ..model import Dataset, Frame
from ..plugin_methods import PLUGIN_TIME_LIMIT_S

# Seconds a benchmark plug-in's import, or one of its calls, may take (as a plug-in method's frame
# by default); `read` and `synthesize` go over a whole dataset, and are not timed.
BENCHMARK_TIME_LIMIT_S = PLUGIN_TIME_LIMIT_S
_UNTIMED = frozenset({"read", "synthesize"})


def plugin_slot(name: str) -> str:
    """What a worker's shared slot (plugin_calls) says while a benchmark plug-in's call runs: no
    method's name has a space."""
    return f"benchmark {name}"


def load(point: importlib.metadata.EntryPoint) -> Any:
    """The object a third party's entry point names: its module imported in a worker process first,
    then here; ConfigError naming it and its entry where either fails."""
    from ..signals import TimeLimitExceeded, time_limit

    limit_s = BENCHMARK_TIME_LIMIT_S
    problem = _imported_in_a_worker(point.value, limit_s)
    if problem is None:
        try:
            with time_limit(limit_s):
                return point.load()
        except TimeLimitExceeded:
            problem = f"importing it {_too_slow(limit_s)}"
        except (Exception, SystemExit) as error:  # not KeyboardInterrupt: Ctrl-C is Ctrl-C
            problem = import_problem(error)
    raise ConfigError(f"benchmark {point.name!r} ({point.value}) cannot be loaded: {problem}")


def _imported_in_a_worker(entry: str, limit_s: float) -> str | None:
    """Why importing `entry` fails in a worker process (it raised or exited, ended the process,
    or took longer than `limit_s`), or None. Where no process can be started (a daemonic Dask
    worker) there is nothing to try it in: None."""
    import multiprocessing
    from concurrent.futures import TimeoutError as WaitedTooLong

    from ..evaluation.plugin_call import OVERDUE_GRACE_S, exit_text
    from ..workers import exit_codes, process_pool, stopping

    if multiprocessing.current_process().daemon:
        return None
    pool = process_pool(1)
    processes = dict(getattr(pool, "_processes", None) or {})

    def died() -> RoneldEvalError:
        codes = list(exit_codes(processes).values())
        return _Died(f"its process ended while importing it{exit_text(codes[0] if codes else None)}")

    try:
        with stopping(pool, died):
            return pool.submit(_import_here, entry, limit_s).result(timeout=limit_s + OVERDUE_GRACE_S)
    except WaitedTooLong:  # it blocked the alarm: the pool's worker is ended by `stopping`
        return f"importing it {_too_slow(limit_s)}"
    except _Died as died_inside:
        return str(died_inside)


class _Died(RoneldEvalError):
    """The probe's worker ended inside the import."""


def _import_here(entry: str, limit_s: float) -> str | None:
    """In the worker: why importing `entry` fails, or None."""
    from ..signals import TimeLimitExceeded, time_limit

    try:
        with time_limit(limit_s):
            importlib.metadata.EntryPoint(name="", value=entry, group="").load()
    except TimeLimitExceeded:
        return f"importing it {_too_slow(limit_s)}"
    except (Exception, SystemExit, KeyboardInterrupt) as error:  # in the probe, a plug-in's own: Ctrl-C
        return import_problem(error)  # reaches the main process, which stops on it
    return None


_CANNOT_IMPORT = re.compile(r"cannot import name '([^']+)'")


def import_problem(error: BaseException) -> str:
    """What importing a benchmark raised, in one line; where it reached into this package's own
    modules for a name they no longer have, what changed: a benchmark builds on roneld_eval.kit."""
    from ..evaluation.plugin_call import raised_text

    text = raised_text(error)
    module = getattr(error, "name", None) if isinstance(error, ImportError) else None
    own = __name__.split(".")[0]
    if not isinstance(module, str) or module.split(".")[0] != own or module == f"{own}.kit":
        return text
    import difflib

    from .. import kit

    try:
        found = _CANNOT_IMPORT.search(str(error))
    except Exception:  # its __str__ fails (raised_text said so)
        found = None
    name = found.group(1) if found else ""
    # the kit's name closest to the one it asked for (`format_culane_lines` is `format_lines_txt`)
    like = difflib.get_close_matches(name, kit.__all__, n=1, cutoff=0.6) if name else []
    where = f"{name} is kit.{like[0]}" if like else 'README "Your own benchmark"'
    return (f"{text}: it imports roneld-eval's own modules, as benchmarks written before the kit did; a "
            f"benchmark now builds on {own}.kit alone ({where})")


def _too_slow(limit_s: float) -> str:
    return f"took longer than {limit_s:g} s"


def _passed_through(member: str) -> tuple[type[BaseException], ...]:
    """What a call may raise as it is: the tool's own errors (InputError for a bad label file)
    and, from decode, TypeError and ValueError (its way of saying a record is malformed)."""
    return (RoneldEvalError, TypeError, ValueError) if member == "decode" else (RoneldEvalError,)


# ---- its calls ------------------------------------------------------------------------------


def _record_problem(record: Any, plugin: "PluginObject") -> str | None:
    """An official record must say itself as JSON (what the resume cache keeps) of finite numbers."""
    to_json = getattr(type(record), "to_json", None)
    if not callable(to_json):
        return f"returned {type(record).__name__}, not an official record (an object with to_json())"
    try:
        value = record.to_json()
    except (Exception, SystemExit) as error:
        from ..evaluation.plugin_call import raised_text

        return f"returned a record whose to_json() raised {raised_text(error)}"
    try:
        json.dumps(value, allow_nan=False)
    except ValueError:
        return "returned a record whose to_json() holds NaN or an infinite number"
    except (TypeError, RecursionError) as error:
        return f"returned a record whose to_json() is not JSON ({error})"
    return None


def _lane_file_problem(lane_file: Any, plugin: "PluginObject") -> str | None:
    from . import LaneFile

    if not isinstance(lane_file, LaneFile) or not isinstance(lane_file.name, str) \
            or not isinstance(lane_file.text, str):
        return f"returned {type(lane_file).__name__}, not a LaneFile of a name and a text"
    return None


def _dataset_problem(dataset: Any, plugin: "PluginObject") -> str | None:
    if not isinstance(dataset, Dataset):
        return f"returned {type(dataset).__name__}, not a roneld_eval.model.Dataset"
    return None


def _command_problem(command: Any, plugin: "PluginObject") -> str | None:
    import click

    if command is not None and not isinstance(command, click.Command):
        return f"returned {type(command).__name__}, not a click command or None"
    return None


def _table_problem(table: Any, plugin: "PluginObject") -> str | None:
    """The official table must be what compare reads back from official.csv: a DataFrame with
    every one of `official_columns`, each value of its kind, one row per `official_key`."""
    import numpy as np
    import pandas as pd

    from ..comparison.runs import EXPECTED, column_numbers

    if not isinstance(table, pd.DataFrame):
        return f"returned {type(table).__name__}, not a pandas DataFrame"
    benchmark = plugin.benchmark
    columns = dict(benchmark.official_columns)
    columns.update({name: kind for name, kind in benchmark.official_optional.items() if name in table.columns})
    missing = [name for name in columns if name not in table.columns]
    if missing:
        return f"returned a table without its official_columns {', '.join(map(str, missing))}"
    for name, kind in columns.items():
        if kind == "text":
            continue
        try:
            values = pd.Series(table[name]).to_numpy(object).tolist()  # Python's scalars, as they are shown
            _, bad = column_numbers(np.array(values, dtype=object), kind)
        except (TypeError, ValueError):  # cells that are not scalars, a column twice
            return f"returned a table whose column {name} holds values that are not numbers"
        if bad is not None:
            return f"returned a table whose column {name} holds {values[bad]!r}, not {EXPECTED[kind]}"
    if table.duplicated(list(benchmark.official_key)).any():
        return f"returned a table with two rows of one {', '.join(benchmark.official_key)}"
    return None


def _tally_problem(tally: Any, plugin: "PluginObject") -> str | None:
    missing = [name for name in _TALLY_CALLS if not callable(getattr(tally, name, None))]
    return f"returned a tally without {', '.join(missing)}" if missing else None


_Check = Callable[[Any, "PluginObject"], "str | None"]
_Unchecked: _Check = lambda result, plugin: None  # noqa: E731
# The calls of a benchmark and of its tally, each with the check of what it returns.
_BENCHMARK_CALLS: dict[str, _Check] = {
    "read": _dataset_problem, "with_labels": _Unchecked, "synthesize": _Unchecked, "label_paths": _Unchecked,
    "prepare": _Unchecked, "score": _record_problem, "tally": _tally_problem, "decode": _Unchecked,
    "lane_file": _lane_file_problem, "score_command": _command_problem, "official_protocol": _Unchecked,
    "official_note": _Unchecked, "check_official": _Unchecked, "official_comparison": _Unchecked,
    "category_panel": _Unchecked,
}
_TALLY_CALLS: dict[str, _Check] = {"add": _Unchecked, "end_clip": _Unchecked, "table": _table_problem}


class PluginObject:
    """A third party's benchmark, or the tally it made, with each call of the protocol guarded:
    made under the time limit (`_UNTIMED` apart), while the worker's shared slot names it; what it
    raises (but the tool's own errors it may raise for bad input, and decode's TypeError and
    ValueError, its way of saying a record is malformed) or returns wrong is a PluginError naming
    it, its entry and the frame. Anything else is passed through unchanged."""

    def __init__(self, target: Any, name: str, entry: str, calls: dict[str, _Check] = _BENCHMARK_CALLS,
                 benchmark: Any = None):
        self._target, self._calls = target, calls
        self.plugin_name, self.plugin_entry = name, entry
        self.benchmark = self if benchmark is None else benchmark
        self.time_limit_s = BENCHMARK_TIME_LIMIT_S if benchmark is None else benchmark.time_limit_s
        self.last_frame = ""  # score() is told no frame: the one prepare() was last given

    def __getattr__(self, member: str) -> Any:
        if member.startswith("_"):  # copy and pickle look for these: never the target's
            raise AttributeError(member)
        check = self._calls.get(member)
        try:
            value = getattr(self._target, member)
        except AttributeError:
            if check is None:
                raise
            raise PluginError(self.failed("", f"has no {member}()")) from None
        if check is None or not callable(value):
            return value
        return functools.partial(self._call, member, value, check)

    def failed(self, frame: str, problem: str) -> str:
        """The one line of a failure in one of its calls (on `frame`, if any)."""
        return f"benchmark {self.plugin_name!r} ({self.plugin_entry}){f', frame {frame}' if frame else ''}: {problem}"

    def _call(self, member: str, function: Callable, check: _Check, *args, **kwargs) -> Any:
        from ..evaluation.plugin_call import in_plugin_call, raised_text
        from ..signals import TimeLimitExceeded, time_limit

        frame = next((arg.relpath for arg in args if isinstance(arg, Frame)), None)
        owner = self.benchmark
        if frame is not None and member == "prepare":
            owner.last_frame = frame
        frame = frame or (owner.last_frame if member == "score" else "")
        limit = None if member in _UNTIMED else self.time_limit_s
        try:
            with in_plugin_call(plugin_slot(self.plugin_name), frame), time_limit(limit):
                started = time.perf_counter()
                result = function(*args, **kwargs)
                problem = check(result, owner)
                elapsed = time.perf_counter() - started
        except _passed_through(member):
            raise
        except TimeLimitExceeded:
            problem, elapsed = None, math.inf
        except (Exception, SystemExit) as error:  # not KeyboardInterrupt: Ctrl-C is Ctrl-C
            problem, elapsed = f"raised {raised_text(error)}", 0.0
        if limit is not None and elapsed > limit:  # cut by the alarm, or it blocked the alarm
            problem = _too_slow(limit)
        if problem is not None:
            raise PluginError(self.failed(frame, f"{member}() {problem}"))
        if member == "tally":
            return PluginObject(result, self.plugin_name, self.plugin_entry, _TALLY_CALLS, owner)
        return result


def plugin_of(benchmark: Any) -> PluginObject | None:
    """The guarded benchmark, if `benchmark` is a third party's."""
    return benchmark if isinstance(benchmark, PluginObject) else None
