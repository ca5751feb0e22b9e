"""`--executor dask`: a command's shards run on a dask.distributed cluster (a LocalCluster here, or
one given by --scheduler) and merge into the files the command writes in one process."""

from __future__ import annotations

import contextlib
import socket
import subprocess
import sys
import threading
import time

import pytest
from click.testing import CliRunner

from roneld_eval.cli import main

distributed = pytest.importorskip("distributed")  # the [cluster] extra, which the test command installs


def _invoke(*args):
    return CliRunner().invoke(main, [str(a) for a in args])


def _same_files(whole, other, skip=()) -> list[str]:
    names = sorted(p.name for p in whole.iterdir() if not p.name.startswith(".") and p.is_file())
    assert sorted(p.name for p in other.iterdir() if not p.name.startswith(".") and p.is_file()) == names
    for name in names:
        if name not in skip:
            assert (other / name).read_bytes() == (whole / name).read_bytes(), name
    return names


def _score(culane_set, out, *extra):
    return _invoke("score", "culane", "--data-root", culane_set / "data", "--pred-root", f"a={culane_set / 'maps'}",
                   "--pred-root", f"b={culane_set / 'maps'}", "--iou", "0.3:0.7:0.1", "--out", out, *extra)


def test_score_on_a_local_dask_cluster_writes_the_files_of_one_process(culane_set, tmp_path):
    assert _score(culane_set, tmp_path / "here", "--workers", "1", "--quiet").exit_code == 0
    # two worker processes, each told --workers 2: a Dask worker is daemonic and scores in itself
    result = _score(culane_set, tmp_path / "dask", "--executor", "dask", "--workers", "2")
    assert result.exit_code == 0, result.output
    assert "dask: 2 shards on tcp://" in result.output and "(2 workers, 2 threads)" in result.output
    assert "official.csv" in _same_files(tmp_path / "here", tmp_path / "dask")


def test_a_run_on_a_given_scheduler_is_the_run_here_but_for_its_clock(tmp_path):
    here = _invoke("run", "--workers", "1", "--quiet", "--out", tmp_path / "here")
    assert here.exit_code == 0, here.output
    with distributed.LocalCluster(n_workers=1, threads_per_worker=2, processes=True, dashboard_address=None) as cluster:
        result = _invoke("run", "--workers", "1", "--quiet", "--out", tmp_path / "dask", "--executor", "dask",
                         "--scheduler", cluster.scheduler_address)
    assert result.exit_code == 0, result.output
    # one worker of two threads: two shards, run one after the other in that worker
    names = _same_files(tmp_path / "here", tmp_path / "dask",
                        skip={"runtime.csv", "runtime.md", "runtime.tex", "report.html", "summary.json"})
    assert {"accuracy.csv", "per_frame.csv", "official.csv", "config.toml"} <= set(names)


@pytest.mark.long
def test_vil100_on_dask_merges_its_sequences_as_one_process_scores_them(tmp_path):
    from test_shards import _vil100_set

    args = _vil100_set(tmp_path, "png")
    assert _invoke(*args, "--quiet", "--out", tmp_path / "here").exit_code == 0
    result = _invoke(*args, "--quiet", "--out", tmp_path / "dask", "--executor", "dask")
    assert result.exit_code == 0, result.output
    assert "temporal.csv" in _same_files(tmp_path / "here", tmp_path / "dask")


@pytest.mark.parametrize("extra, said", [
    (["--scheduler", "tcp://127.0.0.1:8786"], "--scheduler is the address of a Dask scheduler: give it with "
                                              "--executor dask"),
    (["--executor", "dask", "--shard", "1/2"], "cuts the command into shards itself"),
])
def test_executor_options_that_do_not_go_together_are_one_line(culane_set, tmp_path, extra, said):
    result = _score(culane_set, tmp_path / "o", *extra)
    assert result.exit_code == 2 and said in result.output and len(result.output.strip().splitlines()) == 1
    assert not (tmp_path / "o").exists()


