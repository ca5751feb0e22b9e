"""A configuration value checked against its field: its type (from the field's annotation) and
its documented range, each problem one ConfigError naming the setting."""

from __future__ import annotations

import math
import numbers
import os
from dataclasses import dataclass
from typing import Any

from .errors import ConfigError


@dataclass(frozen=True)
class Range:
    """The documented range of a numeric setting: low and high, each included unless open."""

    low: float | None = None
    high: float | None = None
    low_open: bool = False
    high_open: bool = False

    def __contains__(self, value) -> bool:
        if self.low is not None and (value <= self.low if self.low_open else value < self.low):
            return False
        if self.high is not None and (value >= self.high if self.high_open else value > self.high):
            return False
        return True

    def __str__(self) -> str:
        if self.high is None:
            return f"{'>' if self.low_open else '>='} {self.low:g}"
        return f"in {'(' if self.low_open else '['}{self.low:g}, {self.high:g}{')' if self.high_open else ']'}"



def typed(qualified: str, annotation: str, value: Any, limits: Range | None = None) -> Any:
    """`value` as the field's type wants it (ints stay ints, numbers become floats) and within
    `limits`, or ConfigError."""
    base = annotation.split("|")[0].strip()
    if value is None:
        if "None" in annotation:
            return None
        raise ConfigError(f"{qualified} needs a value")
    convert = _CONVERTERS.get("tuple" if base.startswith("tuple") else base)
    if convert is None:  # pragma: no cover - every field type has its converter
        return value
    value = convert(qualified, value)
    if base in ("int", "float") and limits is not None and value not in limits:
        raise ConfigError(f"{qualified} must be {limits}, got {value if isinstance(value, int) else f'{value:g}'}")
    return value


def _names(qualified: str, value: Any) -> tuple[str, ...]:
    if isinstance(value, str):
        value = [part.strip() for part in value.split(",") if part.strip()]
    if not isinstance(value, (list, tuple)) or not all(isinstance(item, str) for item in value):
        raise ConfigError(f"{qualified} must be a list of names or a comma-separated string, got {value!r}")
    return tuple(checked_text(qualified, item) for item in value)


def _bool(qualified: str, value: Any) -> bool:
    if not isinstance(value, bool):
        raise ConfigError(f"{qualified} must be true or false, got {value!r}")
    return value


def _int(qualified: str, value: Any) -> int:
    if isinstance(value, bool) or not isinstance(value, numbers.Integral):
        raise ConfigError(f"{qualified} must be an integer, got {shown(value)}")
    return int(value)


def _float(qualified: str, value: Any) -> float:
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        raise ConfigError(f"{qualified} must be a number, got {shown(value)}")
    value = float(value)
    if not math.isfinite(value):
        raise ConfigError(f"{qualified} must be a finite number, got {value}")
    return value


def _str(qualified: str, value: Any) -> str:
    if isinstance(value, os.PathLike):
        value = os.fspath(value)
    if not isinstance(value, str):
        hint = f' (write it in quotes: "{value}")' if isinstance(value, (int, float)) else ""
        raise ConfigError(f"{qualified} must be a string, got {shown(value)}{hint}")
    return checked_text(qualified, value)


# A field's type (its annotation's first member) -> what turns a given value into it.
_CONVERTERS = {"tuple": _names, "bool": _bool, "int": _int, "float": _float, "str": _str}


def shown(value: Any) -> str:
    return f"the text {value!r}" if isinstance(value, str) else repr(value)


def checked_text(qualified: str, text: str) -> str:
    """Text config.toml can hold and a path can carry: valid Unicode, no NUL character."""
    try:
        text.encode("utf-8")
    except UnicodeEncodeError:
        raise ConfigError(
            f"{qualified} is not valid Unicode text (a name that is not UTF-8: {text!a}); "
            "rename it, or run under a UTF-8 locale such as LC_ALL=C.UTF-8"
        ) from None
    if "\0" in text:
        raise ConfigError(f"{qualified} holds a NUL character: {text!a}")
    return text
