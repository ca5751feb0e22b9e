"""Worker processes that never outlive the run nor hang it, used by `run` and `score` alike.

A worker ignores Ctrl-C (the main process decides what happens), dies with its parent (Linux
parent-death signal, and a check of the parent's pid as it starts), and is killed after a
short grace when the pool is stopped, so a stopped (SIGSTOP) or stuck worker cannot keep the
main process from exiting. Every fork holds Ctrl-C, SIGTERM and SIGHUP back until the child has
its own handlers, and defers them in the parent until the fork is over.
"""

from __future__ import annotations

import contextlib
import ctypes
import multiprocessing
import os
import signal
import sys
import threading
import time
from concurrent.futures import InvalidStateError, ProcessPoolExecutor
from concurrent.futures.process import BrokenProcessPool
from typing import Any, Callable, Iterator

from .errors import RoneldEvalError, RunInterrupted
from .signals import deferred_signals

_PR_SET_PDEATHSIG = 1
GRACE_S = 2.0
_PARENT_SIGNALS = (signal.SIGINT, signal.SIGTERM, signal.SIGHUP)


def leave_signals_to_parent() -> None:
    """In a child process: ignore Ctrl-C and let SIGTERM/SIGHUP end it plainly (the parent
    decides what an interruption means, and says so once)."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    for number in (signal.SIGTERM, signal.SIGHUP):
        signal.signal(number, signal.SIG_DFL)


@contextlib.contextmanager
def _forking() -> Iterator[None]:
    """Around a fork of this process. Ctrl-C, SIGTERM and SIGHUP are deferred here until the block
    ends (signals.deferred_signals), and stay pending in this thread, and so in the child, until
    `_become_child` has set the child's own handlers."""
    with deferred_signals():
        if not hasattr(signal, "pthread_sigmask"):  # pragma: no cover - not POSIX
            yield
            return
        previous = signal.pthread_sigmask(signal.SIG_BLOCK, _PARENT_SIGNALS)
        try:
            yield
        finally:
            signal.pthread_sigmask(signal.SIG_SETMASK, previous)


def _become_child(parent_pid: int) -> None:
    """In a process this module forked: its own signal handlers, then the signals the fork held
    back; death with the parent (Linux parent-death signal, armed before the parent's pid is
    checked, so a parent that died meanwhile is seen)."""
    leave_signals_to_parent()
    if hasattr(signal, "pthread_sigmask"):
        signal.pthread_sigmask(signal.SIG_UNBLOCK, _PARENT_SIGNALS)
    die_with_parent(parent_pid)


def die_with_parent(parent_pid: int) -> None:
    """In a forked child: killed when its parent dies (Linux parent-death signal, armed before the
    parent's pid is checked, so a parent that died meanwhile is seen), even by SIGKILL."""
    if sys.platform == "linux":
        with contextlib.suppress(OSError, AttributeError):
            libc = ctypes.CDLL(None, use_errno=True)
            libc.prctl(_PR_SET_PDEATHSIG, signal.SIGKILL, 0, 0, 0)
    if os.getppid() != parent_pid:
        os._exit(1)


class WorkerPool(ProcessPoolExecutor):
    """A ProcessPoolExecutor whose workers say why they could not start (`start_failure`)."""

    start_failures: Any = None  # a multiprocessing SimpleQueue: one line per worker that failed to start

    def start_failure(self) -> str | None:
        """Why a worker could not start (its initializer's error), or None."""
        queue = self.start_failures
        try:
            return None if queue is None or queue.empty() else str(queue.get())
        except (OSError, EOFError, ValueError):  # the queue's pipe is gone
            return None


def _start_worker(parent_pid: int, initializer: Callable[..., Any] | None, initargs: tuple, failures: Any) -> None:
    _become_child(parent_pid)
    if initializer is None:
        return
    try:
        initializer(*initargs)
    except BaseException as error:
        # Said once, to the parent, which ends the run with it: not concurrent.futures' traceback
        # per worker ("Exception in initializer") and then "a worker process died".
        with contextlib.suppress(Exception):
            failures.put(str(error) if isinstance(error, RoneldEvalError) else f"{type(error).__name__}: {error}")
        os._exit(3)