def test_a_run_on_dask_refuses_what_a_merge_cannot_give(tmp_path):
    for extra, said in ((["--overlays", "2"], "without --resume, --overlays"),
                        (["--no-timings"], "or --no-timings"),
                        (["--method", "mine=plugin_extractors:shifted"], "a merge imports no code a part names")):
        result = _invoke("run", "--executor", "dask", "--out", tmp_path / "o", *extra)
        assert result.exit_code == 2 and said in result.output, result.output
    result = _invoke("score", "tusimple", "--labels", tmp_path / "l.json", "--pred", tmp_path / "p.json",
                     "--executor", "dask")
    assert result.exit_code == 2 and "give --out" in result.output


def test_a_scheduler_that_does_not_answer_is_one_line(culane_set, tmp_path, monkeypatch):
    import roneld_eval.cluster as cluster

    monkeypatch.setattr(cluster, "CONNECT_TIMEOUT_S", 1)
    result = _score(culane_set, tmp_path / "o", "--executor", "dask", "--scheduler", "tcp://127.0.0.1:9")
    assert result.exit_code == 2, result.output
    assert result.output.startswith("error: --scheduler tcp://127.0.0.1:9: no Dask scheduler answers there")
    assert not (tmp_path / "o" / "official.csv").exists()


def test_a_foreign_out_is_refused_before_a_cluster_starts(culane_set, tmp_path, monkeypatch):
    import roneld_eval.cluster as cluster

    def no_cluster(*args, **kwargs):
        raise AssertionError("a cluster was started before --out was checked")

    monkeypatch.setattr(cluster, "_client", no_cluster)
    (tmp_path / "thesis").mkdir()
    (tmp_path / "thesis" / "thesis.tex").write_text("mine")
    result = _score(culane_set, tmp_path / "thesis", "--executor", "dask")
    assert result.exit_code == 2 and "holds files roneld-eval did not write" in result.output, result.output


def test_without_dask_the_extra_to_install_is_named(culane_set, tmp_path, monkeypatch):
    monkeypatch.setitem(sys.modules, "distributed", None)  # import distributed fails
    result = _score(culane_set, tmp_path / "o", "--executor", "dask")
    assert result.exit_code == 2 and "pip install 'roneld-eval[cluster]'" in result.output


def test_a_shards_input_error_is_one_line_and_leaves_no_folder(culane_set, tmp_path):
    # The workers' log printed each failed task's traceback (four blocks for one bad --pred-root
    # pattern), and the folder created to check --out before the cluster started stayed behind.
    out = tmp_path / "sweep" / "deeper"
    done = subprocess.run([sys.executable, "-m", "roneld_eval", "score", "culane", "--data-root",
                           str(culane_set / "data"), "--pred-root", str(tmp_path / "work_dirs" / "epoch_*" / "lines"),
                           "--executor", "dask", "--workers", "2", "--quiet", "--out", str(out)],
                          capture_output=True, text=True, timeout=300)
    assert done.returncode == 2, done.stderr
    said = done.stdout + done.stderr
    assert "Traceback" not in said and "distributed.worker" not in said, said
    assert said.strip().splitlines()[-1].endswith("epoch_*/lines: no folder matches this pattern"), said
    assert not (tmp_path / "sweep").exists()


@pytest.fixture
def silent_scheduler():
    """tcp://127.0.0.1:PORT: accepts every connection and never says a word."""
    listener = socket.socket()
    listener.bind(("127.0.0.1", 0))
    listener.listen(16)
    held = []

    def accept():
        while True:
            try:
                held.append(listener.accept()[0])
            except OSError:  # closed
                return

    threading.Thread(target=accept, daemon=True).start()
    yield f"tcp://127.0.0.1:{listener.getsockname()[1]}"
    listener.close()
    for connection in held:
        connection.close()


# The command line with a short wait for a scheduler's answer, in a process a hang cannot take along.
SHORT_CONNECT = r"""
import sys
import roneld_eval.cluster
roneld_eval.cluster.CONNECT_TIMEOUT_S = 1
from roneld_eval.cli import main
main(sys.argv[1:], prog_name="roneld-eval")
"""


def test_a_scheduler_that_accepts_and_never_answers_is_one_line(culane_set, tmp_path, silent_scheduler):
    # Client(timeout=20) bounds the TCP connection only: the command waited forever for a handshake.
    out = tmp_path / "o"
    done = subprocess.run([sys.executable, "-c", SHORT_CONNECT, "score", "culane", "--data-root",
                           str(culane_set / "data"), "--pred-root", str(culane_set / "maps"), "--out", str(out),
                           "--executor", "dask", "--scheduler", silent_scheduler], capture_output=True, text=True,
                          timeout=60)
    assert done.returncode == 2, done.stderr
    assert done.stderr == f"error: --scheduler {silent_scheduler}: no Dask scheduler answers there (no answer " \
                          "within 1 s)\n"
    assert not out.exists()


