"""Worker processes and signals: a signal that reaches a worker before it has its own handlers."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import pytest

from roneld_eval import workers
from roneld_eval.errors import RunInterrupted
from test_run_integrity import alive, process_state, wait_for

# The child sends itself the signal from a fork hook, that is before `_start_worker` runs: the
# moment in which a worker still has the parent's handlers. The parent's are the run's own:
# SIGTERM raises Terminated, Ctrl-C raises KeyboardInterrupt.
SCRIPT = textwrap.dedent("""
    import os, signal, sys
    from concurrent.futures.process import BrokenProcessPool
    from roneld_eval import signals, workers

    number = signal.Signals[sys.argv[1]]
    os.register_at_fork(after_in_child=lambda: os.kill(os.getpid(), number))
    with signals.terminate_as_interrupt():
        pool = workers.process_pool(2)
        try:
            print("result", pool.submit(sum, [1, 2]).result(timeout=60))
        except BrokenProcessPool:
            print("workers ended")
        workers.stop_pool(pool, finished=True)
""")


@pytest.mark.skipif(sys.platform != "linux", reason="workers are forked on Linux only")
@pytest.mark.parametrize("name, outcome", [
    ("SIGTERM", "workers ended"),  # the default action: the worker ends, as the parent meant
    ("SIGHUP", "workers ended"),
    ("SIGINT", "result 3"),        # workers ignore Ctrl-C: the parent decides
])
def test_a_signal_before_a_worker_has_its_handlers_waits_for_them(name, outcome):
    done = subprocess.run([sys.executable, "-c", SCRIPT, name], capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr
    assert done.stdout.strip() == outcome
    assert done.stderr == ""  # before: "Exception ignored in: <function ...>" and a traceback per worker


# ---- a signal to this process while it forks ----------------------------------------------------

# The signal is sent from a fork hook of the parent: it arrives while the interpreter runs its fork
# hooks, where a handler's exception would be printed as "Exception ignored" and lost.
DURING_FORK = textwrap.dedent("""
    import os, signal, sys, threading, time
    from pathlib import Path
    from roneld_eval import signals, workers

    # Another thread, as a run has (tqdm's monitor): the kernel may hand it the signal (here it
    # is sent to it), whose handler then runs in the main thread all the same, in the fork.
    other = threading.Thread(target=time.sleep, args=(30,), daemon=True)
    other.start()
    number = signal.Signals[sys.argv[1]]

    # The C handler writes each signal it takes to this pipe, whichever thread it runs in.
    taken, wakeup = os.pipe()
    os.set_blocking(taken, False)
    os.set_blocking(wakeup, False)
    signal.set_wakeup_fd(wakeup)

    def hook():  # Python code, as the interpreter's own hooks (logging's) are
        signal.pthread_kill(other.ident, number)
        end = time.monotonic() + 30
        while time.monotonic() < end:  # until the other thread has taken it, however loaded the machine
            try:
                if os.read(taken, 1):
                    break
            except BlockingIOError:
                pass
        for _ in range(1000):  # the main thread's handler runs here, inside the fork's hooks
            pass

    os.register_at_fork(after_in_parent=hook)

    with signals.terminate_as_interrupt():
        try:
            pool = workers.process_pool(2)
            workers.stop_pool(pool, finished=True)
        except KeyboardInterrupt as error:
            print("interrupted", type(error).__name__, flush=True)
        else:
            print("carried on", flush=True)
    deadline = time.monotonic() + 30  # until they have ended (active_children reaps them), however loaded the machine
    while workers.multiprocessing.active_children() and time.monotonic() < deadline:
        time.sleep(0.01)
    print("children", len(workers.multiprocessing.active_children()), flush=True)