def pool_context():
    """The multiprocessing context of the pools: fork where the platform allows, for the
    shared memory and kernels made before the workers start."""
    return multiprocessing.get_context("fork" if sys.platform == "linux" else "spawn")


def process_pool(workers: int, initializer: Callable[..., Any] | None = None,
                 initargs: tuple = ()) -> WorkerPool:
    """Worker processes (forked where the platform allows). Unlike multiprocessing.Pool, a
    worker that dies makes its pending results raise BrokenProcessPool instead of hanging."""
    context = pool_context()
    method = context.get_start_method()
    failures = context.SimpleQueue()
    executor = WorkerPool(workers, mp_context=context, initializer=_start_worker,
                          initargs=(os.getpid(), initializer, initargs, failures))
    executor.start_failures = failures
    if method != "fork":
        return executor
    # The first submit forks every worker at once (fork start method), so none forks later,
    # outside this protection. A forked child runs the parent's signal handlers until
    # `_become_child` replaces them: a signal in that moment (the run's own SIGTERM to its
    # workers, Ctrl-C to the terminal's process group) raised inside the child's fork hooks and
    # printed a traceback; held back, it waits for the child's own handlers. In this process a
    # signal meanwhile is deferred to the end of the fork, not lost in its hooks.
    try:
        with _forking():
            executor.submit(int)
    except BaseException:  # the signal that waited: the workers exist, end them
        stop_pool(executor)
        raise
    return executor


def _quiet_about_cancelled_futures() -> None:
    """Make threading.excepthook drop one known exception of Python 3.11's pool manager thread.

    When workers are ended while some futures are cancelled (Ctrl-C in `pool.map`, whose
    generator cancels what is left), 3.11's terminate_broken sets an exception on those
    cancelled futures and its thread dies with InvalidStateError, printing a traceback under
    the interruption's one line (3.12 checks first). Nothing is lost by it.
    """
    previous = threading.excepthook
    if previous in _QUIET_HOOKS:
        return

    def hook(args) -> None:
        if issubclass(args.exc_type, InvalidStateError) and type(args.thread).__name__ == "_ExecutorManagerThread":
            return
        previous(args)

    _QUIET_HOOKS.add(hook)
    threading.excepthook = hook


_QUIET_HOOKS: set[Callable[..., None]] = set()


def _wait_for_end(process, deadline: float) -> None:
    # exitcode asks the kernel (waitpid); a join alone waits for the process's sentinel pipe to
    # close, which a process it forked (a plug-in's) holds open past its end: a run's one line
    # then came the whole grace (and the second after a kill) later.
    while process.exitcode is None and time.monotonic() < deadline:
        process.join(min(0.05, max(0.0, deadline - time.monotonic())))


DRAIN_S = 2.0  # the longest an ended pool's unread calls are drained
MANAGER_JOIN_S = 0.5  # a worker's forked process holding the pool's pipes keeps the thread alive: not waited out