STARTED, RELEASE = threading.Event(), threading.Event()


def _held_shard(function, arguments, shard):
    """A shard that waits, its worker killed meanwhile (a module's function: pickled by name, so the
    in-process worker runs this one, with these events)."""
    STARTED.set()
    RELEASE.wait(120)
    return {}


def test_a_run_whose_only_worker_dies_is_one_line(tmp_path, monkeypatch):
    # The shards' tasks waited for a worker forever.
    import _thread

    import roneld_eval.cluster as cluster

    monkeypatch.setattr(cluster, "WORKER_WAIT_S", 2)
    monkeypatch.setattr(cluster, "shard_task", _held_shard)
    STARTED.clear()
    RELEASE.clear()
    with distributed.LocalCluster(n_workers=1, threads_per_worker=1, processes=False,
                                  dashboard_address=None) as local:
        worker = next(iter(local.workers.values()))

        def kill() -> None:
            if STARTED.wait(60):
                local.sync(worker.close, executor_wait=False)

        threading.Thread(target=kill, daemon=True).start()
        hung = threading.Timer(60, _thread.interrupt_main)  # what was a hang fails the test instead
        hung.start()
        try:
            result = _invoke("run", "--workers", "1", "--quiet", "--out", tmp_path / "o", "--executor", "dask",
                             "--scheduler", local.scheduler_address)
        finally:
            hung.cancel()
            RELEASE.set()
        assert STARTED.is_set() and worker.status.name == "closed"
        assert result.exit_code == 1, result.output
        assert result.output == (f"error: the Dask cluster at {local.scheduler_address} has had no worker for 2 s "
                                 "(its workers died or left, or its scheduler does not answer): no result was "
                                 "written\n")
        # Nothing left running: its task released, its client gone.
        deadline = time.monotonic() + 10
        while (local.scheduler.tasks or set(local.scheduler.clients) - {"fire-and-forget"}) \
                and time.monotonic() < deadline:
            time.sleep(0.05)
        assert not local.scheduler.tasks and set(local.scheduler.clients) == {"fire-and-forget"}
    assert not (tmp_path / "o").exists() or not [p.name for p in (tmp_path / "o").iterdir()]


def test_a_run_whose_scheduler_is_killed_is_one_line(tmp_path, monkeypatch):
    # The client cancelled every task on losing its scheduler, and FuturesCancelledError came out as
    # a traceback (found by an independent check, scheduler killed with SIGKILL mid-run).
    import _thread

    import roneld_eval.cluster as cluster

    monkeypatch.setattr(cluster, "WORKER_WAIT_S", 30)
    monkeypatch.setattr(cluster, "shard_task", _held_shard)
    STARTED.clear()
    RELEASE.clear()
    local = distributed.LocalCluster(n_workers=1, threads_per_worker=1, processes=False, dashboard_address=None)
    try:
        address = local.scheduler_address

        def kill() -> None:
            if STARTED.wait(60):
                local.sync(local.scheduler.close)

        threading.Thread(target=kill, daemon=True).start()
        hung = threading.Timer(60, _thread.interrupt_main)  # what was a hang fails the test instead
        hung.start()
        try:
            result = _invoke("run", "--workers", "1", "--quiet", "--out", tmp_path / "o", "--executor", "dask",
                             "--scheduler", address)
        finally:
            hung.cancel()
            RELEASE.set()
    finally:
        with contextlib.suppress(Exception):  # its scheduler is gone: closing waits 30 s for it otherwise
            local.close(timeout=1)
    assert STARTED.is_set()
    assert "Traceback" not in result.output
    assert result.exit_code == 1, result.output
    assert result.output.endswith("no result was written\n") and result.output.count("\n") == 1, result.output
    assert "Dask" in result.output and address in result.output
    assert not (tmp_path / "o").exists() or not [p.name for p in (tmp_path / "o").iterdir()]