""")


@pytest.mark.skipif(sys.platform != "linux", reason="forks on Linux only")
@pytest.mark.parametrize("name, raised", [("SIGTERM", "Terminated"), ("SIGINT", "KeyboardInterrupt")])
def test_a_signal_while_forking_interrupts_and_leaves_no_process(tmp_path, name, raised):
    done = subprocess.run([sys.executable, "-c", DURING_FORK, name],
                          capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr
    assert done.stdout.split("\n")[:2] == [f"interrupted {raised}", "children 0"], done.stdout
    assert "Exception ignored" not in done.stderr and "Traceback" not in done.stderr, done.stderr


# ---- a worker that cannot start -------------------------------------------------------------------


def _failing_start():
    raise MemoryError("no memory for the kernels")


@pytest.mark.skipif(sys.platform != "linux", reason="forks on Linux only")
def test_a_worker_that_cannot_start_says_why_once(capfd):
    pool = workers.process_pool(2, initializer=_failing_start)
    with pytest.raises(RunInterrupted) as raised:
        with workers.stopping(pool, lambda: "a worker process died"):
            pool.submit(sum, [1, 2]).result(timeout=60)
    assert str(raised.value) == "a worker process could not start: MemoryError: no memory for the kernels"
    captured = capfd.readouterr()
    assert "Traceback" not in captured.err and "Exception in initializer" not in captured.err, captured.err


@pytest.mark.skipif(sys.platform != "linux", reason="forks on Linux only")
def test_a_worker_that_dies_later_is_still_said_to_have_died():
    pool = workers.process_pool(2)
    with pytest.raises(RunInterrupted, match="^a worker process died$"):
        with workers.stopping(pool, lambda: "a worker process died"):
            pool.submit(os._exit, 9).result(timeout=60)


def _fork_a_child(pid_file: str) -> None:
    child = os.fork()
    if child == 0:  # holds its parent's pipes, the worker's sentinel among them, until killed
        time.sleep(300)
        os._exit(0)
    Path(pid_file).write_text(str(child))


def _seconds_to_stop(pool, grace_s: float, pid_files: list[Path], finished: bool = False) -> float:
    """How long stop_pool takes; then the processes the workers forked are killed."""
    try:
        start = time.monotonic()
        workers.stop_pool(pool, grace_s=grace_s, finished=finished)
        return time.monotonic() - start
    finally:
        for pid_file in pid_files:
            os.kill(int(pid_file.read_text()), signal.SIGKILL)


def _end_leaving_a_child(pid_file: str) -> None:
    _fork_a_child(pid_file)
    os._exit(0)


@pytest.mark.skipif(sys.platform != "linux", reason="forks on Linux only")
def test_a_worker_that_ended_is_not_waited_for_while_a_process_it_forked_lives(tmp_path):
    # Joined on its sentinel pipe, which that process holds open, an ended worker was waited for
    # the whole grace: a run whose plug-in forked and ended said so 2 s late. Here, 60 s.
    pool = workers.process_pool(1)
    pool.submit(_end_leaving_a_child, str(tmp_path / "child"))
    (process,) = pool._processes.values()
    assert wait_for(lambda: not alive(process.pid))  # ended, its exit code not yet asked for
    assert _seconds_to_stop(pool, 60, [tmp_path / "child"]) < 30


def _stuck_leaving_a_child(pid_file: str) -> None:
    signal.signal(signal.SIGTERM, signal.SIG_IGN)
    _fork_a_child(pid_file)
    while True:
        time.sleep(0.01)


@pytest.mark.skipif(sys.platform != "linux", reason="forks on Linux only")
def test_workers_killed_after_the_grace_are_not_waited_for_while_processes_they_forked_live(tmp_path):
    # After the SIGKILL each was joined for up to 1 s on its sentinel: 2.3 s for these two.
    pool = workers.process_pool(2)
    for k in range(2):
        pool.submit(_stuck_leaving_a_child, str(tmp_path / f"child{k}"))
    assert wait_for(lambda: all((tmp_path / f"child{k}").exists() for k in range(2)))
    assert _seconds_to_stop(pool, 0.2, [tmp_path / f"child{k}" for k in range(2)]) < 1.5


def _wait_stopped() -> None:
    os.kill(os.getpid(), signal.SIGSTOP)


@pytest.mark.skipif(sys.platform != "linux", reason="signals of Linux")
@pytest.mark.parametrize("finished, exitcode", [(False, -signal.SIGTERM), (True, 0)])
def test_a_stopped_worker_ends_at_once_not_after_the_grace(finished, exitcode):
    # Stopped, it held the SIGTERM (or the request to exit of a finished run) until the SIGKILL
    # after the grace: 2 s in a run, 60 s here.
    pool = workers.process_pool(1)
    (process,) = pool._processes.values()
    if finished:  # idle, between clips or after the last
        pool.submit(int).result()
        os.kill(process.pid, signal.SIGSTOP)
    else:  # in the middle of a clip
        pool.submit(_wait_stopped)
    assert wait_for(lambda: process_state(process.pid) == "T")
    assert _seconds_to_stop(pool, 60, [], finished=finished) < 30
    assert process.exitcode == exitcode  # not -SIGKILL, the kill after the grace


# A signal that lands while a weakref callback runs (importlib's module-lock callback, during any
# import) raises there, where Python prints "Exception ignored" and drops the exception; the
# handler is called from such a callback here, as the interpreter would call it.
LOST = textwrap.dedent("""
    import signal, sys, time, weakref
    from roneld_eval import signals

    class Thing:
        pass

    number = signal.Signals[sys.argv[1]]
    try:
        with signals.terminate_as_interrupt():
            thing = Thing()
            ref = weakref.ref(thing, lambda ref: signal.getsignal(number)(number, None))
            del thing
            deadline = time.monotonic() + 10
            while time.monotonic() < deadline:
                pass
            print("carried on")
    except KeyboardInterrupt as error:
        print("stopped by", type(error).__name__)
