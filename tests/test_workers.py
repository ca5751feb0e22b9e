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
from roneld_eval.errors import InputError, RunInterrupted

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


# ---- alongside: a task in a forked process while the caller goes on --------------------------


def _write(path, text):
    def task():
        path.write_text(f"{text} {os.getpid()}")
    return task


def test_alongside_runs_the_task_in_another_process_during_the_block(tmp_path):
    target = tmp_path / "figure"
    with workers.alongside(_write(target, "drawn")):
        here = os.getpid()
    text, pid = target.read_text().split()
    assert text == "drawn"
    assert int(pid) != here if sys.platform == "linux" else int(pid) == here


def test_a_task_that_fails_there_runs_here_so_its_error_is_raised(tmp_path):
    calls = []

    def task():
        calls.append(os.getpid())
        raise InputError(tmp_path / "figure.png", "cannot write: No space left on device")

    with pytest.raises(InputError, match="No space left"):
        with workers.alongside(task):
            pass
    assert calls == [os.getpid()]  # the child's try is not seen here; this process's is


def test_where_nothing_forks_the_task_runs_after_the_block(tmp_path, monkeypatch):
    monkeypatch.setattr(workers.sys, "platform", "darwin")
    order = []
    with workers.alongside(lambda: order.append("task")):
        order.append("block")
    assert order == ["block", "task"]


@pytest.mark.skipif(sys.platform != "linux", reason="forks on Linux only")
def test_when_the_block_fails_the_task_is_killed_before_the_error_goes_on(tmp_path):
    started, target = tmp_path / "started", tmp_path / "late"

    def slow():
        started.write_text("")
        time.sleep(5)
        target.write_text("written after the caller gave up")

    children_before = _children()
    with pytest.raises(KeyboardInterrupt):
        with workers.alongside(slow):
            deadline = time.monotonic() + 10
            while not started.exists() and time.monotonic() < deadline:
                time.sleep(0.01)
            raise KeyboardInterrupt
    assert _children() == children_before  # killed and reaped: no zombie either
    time.sleep(0.2)
    assert not target.exists()


def _children() -> set[int]:
    own = Path(f"/proc/{os.getpid()}/task")
    pids = set()
    for task in own.iterdir():
        children = task / "children"
        if children.exists():
            pids |= {int(pid) for pid in children.read_text().split()}
    return pids


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
    what, target = sys.argv[2], Path(sys.argv[3])

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

    def late():
        time.sleep(1.0)
        target.write_text("written after the caller gave up")

    with signals.terminate_as_interrupt():
        try:
            if what == "pool":
                pool = workers.process_pool(2)
                workers.stop_pool(pool, finished=True)
            else:
                with workers.alongside(late):
                    pass
        except KeyboardInterrupt as error:
            print("interrupted", type(error).__name__, flush=True)
        else:
            print("carried on", flush=True)
    time.sleep(1.5)
    print("children", len(workers.multiprocessing.active_children()), "late file", target.exists(), flush=True)
""")


@pytest.mark.skipif(sys.platform != "linux", reason="forks on Linux only")
@pytest.mark.parametrize("what", ["pool", "alongside"])
@pytest.mark.parametrize("name, raised", [("SIGTERM", "Terminated"), ("SIGINT", "KeyboardInterrupt")])
def test_a_signal_while_forking_interrupts_and_leaves_no_process(tmp_path, what, name, raised):
    done = subprocess.run([sys.executable, "-c", DURING_FORK, name, what, str(tmp_path / "late")],
                          capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr
    assert done.stdout.split("\n")[:2] == [f"interrupted {raised}", "children 0 late file False"], done.stdout
    assert "Exception ignored" not in done.stderr and "Traceback" not in done.stderr, done.stderr
    if what == "alongside":  # killed and reaped: no zombie, nothing written
        assert not (tmp_path / "late").exists()


ORPHANED = textwrap.dedent("""
    import os, signal, sys, time
    from pathlib import Path
    from roneld_eval import workers

    target = Path(sys.argv[1])

    def late():
        time.sleep(1.0)
        target.write_text("written by an orphan")

    with workers.alongside(late):
        os.kill(os.getpid(), signal.SIGKILL)
""")


@pytest.mark.skipif(sys.platform != "linux", reason="forks on Linux only")
def test_the_process_alongside_dies_with_its_parent(tmp_path):
    done = subprocess.run([sys.executable, "-c", ORPHANED, str(tmp_path / "late")], capture_output=True, timeout=60)
    assert done.returncode == -signal.SIGKILL
    time.sleep(1.5)
    assert not (tmp_path / "late").exists()


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
