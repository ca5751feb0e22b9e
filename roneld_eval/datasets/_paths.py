"""Normalising the image paths that list and label files hold."""

from __future__ import annotations

import posixpath

from ..errors import InputError


def normalise_relpath(entry: str, path, line: int) -> str:
    """'/driver_37/.../00000.jpg' -> 'driver_37/.../00000.jpg'; refuses paths leaving the root."""
    cleaned = entry.strip().replace("\\", "/").lstrip("/")
    if not cleaned:
        raise InputError(path, "empty image path", line=line)
    normal = posixpath.normpath(cleaned)
    if normal == "." or normal == ".." or normal.startswith("../"):
        raise InputError(path, f"{entry.strip()!r} points outside the dataset root", line=line)
    return normal


def frame_sort_key(relpath: str):
    """Frames of a clip sort by frame number where the file name is one, else by name."""
    name = posixpath.basename(relpath)
    stem = name.rsplit(".", 1)[0]
    return (0, int(stem), name) if stem.isdigit() else (1, 0, name)
