"""Normalising the image paths that list and label files hold, and finding their files on disk."""

from __future__ import annotations

import os
import posixpath
import stat
import sys
from pathlib import Path
from typing import Any, Callable

from ..errors import InputError
from ..model import image_stem

# Whether str paths reach the disk as UTF-8 (almost always; not under LC_ALL=C without
# Python's UTF-8 mode, where the file system encoding is ASCII).
_FS_UTF8 = sys.getfilesystemencoding().lower().replace("-", "") == "utf8"


def normalise_relpath(entry: str, path, line: int) -> str:
    """'/driver_37/.../00000.jpg' -> 'driver_37/.../00000.jpg'; refuses paths leaving the root."""
    cleaned = entry.strip().replace("\\", "/").lstrip("/")
    if not cleaned:
        raise InputError(path, "empty image path", line=line)
    if "\0" in cleaned:
        raise InputError(path, f"image path {cleaned!a} holds a NUL character", line=line)
    try:
        cleaned.encode("utf-8")
    except UnicodeEncodeError:  # a lone surrogate, as a JSON \udcff escape gives
        raise InputError(path, f"image path {cleaned!a} is not valid Unicode text (a name that is not UTF-8?)",
                         line=line) from None
    normal = posixpath.normpath(cleaned)
    if normal == "." or normal == ".." or normal.startswith("../"):
        raise InputError(path, f"{entry.strip()!r} points outside the dataset root", line=line)
    return normal


def check_folder(path: Path, missing: str) -> None:
    """Refuse, naming it, a folder that is missing, not a folder, or unreadable."""
    try:
        info = os.stat(path)
    except (FileNotFoundError, NotADirectoryError):
        raise InputError(path, missing) from None
    except OSError as error:
        raise InputError(path, f"cannot read: {error.strerror}") from None
    except ValueError:  # a NUL character in the name
        raise InputError(path, "not a usable folder name") from None
    if not stat.S_ISDIR(info.st_mode):
        raise InputError(path, "is not a folder")


def under_root(root, relpath: str) -> Path:
    """`root / relpath`, the relpath's text reaching the disk as UTF-8 bytes whatever the locale.

    List and label files are UTF-8, so the files they name are too; a non-UTF-8 file system
    encoding (LC_ALL=C without UTF-8 mode) must not turn 'é' into another name or an error.
    """
    if _FS_UTF8:
        return Path(root) / relpath
    return Path(root) / os.fsdecode(relpath.encode("utf-8", "surrogateescape"))


def files_below(root: Path, suffix: str, key: Callable[[str], Any] | None = None) -> list[str]:
    """The relative paths (with '/') of the files below `root` named `*<suffix>`: folder by folder in
    the order of their paths, in a folder by `key` of the name (default: the name). This tool's own
    files are not among them: an output folder (its manifest in it), a command's staging folder,
    its lock and journal; so a command's --out given inside a label folder is not read as labels
    the next time."""
    walked = []
    for folder, names, files in os.walk(root):
        names[:] = [name for name in names if not tool_folder(os.path.join(folder, name))]
        walked.append((folder, [name for name in files if name.endswith(suffix) and not _tool_name(name)]))
    found = []
    for folder, files in sorted(walked):
        relative = os.path.relpath(folder, root).replace(os.sep, "/")
        found += [name if relative == "." else f"{relative}/{name}" for name in sorted(files, key=key)]
    return found


def _tool_name(name: str) -> bool:
    """This tool's own lock, journal or staging folder, by its name."""
    from ..output import STAGING_PREFIX

    return name.startswith((".roneld-", STAGING_PREFIX))


def tool_folder(path: str | Path) -> bool:
    """Whether a folder below a label folder is this tool's own: an output folder (its manifest in
    it) or a command's staging folder, not labels."""
    from ..output import MANIFEST

    return _tool_name(os.path.basename(path)) or os.path.exists(os.path.join(path, MANIFEST))


def frame_sort_key(relpath: str):
    """Frames of a clip sort by frame number where the file name is one, else by name."""
    name = posixpath.basename(relpath)
    stem = image_stem(name)
    return (0, int(stem), name) if stem.isdigit() and stem.isascii() else (1, 0, name)


def read_image_list(path: Path, keep_suffix: bool = True) -> list[str]:
    """The relpaths a list file names, one a line (its first word), in order; with
    `keep_suffix=False` without their image extension. Duplicates and an empty list refused."""
    from ..lanes_io import read_text, split_lines
    from ..model import image_stem

    entries: list[str] = []
    seen: set[str] = set()
    for number, line in enumerate(split_lines(read_text(path)), start=1):
        if not line.strip():
            continue
        relpath = normalise_relpath(line.split()[0], path, number)
        relpath = relpath if keep_suffix else image_stem(relpath)
        if relpath in seen:
            raise InputError(path, f"{relpath} is listed twice", line=number)
        seen.add(relpath)
        entries.append(relpath)
    if not entries:
        raise InputError(path, "the list names no images")
    return entries

