"""A plug-in method's call, guarded: its prediction checked, its time limit kept, and its
worker's shared slot (plugin_calls) naming the call while it runs, so that the main process can
name it if the process ends inside."""

from __future__ import annotations

import contextlib
import time
from dataclasses import replace
from typing import Iterator

from ..config import EvalConfig
from ..errors import ExtractorError
from ..extract.protocol import Extractor, Prediction, prediction_problem
from ..extract.registry import Method
from ..model import Frame, FrameMaps, read_only
from ..plugin_calls import PluginCalls
from ..signals import TimeLimitExceeded, time_limit


def plugin_prediction(method: Method, extractor: Extractor, maps: FrameMaps, frame: Frame,
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
        with in_plugin_call(method.name, frame.relpath), time_limit(method.time_limit_s):
            start = time.perf_counter()
            prediction = extractor(maps)
            elapsed = time.perf_counter() - start
    except TimeLimitExceeded:
        problem = too_slow
    except (Exception, SystemExit) as error:  # sys.exit() in a plug-in must not end the run silently
        problem = f"raised {raised_text(error)}"
    else:
        if method.time_limit_s is not None and elapsed > method.time_limit_s:
            problem = too_slow  # it caught or blocked the alarm
        else:
            problem = prediction_problem(prediction, *(frame.image_size or config.geometry.image_size))
    if problem is not None:
        raise ExtractorError(method.name, frame.relpath, problem)
    extract_ms[method.name].append(elapsed * 1e3)
    return prediction


# This worker's shared call slots, in a worker of a run with plug-ins (set by pool._init_worker).
SLOTS: PluginCalls | None = None


@contextlib.contextmanager
def in_plugin_call(plugin: str, frame: str) -> Iterator[None]:
    """Within the block, this worker's shared slot names the plug-in call (plugin_calls: a method's
    name, or a benchmark's slot) and its frame, so the main process can name it if the process
    ends inside."""
    if SLOTS is None:
        yield
        return
    SLOTS.enter(plugin, frame)
    try:
        yield
    finally:
        SLOTS.leave()


def too_slow_text(method: str, limit_s: float | None) -> str:
    return f"took longer than {limit_s or 0:g} s (time_limit_s in [methods.{method}])"


# How long past its time limit a plug-in call may run before the main process ends its worker:
# SIGALRM stops it inside the worker, unless the plug-in blocks or ignores that signal.
OVERDUE_GRACE_S = 2.0


RAISED_TEXT_CHARS = 500  # of a plug-in's message: one line, not the 5 MB one an attack pass raised


def raised_text(error: BaseException) -> str:
    """'Type: first line of its message' (cut to RAISED_TEXT_CHARS), or the type alone where its
    message is empty or cannot be made (a __str__ that raises)."""
    try:
        text = str(error).strip().splitlines()
    except Exception:  # a plug-in's exception whose __str__ fails: its type is what is known
        text = []
    if not text:
        return type(error).__name__
    line = text[0] if len(text[0]) <= RAISED_TEXT_CHARS else text[0][:RAISED_TEXT_CHARS] + " …"
    return f"{type(error).__name__}: {line}"


def exit_text(code: int | None) -> str:
    """' (exit status 0)', ' (signal 9)', or '' where the exit code is not known."""
    return "" if code is None else f" (exit status {code})" if code >= 0 else f" (signal {-code})"
