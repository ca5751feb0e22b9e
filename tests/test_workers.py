"""Worker processes and signals: a signal that reaches a worker before it has its own handlers."""

from __future__ import annotations

import subprocess
import sys
import textwrap

import pytest

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
