"""Signals in the main process: SIGTERM and SIGHUP end a run as Ctrl-C does, cleanly.

Without this, `kill` or a closed terminal ends the process at once: no message, staging
folders with half-written files left behind, workers orphaned. With it, every signal goes
through the same path as Ctrl-C (KeyboardInterrupt), so cleanup runs and one line is printed.
"""

from __future__ import annotations

import contextlib
import os
import signal
import sys
import threading
from typing import Iterator

from .errors import RoneldEvalError, RunInterrupted

_ENDING = (signal.SIGTERM, signal.SIGHUP)
_HELD = (signal.SIGINT, signal.SIGTERM, signal.SIGHUP)
_RESEND_AFTER_S = 0.01


class Terminated(KeyboardInterrupt):
    """SIGTERM or SIGHUP received: handled wherever Ctrl-C is."""

    def __init__(self, number: int):
        super().__init__(signal.Signals(number).name)
        self.number = number
        self.exit_code = 128 + number


# The signal of every interruption this module's handlers raised, in order: one that C code then
# swallowed and replaced with an error of its own is still known (interruptions_unwrapped).
_delivered: list[int] = []


def _raise_terminated(number, frame):
    _delivered.append(number)
    raise Terminated(number)


def _raise_interrupt(number, frame):
    """Ctrl-C as Python's own handler raises it, noted."""
    _delivered.append(number)
    raise KeyboardInterrupt


def _in_main_thread() -> bool:
    return threading.current_thread() is threading.main_thread()


@contextlib.contextmanager
def _handling(numbers, handler):
    """`handler` for these signals within the block (main thread only; elsewhere a no-op); after
    it, the previous handlers again, but where the block set another (`ignored_to_the_end`)."""
    if not _in_main_thread():
        yield
        return
    previous = {number: signal.getsignal(number) for number in numbers}
    for number in numbers:
        signal.signal(number, handler)
    try:
        yield
    finally:
        for number, old in previous.items():
            if signal.getsignal(number) is handler:
                signal.signal(number, old)


def ignored_to_the_end() -> None:
    """Ctrl-C, SIGTERM and SIGHUP ignored from now until the process ends (the command line's,
    once its command is over). Python hands a signal with a Python handler back to the default
    action while it shuts down: in the last tens of ms of an exit, after the command had said
    all and its results were complete, SIGTERM or SIGHUP ended the process without a word (and
    status 143 or 129), Ctrl-C gave a traceback. An ignored one stays ignored."""
    if _in_main_thread():
        for number in _HELD:
            signal.signal(number, signal.SIG_IGN)
    _interruption_handled()


def _interruption_handled() -> None:
    """Tell CPython that no interruption went unhandled: once a KeyboardInterrupt has left an
    exec() or eval() of a string (as numba, dataclasses and namedtuple make their code), CPython
    ends the process with SIGINT at exit, whatever caught it since (`_Py_UnhandledKeyboardInterrupt`):
    a Ctrl-C while `score` imported numba said "interrupted" and then died of SIGINT, status -2.
    The command has said its line and chosen its status. A Python without that flag: nothing."""
    try:
        import ctypes

        ctypes.c_int.in_dll(ctypes.pythonapi, "_Py_UnhandledKeyboardInterrupt").value = 0
    except (ImportError, AttributeError, ValueError, OSError):
        pass


@contextlib.contextmanager
def terminate_as_interrupt():
    """Within the block, SIGTERM and SIGHUP raise `Terminated` (a KeyboardInterrupt), Ctrl-C its
    KeyboardInterrupt as before (unless it is ignored, as in a background job), each noted for
    `interruptions_unwrapped`, and an interruption raised where Python cannot raise it is sent
    again (`_lost_interruptions_resent`)."""
    ctrl_c = (signal.SIGINT,) if _in_main_thread() and signal.getsignal(signal.SIGINT) is signal.default_int_handler \
        else ()
    with _handling(_ENDING, _raise_terminated), _handling(ctrl_c, _raise_interrupt), _lost_interruptions_resent():
        yield


@contextlib.contextmanager
def _lost_interruptions_resent():
    """A signal's exception raised inside a weakref callback or a __del__ (importlib's module-lock
    callback, when it lands during an import) is printed as "Exception ignored" and dropped, and
    the run carried on as if never signalled. Within the block such an interruption is sent again
    instead, to be raised at the next point that can raise."""
    if not _in_main_thread():
        yield
        return
    previous = sys.unraisablehook

    def hook(unraisable) -> None:
        error = unraisable.exc_value
        if isinstance(error, KeyboardInterrupt) and _in_main_thread():
            number = error.number if isinstance(error, Terminated) else signal.SIGINT
            # From another thread, a moment later: sent from here, its handler would raise here,
            # inside the hook, where the exception is dropped once more.
            resend = threading.Timer(_RESEND_AFTER_S, os.kill, (os.getpid(), number))
            resend.daemon = True
            resend.start()
        else:
            previous(unraisable)

    sys.unraisablehook = hook
    try:
        yield
    finally:
        sys.unraisablehook = previous


