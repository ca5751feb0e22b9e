"""`--executor dask`: a command's shards run as tasks on a dask.distributed cluster and are merged
here into the files one unsharded command writes (shards.merge), byte for byte.

Each task calls the command's own library function with `shard="k/N"` into a scratch folder on
its worker and sends the part's files back: the workers must see the inputs at the same paths
(a shared file system), and nothing they write reaches the results but through the merge, which
checks every part as untrusted input. Without a scheduler's address a local cluster of worker
processes is started for the command and closed after it. Dask is an optional extra
(`pip install 'roneld-eval[cluster]'`): nothing else imports this module.
"""

from __future__ import annotations

import concurrent.futures
import contextlib
import inspect
import tempfile
import threading
import time
from pathlib import Path
from typing import Any, Callable

from .errors import ConfigError, InputError, RunInterrupted

EXECUTORS = ("local", "dask")
# How long a cluster may be without a worker (its scheduler's first one, or after the last one
# died or left) before the command gives it up: tasks would wait for one forever.
WORKER_WAIT_S = 60.0
# How long a scheduler may take to answer: distributed's Client bounds the TCP connection only, and
# waits forever on an address that accepts it and never answers.
CONNECT_TIMEOUT_S = 20.0

# A worker with several threads runs its shards one after another: compiled kernels and the
# plug-in slot are process-wide.
_ONE_AT_A_TIME = threading.Lock()


def executed(executor: str, scheduler: str | None, command: str, function: Callable, *args, **kwargs):
    """`function(*args, **kwargs)` here (executor "local"), or its shards on a Dask cluster
    ("dask": the one at `scheduler`, or a local one) merged into its `out`. `function` is the
    library function of `command`, taking `shard` and `out` (and returning None for a shard)."""
    if executor not in EXECUTORS:
        raise ConfigError(f"--executor must be one of {', '.join(EXECUTORS)}, got {executor!r}")
    if executor == "local":
        if scheduler is not None:
            raise ConfigError("--scheduler is the address of a Dask scheduler: give it with --executor dask")
        return function(*args, **kwargs)
    arguments = inspect.signature(function).bind(*args, **kwargs).arguments
    if arguments.get("shard") is not None:
        raise ConfigError("--executor dask cuts the command into shards itself: give it without --shard")
    if arguments.get("out") is None:
        raise ConfigError("--executor dask merges the shards' parts into --out: give --out")
    if arguments.get("resume") or arguments.get("overlays") or arguments.get("timings") is False:
        raise ConfigError("--executor dask merges shards, which keep no report to resume or draw in: without --resume, "
                          "--overlays (draw pictures of the merged run with `roneld-eval show`) or --no-timings")
    if getattr(arguments.get("config"), "plugins", None):
        raise ConfigError("--executor dask merges the shards' parts, and a merge imports no code a part names: run "
                          "plug-in methods without it")
    return on_dask(function, arguments, command, scheduler, _workers(arguments),
                   arguments.get("announce") or (lambda message: None), bool(arguments.get("progress")))


def _workers(arguments: dict) -> int | None:
    config = arguments.get("config")
    return getattr(config, "workers", None) if config is not None else arguments.get("workers")


def shard_task(function: Callable, arguments: dict, shard: str) -> dict[str, bytes]:
    """On a worker: one shard of the command into a scratch folder, its part's files back."""
    with _ONE_AT_A_TIME, tempfile.TemporaryDirectory(prefix="roneld-eval-shard-") as scratch:
        folder = Path(scratch) / "part"
        function(**{**arguments, "out": folder, "shard": shard, **_quiet(function)})
        return {path.relative_to(folder).as_posix(): path.read_bytes() for path in sorted(folder.rglob("*"))
                if path.is_file() and not path.relative_to(folder).parts[0].startswith(".")}  # not the folder's marker


def _quiet(function: Callable) -> dict[str, Any]:
    """No progress bar or notes in a worker (its output is the worker's log)."""
    names = inspect.signature(function).parameters
    return {name: value for name, value in (("progress", False), ("announce", None)) if name in names}


def on_dask(function: Callable, arguments: dict, command: str, scheduler: str | None, workers: int | None,
            announce: Callable[[str], None], progress: bool):
    """Every shard of the command as a task, then their parts merged into `arguments["out"]`."""
    try:
        import distributed
    except ImportError:
        raise ConfigError("--executor dask needs Dask: pip install 'roneld-eval[cluster]'") from None
    from .output import OutputFolder, write_file
    from .shards import merge

    out = Path(arguments["out"])
    OutputFolder.check(out, command, nested={"show": "show"})  # refused now, not after the work
    arguments = {name: value for name, value in arguments.items() if name not in ("out", "shard")}
    with _client(distributed, scheduler, workers) as client:
        threads = sum(client.nthreads().values())
        count = max(1, threads)
        announce(f"dask: {count} shard{'s' if count > 1 else ''} on {client.scheduler.address} "
                 f"({len(client.nthreads())} worker{'s' if len(client.nthreads()) > 1 else ''}, {threads} threads)")
        futures = {client.submit(shard_task, function, arguments, f"{k}/{count}", pure=False): k
                   for k in range(1, count + 1)}
        try:
            from .progress import progress_bar

            with progress_bar(count, "shard", "shards", wanted=progress) as bar:
                parts = _gathered(distributed, client, futures, count, bar.update)
        finally:
            for future in futures:
                future.cancel()
    with tempfile.TemporaryDirectory(prefix="roneld-eval-parts-") as scratch:
        folders = []
        for k in sorted(parts):
            folder = Path(scratch) / f"{k}"
            for name, data in parts[k].items():
                target = folder / name
                if not target.resolve().is_relative_to(folder.resolve()):
                    raise InputError(folder, f"a worker sent a file outside its part ({name[:80]!r})")
                target.parent.mkdir(parents=True, exist_ok=True)
                write_file(target, data)  # a full scratch disk names the file
            folders.append(folder)
        return merge(folders, out)[1]


