"""Counts as people write them: '1 clip', '2 clips'."""

from __future__ import annotations


def counted(number: int, noun: str, plural: str | None = None) -> str:
    return f"{number} {noun if number == 1 else plural or noun + 's'}"


def ego_lanes_only(names: list[str]) -> str:
    """'RONELD outputs the two ego lanes only', or 'A and B output ...' for several."""
    return f"{' and '.join(names)} output{'s' if len(names) == 1 else ''} the two ego lanes only"