""")


@pytest.mark.parametrize("name, raised", [("SIGTERM", "Terminated"), ("SIGHUP", "Terminated"),
                                          ("SIGINT", "KeyboardInterrupt")])
def test_a_signal_raised_where_python_drops_it_still_stops_the_run(name, raised):
    done = subprocess.run([sys.executable, "-c", LOST, name], capture_output=True, text=True, timeout=60)
    assert done.stdout.strip() == f"stopped by {raised}", (done.stdout, done.stderr)
    assert "Exception ignored" not in done.stderr



UNREAD_CALL = """
import multiprocessing, sys, time
from roneld_eval import workers

if __name__ == "__main__":
    calls = multiprocessing.get_context("fork").Queue()
    calls.put(b"x" * (4 << 20))  # far beyond a pipe's 64 KB, and no worker left to read it
    time.sleep(0.5)
    if sys.argv[1] == "drained":
        workers._drain_calls(calls)
    print("exiting", flush=True)
"""


@pytest.mark.skipif(sys.platform != "linux", reason="forks on Linux only")
@pytest.mark.parametrize("how", ["drained", "left"])
def test_a_call_larger_than_a_pipe_left_unread_by_ended_workers_does_not_hold_the_exit(tmp_path, how):
    # `score apollo3d` hands its workers chunks of parsed frames; ended by SIGTERM, its call queue's
    # feeder thread stayed blocked writing one to workers that were gone, and the interpreter's
    # exit waited for it for good. stop_pool drains what is left (_drain_calls); the other case
    # shows the hang it prevents.
    script = tmp_path / "unread_call.py"
    script.write_text(UNREAD_CALL)
    command = [sys.executable, str(script), how]
    if how == "left":
        with pytest.raises(subprocess.TimeoutExpired):
            subprocess.run(command, capture_output=True, timeout=5, cwd=Path(__file__).parent.parent)
        return
    start = time.monotonic()
    done = subprocess.run(command, capture_output=True, text=True, timeout=60, cwd=Path(__file__).parent.parent)
    assert done.returncode == 0 and done.stdout == "exiting\n", done.stderr
    assert time.monotonic() - start < 10 and done.stderr == ""