def _gathered(distributed, client, futures: dict, count: int, advance: Callable[[int], object]
              ) -> dict[int, dict[str, bytes]]:
    """Each shard's part (by its number) as its task finishes; RunInterrupted once the cluster has
    had no worker, or its scheduler has not answered, for WORKER_WAIT_S (said within it)."""
    parts: dict[int, dict[str, bytes]] = {}
    pending = set(futures)
    poll = min(1.0, WORKER_WAIT_S / 20)
    alive = time.monotonic()  # when the cluster last had a worker
    while pending:
        try:
            done, pending = distributed.wait(pending, timeout=poll, return_when="FIRST_COMPLETED")
            for future in done:
                parts[futures[future]] = _result(distributed, future, futures[future], count)
                advance(1)
        except TimeoutError:  # none finished meanwhile
            done = set()
        except (concurrent.futures.CancelledError, distributed.comm.core.CommClosedError):
            # The client cancels every task when it loses its scheduler (a scheduler killed or
            # gone): the cluster is lost, not a shard.
            raise RunInterrupted(f"the Dask scheduler at {client.scheduler.address} stopped answering (the "
                                 "connection to it was lost): no result was written") from None
        if done or _has_workers(client, poll):
            alive = time.monotonic()
        elif time.monotonic() - alive > WORKER_WAIT_S - 2 * poll:  # a poll and an answer late at most
            raise RunInterrupted(f"the Dask cluster at {client.scheduler.address} has had no worker for "
                                 f"{WORKER_WAIT_S:g} s (its workers died or left, or its scheduler does not "
                                 "answer): no result was written")
    return parts


def _has_workers(client, timeout_s: float) -> bool:
    """Whether the scheduler answers within `timeout_s` and has a worker."""
    try:
        return bool(client.nthreads(callback_timeout=timeout_s))
    except (OSError, TimeoutError):  # a dead or silent scheduler
        return False


def _result(distributed, future, k: int, count: int) -> dict[str, bytes]:
    try:
        return future.result()
    except distributed.KilledWorker:
        raise RunInterrupted(f"shard {k}/{count}: its Dask workers died (killed, or out of memory) while "
                             "running it: no result was written") from None


@contextlib.contextmanager
def _client(distributed, address: str | None, workers: int | None):
    """A Client of the scheduler at `address`, or of a local cluster started (and closed) here."""
    if address is None:
        import logging

        from .workers import default_workers

        with distributed.LocalCluster(n_workers=workers or default_workers(), threads_per_worker=1, processes=True,
                                      # A task's error reaches the client, which says it in one line;
                                      # the workers' log printed it again, traceback and all.
                                      dashboard_address=None, silence_logs=logging.CRITICAL) as cluster:
            with distributed.Client(cluster) as client:
                yield client
        return
    try:
        _answers(distributed, address)
        client = distributed.Client(address, timeout=CONNECT_TIMEOUT_S)
    except (OSError, TimeoutError, ValueError) as error:
        raise ConfigError(f"--scheduler {address}: no Dask scheduler answers there ({error})") from None
    with client:
        try:
            client.wait_for_workers(1, timeout=WORKER_WAIT_S)
        except TimeoutError:
            raise ConfigError(f"--scheduler {address}: no worker joined it within {WORKER_WAIT_S:g} s") from None
        yield client


def _answers(distributed, address: str) -> None:
    """Connect to `address` as a Client does, handshake included, within CONNECT_TIMEOUT_S, or
    raise TimeoutError (OSError, ValueError: nothing there, not an address); nothing is left open.
    The Client's own timeout bounds the TCP connection only, and then waits forever for the
    handshake of an address that accepts it and never answers."""
    import asyncio

    async def handshake() -> None:
        comm = await asyncio.wait_for(distributed.comm.connect(address, timeout=CONNECT_TIMEOUT_S),
                                      CONNECT_TIMEOUT_S)
        await comm.close()

    try:
        asyncio.run(handshake())
    except asyncio.TimeoutError:
        raise TimeoutError(f"no answer within {CONNECT_TIMEOUT_S:g} s") from None