def stop_pool(executor: ProcessPoolExecutor, grace_s: float = GRACE_S, finished: bool = False) -> None:
    """End every worker: SIGTERM (or, when `finished`, a polite request to exit), then SIGKILL
    for any still there after `grace_s`, so a stopped or stuck worker cannot hold us up."""
    processes = list((getattr(executor, "_processes", None) or {}).values())
    manager = getattr(executor, "_executor_manager_thread", None)  # shutdown forgets it
    calls = getattr(executor, "_call_queue", None)  # and this
    if finished:
        executor.shutdown(wait=False)
    else:
        _quiet_about_cancelled_futures()
        for process in processes:
            with contextlib.suppress(Exception):
                process.terminate()
    # A stopped worker (SIGSTOP) acts on neither until it is continued, so each is continued, as a
    # shell's `kill` continues a stopped job: it waited out the whole grace, while the pool's
    # manager thread spun on a core (Python's shutdown_workers retries a full call queue while any
    # worker lives). A worker already known to have exited is skipped: its pid may be another's now.
    for process in processes:
        with contextlib.suppress(Exception):
            if process.exitcode is None:
                os.kill(process.pid, signal.SIGCONT)
    deadline = time.monotonic() + grace_s
    for process in processes:
        with contextlib.suppress(Exception):
            _wait_for_end(process, deadline)
    for process in processes:
        with contextlib.suppress(Exception):
            if process.is_alive():
                process.kill()
                _wait_for_end(process, time.monotonic() + 1.0)
    executor.shutdown(wait=False, cancel_futures=True)
    if not finished and calls is not None:
        _drain_calls(calls)
    # The pool's manager thread closes its wake-up pipe as it ends; Python 3.11's exit handler
    # writes to that pipe unlocked, and one racing the close printed "Exception ignored ... Bad
    # file descriptor" after our one-line error (1 run in 50). Once the thread has ended, the
    # handler sees the pipe closed and writes nothing.
    if manager is not None:
        with contextlib.suppress(Exception):
            manager.join(MANAGER_JOIN_S)


def _drain_calls(calls, wait_s: float = DRAIN_S) -> None:
    """Read what the pool's call queue is still writing to its ended workers, and let the process
    exit without waiting for that writer. A call larger than a pipe holds (a chunk of parsed
    frames) left the queue's feeder thread blocked in its write for good, and the interpreter's
    exit waits for it: `score apollo3d` ended by SIGTERM hung there (as multiprocessing.Pool's
    own _help_stuff_finish drains its task pipe)."""
    with contextlib.suppress(Exception):
        calls.cancel_join_thread()
        feeder = calls._thread
        deadline = time.monotonic() + wait_s
        while feeder is not None and feeder.is_alive() and time.monotonic() < deadline:
            if calls._reader.poll(0.02):
                calls._reader.recv_bytes()
            elif not calls._buffer:
                break  # nothing being written: its thread waits for more, which never blocks an exit


@contextlib.contextmanager
def stopping(executor: ProcessPoolExecutor,
             died: Callable[[], str | RoneldEvalError]) -> Iterator[ProcessPoolExecutor]:
    """Use a pool and always end its workers: politely when the block finishes, at once when it
    fails. A worker that died makes the block end in RunInterrupted(`died()`), not a traceback,
    or in the error `died()` gives (one that names what the worker was doing)."""
    try:
        yield executor
    except BrokenProcessPool:
        stop_pool(executor)
        failure = executor.start_failure() if isinstance(executor, WorkerPool) else None
        if failure is not None:
            raise RunInterrupted(f"a worker process could not start: {failure}") from None
        reason = died()
        if isinstance(reason, RoneldEvalError):
            raise reason from None
        raise RunInterrupted(reason) from None
    except BaseException:
        stop_pool(executor)
        raise
    stop_pool(executor, finished=True)


def exit_codes(processes: dict[int, Any], wait_s: float = 2.0) -> dict[int, int | None]:
    """pid -> exit code of a broken pool's processes (`WorkerPool._processes`), all ended by now:
    waited for up to `wait_s`, as the pool's own thread may be reaping one (its code is None here
    until that thread has set it)."""
    deadline = time.monotonic() + wait_s
    while any(process.exitcode is None for process in processes.values()) and time.monotonic() < deadline:
        time.sleep(0.01)
    return {pid: process.exitcode for pid, process in processes.items()}


def worker_count(asked: int | None) -> int:
    """Processes to work in: `asked`, or all usable cores when None; 1 (this process alone) in a
    daemonic process, which may start none (a Dask worker running a shard is one)."""
    import multiprocessing

    if multiprocessing.current_process().daemon:
        return 1
    return asked or default_workers()


def default_workers() -> int:
    """All cores this process may use."""
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except AttributeError:  # pragma: no cover - not Linux
        return max(1, os.cpu_count() or 1)
