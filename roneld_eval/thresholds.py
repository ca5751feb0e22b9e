"""IoU thresholds and image rows as settings write them: exact decimals, ranges checked, one
ConfigError line for anything else."""

from __future__ import annotations

from dataclasses import dataclass
from decimal import Decimal, InvalidOperation

import math

from .errors import ConfigError

TALLEST_IMAGE = 100_000  # dataset.image_height's bound (config.RANGES): rows beyond it lie below any image

# IoU thresholds (paper.thresholds, `score --iou`): at most this many in a sweep, each with at
# most this many decimals (a sweep costs one array comparison per threshold).
MAX_THRESHOLDS = 1000
MAX_THRESHOLD_DECIMALS = 12


def parse_rows(spec: str) -> range:
    """Image rows 'start:stop:step' (Python range semantics, 0-based)."""
    try:
        start, stop, step = (int(part) for part in str(spec).split(":"))
    except ValueError:
        raise ConfigError(f"rows must look like 'start:stop:step' with integers, got {spec!r}") from None
    if step <= 0 or start < 0 or stop <= start:
        raise ConfigError(f"rows {spec!r} must have 0 <= start < stop and a positive step")
    if stop > TALLEST_IMAGE:
        raise ConfigError(f"rows {spec!r} go below any image (stop must be at most the image height)")
    return range(start, stop, step)


@dataclass(frozen=True)
class Thresholds:
    """IoU thresholds as exact decimals: `labels` like '0.30', `values` the nearest doubles."""

    labels: tuple[str, ...]
    values: tuple[float, ...]

    def __len__(self) -> int:
        return len(self.values)


_THRESHOLD_FORMS = "START:STOP:STEP (e.g. 0.30:0.50:0.01), one number (0.5), or numbers separated by commas"


def _decimal_places(value: Decimal) -> int:
    """Digits after the point of a finite Decimal (negative for 1E+2)."""
    exponent = value.as_tuple().exponent
    assert isinstance(exponent, int), value  # only NaN and infinities have a letter here
    return -exponent


def _threshold_decimal(part: str, spec: str) -> Decimal:
    """One number of a threshold spec: finite, in [0, 1), at most MAX_THRESHOLD_DECIMALS places."""
    try:
        value = Decimal(part.strip())
    except InvalidOperation:
        raise ConfigError(f"thresholds {spec!r}: {part.strip()!r} is not a number; write {_THRESHOLD_FORMS}") from None
    if not value.is_finite():
        raise ConfigError(f"thresholds {spec!r}: {part.strip()!r} is not a finite number")
    if _decimal_places(value) > MAX_THRESHOLD_DECIMALS:
        raise ConfigError(f"thresholds {spec!r}: {part.strip()} has more than {MAX_THRESHOLD_DECIMALS} decimals")
    return value


def _check_in_unit_range(value: Decimal) -> None:
    if not 0 <= value < 1:
        raise ConfigError(f"IoU thresholds must lie in [0, 1), got {value}")


def _swept(text: str) -> list[Decimal]:
    """START:STOP:STEP, inclusive, each value start + i * step."""
    parts = text.split(":")
    if len(parts) != 3:
        raise ConfigError(f"thresholds {text!r} must be {_THRESHOLD_FORMS}")
    start, stop, step = (_threshold_decimal(part, text) for part in parts)
    _check_in_unit_range(start)
    _check_in_unit_range(stop)
    if step <= 0 or stop < start:
        raise ConfigError(f"thresholds {text!r} need start <= stop and a positive step")
    count = (stop - start) / step
    if count + 1 > MAX_THRESHOLDS:
        raise ConfigError(f"thresholds {text!r} give {int(count) + 1:,} values; at most {MAX_THRESHOLDS:,} are allowed")
    if count != count.to_integral_value():
        raise ConfigError(f"thresholds {text!r}: the step does not divide stop - start")
    return [start + step * i for i in range(int(count) + 1)]


def _listed(text: str) -> list[Decimal]:
    """A,B,...: the values as written."""
    parts = [part for part in text.split(",") if part.strip()]
    if len(parts) > MAX_THRESHOLDS:
        raise ConfigError(f"{len(parts):,} thresholds given; at most {MAX_THRESHOLDS:,} are allowed")
    return [_threshold_decimal(part, text) for part in parts]


def parse_thresholds(spec: str) -> Thresholds:
    """'0.30:0.50:0.01' (inclusive) or '0.5' or '0.3,0.5' -> exact decimal thresholds.

    Values are built as integer multiples of the step divided last, so 0.30 is the double
    nearest 0.3, never 0.30000000000000004. Every value lies in [0, 1); a sweep has a positive
    step and at most MAX_THRESHOLDS values. Anything else is one ConfigError line.
    """
    text = str(spec).strip()
    decimals = _swept(text) if ":" in text else _listed(text)
    if not decimals:
        raise ConfigError(f"no thresholds given; write {_THRESHOLD_FORMS}")
    for value in decimals:
        _check_in_unit_range(value)
    places = max(max(max(_decimal_places(d), 0) for d in decimals), 2)
    labels = tuple(f"{value:.{places}f}" for value in decimals)
    # Exact: a Decimal with few digits converts to the nearest double.
    values = tuple(float(value) for value in decimals)
    if len(set(labels)) != len(labels) or len(set(values)) != len(values):
        raise ConfigError(f"thresholds {text!r} repeat a value")
    assert all(math.isfinite(v) for v in values)
    return Thresholds(labels=labels, values=values)
