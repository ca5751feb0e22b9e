"""Plain JSON values the tool writes and reads back (the resume cache's records): numbers
that may be infinite, and field checks that raise TypeError/ValueError on anything else,
because a file read back is untrusted input."""

from __future__ import annotations

import math
from typing import Any


def json_number(value: float) -> Any:
    """A float as JSON can hold it: non-finite values as the strings 'inf', '-inf', 'nan'."""
    value = float(value)
    return value if math.isfinite(value) else repr(value)


def read_float(value: Any) -> float:
    """The inverse of json_number."""
    if isinstance(value, bool) or not isinstance(value, (int, float, str)):
        raise TypeError(f"expected a number, got {type(value).__name__}")
    if isinstance(value, str) and value not in ("inf", "-inf", "nan"):
        raise ValueError(f"expected a number, got {value!r}")
    return float(value)


def read_count(value: Any) -> int:
    """A non-negative integer."""
    if isinstance(value, bool) or not isinstance(value, int) or value < 0:
        raise TypeError("expected a count")
    return value


def read_string(value: Any) -> str:
    if not isinstance(value, str):
        raise TypeError("expected a string")
    return value


def read_list(value: Any) -> list:
    if not isinstance(value, list):
        raise TypeError("expected a list")
    return value
