"""The largest file of each kind the tool reads, checked on its size before it is read.

Every input is untrusted: a 10 GB sparse label file, or a cache entry of 1.5 GB, must be one
clear line, not a process that reads until the machine runs out of memory. Each bound is some
100 times what the benchmarks' real files hold, and keeps the memory one such file can take
under about 2 GB (JSON lines take some 8 bytes of Python objects per byte). Each can be raised
through its environment variable, in MiB (README, "Bad input").
"""

from __future__ import annotations

import os
import re
from dataclasses import dataclass

from .errors import ConfigError

_DECIMAL = re.compile(r"[0-9]+(\.[0-9]*)?|\.[0-9]+", re.ASCII)


@dataclass(frozen=True)
class SizeLimit:
    """The bound on one kind of input file."""

    what: str  # "a label, lane or list file"
    variable: str  # the environment variable that raises it, in MiB
    default_mib: int

    @property
    def bytes(self) -> int:
        raw = os.environ.get(self.variable, "").strip()
        if not raw:
            return self.default_mib << 20
        mib = float(raw) if _DECIMAL.fullmatch(raw) else -1.0
        if not 1 / 1024 <= mib < 1 << 30:
            raise ConfigError(f"{self.variable}={raw!r}: give the largest size in MiB, a number from 0.001 "
                              "(1 KiB) up")
        return int(mib * (1 << 20))

    def rule(self) -> str:
        return f"{self.what} may have at most {self.bytes:,} bytes (raise it with {self.variable}=MiB)"

    def problem(self, size: int) -> str:
        """Why a file of `size` bytes is refused."""
        return f"too large ({size:,} bytes): {self.rule()}"


TEXT = SizeLimit("a label, lane, existence or list file", "RONELD_EVAL_MAX_TEXT_MIB", 16)
CONFIG = SizeLimit("a configuration file", "RONELD_EVAL_MAX_TEXT_MIB", 16)
JSON_LINES = SizeLimit("a JSON-lines label or prediction file", "RONELD_EVAL_MAX_JSON_MIB", 256)
MAP = SizeLimit("a map file (.npy, .npz or one of its members, .png)", "RONELD_EVAL_MAX_MAP_MIB", 256)
RUN_TABLE = SizeLimit("a run's table (per_frame.csv, accuracy.csv, ...)", "RONELD_EVAL_MAX_TABLE_MIB", 256)
CACHE_ENTRY = SizeLimit("a resume cache entry", "RONELD_EVAL_MAX_CACHE_ENTRY_MIB", 64)

ALL = (TEXT, CONFIG, JSON_LINES, MAP, RUN_TABLE, CACHE_ENTRY)


@dataclass(frozen=True)
class CountLimit:
    """The bound on how many lanes one frame's labels or predictions may hold: each is drawn and
    kept as a mask, so a 2 MB lane file of 90,000 short lanes took 1.1 GB and 4 s for one frame
    (a 16 MiB one, eight times that); the benchmarks' frames hold at most some 20."""

    what: str  # "one frame's labels or predictions"
    variable: str  # the environment variable that raises it
    default: int

    @property
    def count(self) -> int:
        raw = os.environ.get(self.variable, "").strip()
        if not raw:
            return self.default
        if not re.fullmatch(r"[0-9]{1,9}", raw, re.ASCII) or int(raw) < 1:
            raise ConfigError(f"{self.variable}={raw!r}: give the most lanes one frame may hold, a whole number "
                              "from 1 to 999,999,999")
        return int(raw)

    def problem(self, count: int, counted: str = "") -> str:
        """Why a file of `count` lanes is refused; `counted` says what was counted where lanes are
        not written out as such ("grey values" of an instance mask)."""
        most = self.count
        what = f"{count:,} {counted}" if counted else f"{count:,}"
        return (f"too many lanes ({what}): {self.what} may hold at most {most:,} lane{'' if most == 1 else 's'} "
                f"(raise it with {self.variable}=N)")


LANES = CountLimit("one frame's labels or predictions", "RONELD_EVAL_MAX_LANES", 1000)


def check_environment() -> None:
    """Raise ConfigError for a bound set to something that is not one (RONELD_EVAL_MAX_LANES=0),
    before a command does any work: otherwise it would be said only where the first file of that
    kind is read, for `score` inside the scoring, after its progress bar."""
    for limit in ALL:
        _ = limit.bytes  # reading a bound raises for a bad value
    _ = LANES.count
