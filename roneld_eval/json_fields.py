"""Plain JSON values the tool writes and reads back (the resume cache's records): numbers
that may be infinite, and field checks that raise TypeError/ValueError on anything else,
because a file read back is untrusted input; and JSON text as every reader parses it (`loads`)."""

from __future__ import annotations

import json
import math
from typing import Any


class RepeatedKey(ValueError):
    """A JSON object naming a key twice. JSON leaves it undefined which one counts: Python's json
    keeps the last, cJSON (under OpenLane's C++ evaluator) the first, so the same file would be
    scored two ways; every reader refuses it instead."""

    def __init__(self, key: str):
        super().__init__(f"key {key!r} appears twice in one object (JSON readers differ on which one "
                         "counts): give it once")


def _unique_keys(pairs: list[tuple[str, Any]]) -> dict[str, Any]:
    value = dict(pairs)
    if len(value) < len(pairs):
        seen: set[str] = set()
        for key, _ in pairs:
            if key in seen:
                raise RepeatedKey(key)
            seen.add(key)
    return value


def loads(text: str | bytes) -> Any:
    """json.loads, refusing an object that names a key twice (RepeatedKey, a ValueError): the one
    parser of every JSON file the tool reads (labels, predictions, sizes, a run's files read back)."""
    return json.loads(text, object_pairs_hook=_unique_keys)


def shown(value: Any, most: int = 40) -> str:
    """A value read from a file as an error message quotes it: repr, cut short (a 400-digit
    integer or a long string would make the one line of the error unreadable)."""
    text = repr(value)
    return text if len(text) <= most else f"{text[:most - 3]}..."


def is_finite_number(value: Any) -> bool:
    """A JSON number that is a finite float: not a bool, not inf or NaN, not an integer beyond a
    float's range (JSON allows 400 digits, where float() raises OverflowError)."""
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        return False
    try:
        return math.isfinite(value)
    except OverflowError:
        return False


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