def interruption_within(error: BaseException | None) -> KeyboardInterrupt | None:
    """The Ctrl-C, SIGTERM or SIGHUP that `error` is, or that directly caused it. An interruption
    raised in Python code that C code called comes out of the C code as another exception it
    caused: numba's kernels unpickle their constants as they use them ("SystemError: ...
    returned a result with an exception set"); an extension module's initialisation during an
    import ("ImportError: initialization failed")."""
    seen: set[int] = set()
    while error is not None and id(error) not in seen:
        if isinstance(error, KeyboardInterrupt):
            return error
        seen.add(id(error))
        error = error.__cause__
    return None


@contextlib.contextmanager
def interruptions_unwrapped():
    """Within the block, an exception an interruption caused (interruption_within) is raised as
    that interruption: what runs numba's kernels in this process is then stopped as by Ctrl-C
    anywhere else, not as by a bug. So is any other error but the tool's own that follows an
    interruption raised within the block (terminate_as_interrupt's handlers note each): C code
    that called back into Python may swallow it and raise its own, naming no cause (matplotlib's
    Agg renderer, cut short while drawing a run's figure: "ValueError: Invalid bounding box", a
    traceback and exit 1, in 2 of 53 `run` signalled in their last second)."""
    delivered = len(_delivered)
    try:
        yield
    except Exception as error:
        interruption = interruption_within(error)
        if interruption is None and len(_delivered) > delivered and not isinstance(error, RoneldEvalError):
            number = _delivered[-1]
            interruption = KeyboardInterrupt() if number == signal.SIGINT else Terminated(number)
        if interruption is None:
            raise
        raise interruption from None


def signal_number(error: KeyboardInterrupt) -> int:
    """The signal an interruption stands for: SIGINT for Ctrl-C."""
    return error.number if isinstance(error, Terminated) else signal.SIGINT


def interruption_name(error: BaseException) -> tuple[str, int]:
    """('interrupted', 130) for Ctrl-C, ('terminated (SIGTERM)', 143) for a signal."""
    if isinstance(error, Terminated):
        return f"terminated ({signal.Signals(error.number).name})", error.exit_code
    return "interrupted", 130


@contextlib.contextmanager
def _noted() -> Iterator[list[int]]:
    """Within the block, Ctrl-C, SIGTERM and SIGHUP are only appended to the list it gives."""
    received: list[int] = []
    with _handling(_HELD, lambda number, frame: received.append(number)):
        yield received


@contextlib.contextmanager
def held_signals():
    """Hold Ctrl-C, SIGTERM and SIGHUP during the block, then act on the first one received.

    Used while results are put in place: once the block is over they are complete, so the
    interruption is reported as such (RunInterrupted, exit 128 + signal), not as a run that
    wrote nothing.
    """
    with _noted() as received:
        yield
    if received:
        name = signal.Signals(received[0]).name
        raise RunInterrupted(f"{name} received while the results were being put in place; they are complete",
                             exit_code=128 + received[0])


@contextlib.contextmanager
def deferred_signals():
    """Within the block, Ctrl-C, SIGTERM and SIGHUP are only noted; after it, the first one is
    sent again, to the handler that was there before (which raises, ends the process, or
    ignores it, as it would have).

    Around numba's loading and first calls (kernels.warm_up): interrupted there, numba and
    llvmlite leave half-made objects that crash the process later. For a fork of this process:
    a signal handled while the interpreter runs its fork hooks
    (logging's, threading's) raises inside them, where the exception is printed as "Exception
    ignored" and lost, and the interrupted run would carry on. Blocking the signals in the
    forking thread alone cannot prevent it: any other thread (tqdm's monitor, a library's) may
    take the signal, and its handler then runs in the main thread all the same.
    """
    with _noted() as received:
        yield
    if received:
        signal.raise_signal(received[0])


class TimeLimitExceeded(BaseException):
    """A call outlived its `time_limit` (a BaseException, so that `except Exception` in the
    code being timed does not swallow it)."""


@contextlib.contextmanager
def time_limit(seconds: float | None):
    """Interrupt the block after `seconds` (SIGALRM; main thread only, else no limit). Code
    inside a C call is interrupted when the call returns to Python."""
    if seconds is None or threading.current_thread() is not threading.main_thread():
        yield
        return

    def expired(number, frame):
        raise TimeLimitExceeded()

    previous = signal.signal(signal.SIGALRM, expired)
    signal.setitimer(signal.ITIMER_REAL, seconds)
    try:
        yield
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)
        signal.signal(signal.SIGALRM, previous)
