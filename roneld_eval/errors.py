"""Errors the tool raises for bad input and bad configuration.

Every problem a user can fix is an `InputError` or a `ConfigError`, raised where the problem
is found and carrying the file (and line) it is about. The CLI prints them as one line and
exits with status 2; nothing here knows about the CLI.
"""

from __future__ import annotations

from pathlib import Path


class RoneldEvalError(Exception):
    """Base class of the errors a user can act on."""


class InputError(RoneldEvalError):
    """A file or folder the user gave us is missing or malformed."""

    def __init__(self, path: str | Path | None, problem: str, line: int | None = None):
        self.path = None if path is None else str(path)
        self.problem = problem
        self.line = line
        super().__init__(self.__str__())

    def __str__(self) -> str:
        where = self.path or ""
        if self.line is not None:
            where = f"{where}:{self.line}"
        return f"{where}: {self.problem}" if where else self.problem

    @classmethod
    def unwritable(cls, path: str | Path, error: OSError) -> "InputError":
        """'PATH: cannot write: <why>' for a write that failed (a full disk names no file itself)."""
        return cls(path, f"cannot write: {error.strerror or error}")

    def __reduce__(self):
        # Worker processes send errors back by pickling; keep the three fields.
        return (type(self), (self.path, self.problem, self.line))


class ConfigError(RoneldEvalError):
    """A configuration value is invalid or inconsistent."""


class ExtractorError(RoneldEvalError):
    """A plug-in extractor failed on a frame (raised, was too slow, or returned bad lanes)."""

    def __init__(self, method: str, frame: str, problem: str):
        self.method, self.frame, self.problem = method, frame, problem
        super().__init__(f"method {method!r}, frame {frame}: {problem}")

    def __reduce__(self):
        return (type(self), (self.method, self.frame, self.problem))


class PluginError(RoneldEvalError):
    """A benchmark of another package failed in a call: it raised or exited, ended its process,
    took longer than its time limit, or returned something malformed."""


class RunInterrupted(RoneldEvalError):
    """A run stopped before its end (Ctrl-C, a worker killed); finished clips may be cached."""

    def __init__(self, message: str, exit_code: int = 1):
        super().__init__(message)
        self.exit_code = exit_code

    def __reduce__(self):
        return (type(self), (str(self), self.exit_code))
