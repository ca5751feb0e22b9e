"""Which plug-in call each worker process is in, in memory shared with the main process.

A plug-in may end its process (os._exit, a signal it sends itself, a crash in a C extension):
nothing in that process can report it. So each worker writes "pid, method, frame" into its own
slot before calling a plug-in and clears it after; when a worker dies, the main process reads
the slots and names the method and frame the worker died in.
"""

from __future__ import annotations

import ctypes
import os
import signal
import time
from typing import Any, Mapping

SLOT_BYTES = 1024


class PluginCalls:
    """Made in the main process before the workers fork; `claim` once in each worker."""

    def __init__(self, workers: int, context: Any):
        self._slots = context.RawArray(ctypes.c_char, workers * SLOT_BYTES)
        self._claimed = context.Value(ctypes.c_int, 0)
        self._workers = workers
        self._mine: int | None = None

    def claim(self) -> None:
        """Take this worker's slot."""
        with self._claimed.get_lock():
            number = self._claimed.value
            self._claimed.value = number + 1
        self._mine = number if number < self._workers else None

    def enter(self, method: str, frame: str) -> None:
        # CLOCK_MONOTONIC is one clock for every process of the machine.
        self._write(f"{os.getpid()}\t{time.monotonic():.3f}\t{method}\t{frame}".encode("utf-8", "surrogateescape"))

    def leave(self) -> None:
        self._write(b"")

    def _write(self, text: bytes) -> None:
        if self._mine is None:
            return
        text = text[:SLOT_BYTES - 1] + b"\0"
        start = self._mine * SLOT_BYTES
        self._slots[start:start + len(text)] = text

    def open_calls(self) -> dict[int, tuple[str, str, float]]:
        """pid -> (method, frame, monotonic time it started) of every worker in a plug-in call now."""
        calls = {}
        raw = bytes(self._slots.raw)
        for number in range(self._workers):
            text = raw[number * SLOT_BYTES:(number + 1) * SLOT_BYTES].split(b"\0", 1)[0]
            parts = text.decode("utf-8", "surrogateescape").split("\t", 3)
            if len(parts) == 4 and parts[0].isdigit():
                try:
                    calls[int(parts[0])] = (parts[2], parts[3], float(parts[1]))
                except ValueError:
                    continue
        return calls

    def overdue(self, limits: Mapping[str, float | None], grace_s: float) -> dict[int, tuple[str, str]]:
        """pid -> (method, frame) of the calls that have run `grace_s` past their method's limit:
        a plug-in that blocks or ignores SIGALRM is not stopped inside its worker."""
        now = time.monotonic()
        late = {}
        for pid, (method, frame, started) in self.open_calls().items():
            limit = limits.get(method)
            if limit is not None and now - started > limit + grace_s:
                late[pid] = (method, frame)
        return late

    def died_in(self, exit_codes: Mapping[int, int | None]) -> tuple[str, str, int | None] | None:
        """(method, frame, exit code or None) of a worker that ended inside a plug-in call, or None.

        `exit_codes`: pid -> exit code of the pool's workers (all ended by now; None where it
        cannot be told). The ones the pool or the run ended afterwards (SIGTERM, SIGKILL) are
        taken only when no other died inside a call.
        """
        calls = self.open_calls()
        ended = [(pid, code) for pid, code in exit_codes.items() if pid in calls]
        if not ended:
            return None
        # An unknown code (the pool's thread reaped the process first) ranks after any other; of
        # the signals the pool and the run end workers with, SIGTERM (sent first, to every worker
        # left) ranks last: a SIGKILL is a worker that ignored it past its grace, or one that a
        # plug-in killed itself, and comes first.
        rank = {None: 1, -signal.SIGKILL: 2, -signal.SIGTERM: 3}
        pid, code = sorted(ended, key=lambda item: rank.get(item[1], 0))[0]
        method, frame, _ = calls[pid]
        return method, frame, code
