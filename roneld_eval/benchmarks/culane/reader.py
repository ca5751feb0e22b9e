"""CULane as it lies on disk: a list file of image paths, a `.lines.txt` beside each image.

A clip is one video folder (``driver_37_30frame/05181432_0203.MP4``); its frames are sorted
by frame number. Clips keep the order in which the list first names them. Category lists
(``list/test_split/test<i>_<name>.txt``) are read when present. Images are optional.
"""

from __future__ import annotations

import os
import posixpath
import re
from dataclasses import replace
from pathlib import Path
from typing import Mapping


from ...errors import InputError
from ...lanes_io import check_inside_image, check_regular_file, read_lines_txt, read_text, split_lines
from ...model import Clip, Dataset, Frame, image_stem
from ...datasets._paths import check_folder, frame_sort_key, normalise_relpath, under_root

IMAGE_WIDTH, IMAGE_HEIGHT = 1640, 590  # every CULane frame (Pan et al., AAAI 2018)
_CATEGORY_FILE = re.compile(r"test(\d+)_(\w+)\.txt\Z")
_LIKE_A_CATEGORY_FILE = re.compile(r"test\d+_.+\.txt\Z", re.S)
# Names of the official and accuracy tables' own rows, which a category list would be confused with.
RESERVED_CATEGORIES = {"all": "every frame", "ego": "the two ego lanes"}


def read_list_file(path: Path) -> list[tuple[int, str]]:
    """(line number, relpath) of every entry; extra columns (train lists) are ignored."""
    text = read_text(path)
    entries = []
    for number, line in enumerate(split_lines(text), start=1):
        if line.strip():
            entries.append((number, normalise_relpath(line.split()[0], path, number)))
    if not entries:
        raise InputError(path, "the list file names no images")
    return entries


def labels_path(root: Path, relpath: str) -> Path:
    """Where CULane keeps the ground truth of an image: the `.lines.txt` beside it."""
    return under_root(root, f"{image_stem(relpath)}.lines.txt")


def category_files(root: Path) -> list[tuple[int, str, Path]]:
    """(number, name, path) of each category list in list/test_split/ (test<number>_<name>.txt),
    in order of number; none without the folder. A file named almost so is refused."""
    folder = root / "list" / "test_split"
    try:
        names = sorted(entry.name for entry in os.scandir(folder))
    except (FileNotFoundError, NotADirectoryError):
        return []
    except OSError as error:
        raise InputError(folder, f"cannot read: {error.strerror}") from None
    found = []
    for name in names:
        match = _CATEGORY_FILE.match(name)
        if match:
            found.append((int(match.group(1)), match.group(2), folder / name))
        elif _CATEGORY_FILE.match(name + ".txt"):  # its rows would be missing from every table, silently
            raise InputError(folder / name, f"a category list must end in .txt: rename it {name}.txt")
        elif _LIKE_A_CATEGORY_FILE.match(name):  # as silently
            raise InputError(folder / name, "a category list is named test<number>_<name>.txt with letters, digits "
                                            "and _ only in <name> (it names the category's rows): rename it")
    return sorted(found)


def read_categories(root: Path, listed: Mapping[str, str] | None = None) -> dict[str, frozenset[str]]:
    """Category name -> frame relpaths, from list/test_split/ when it exists. A relpath found
    in `listed` is that string object: the test list's frames are kept once, not twice."""
    listed = listed or {}
    # Matched by image stem, as every file of a frame is: a test list without extensions (or
    # with .png) and category lists with .jpg name the same frames.
    by_stem = {image_stem(relpath): relpath for relpath in listed.values()}
    categories = {}
    for _, name, path in category_files(root):
        if name in RESERVED_CATEGORIES:
            raise InputError(path, f"a category list cannot be called {name!r}: the tables have a row of that name "
                                   f"({RESERVED_CATEGORIES[name]}); rename the file")
        entries = read_list_file(path)
        members = [by_stem.get(image_stem(relpath)) for _, relpath in entries]
        if listed and not any(members):
            raise InputError(path, f"none of its {len(entries):,} frames is in the test list (first: "
                                   f"{entries[0][1]}): its rows would be empty")
        categories[name] = frozenset(member or relpath for member, (_, relpath) in zip(members, entries))
    return categories


def read_frame_labels(root: Path, relpath: str):
    """A frame's ground-truth lanes from the `.lines.txt` beside its image (none if absent)."""
    path = labels_path(root, relpath)
    lanes = read_lines_txt(path)
    check_inside_image(lanes, path, IMAGE_WIDTH, IMAGE_HEIGHT)
    return lanes


def with_labels(clip: Clip, root: str | Path, errors: list[InputError] | None = None) -> Clip:
    """The clip with its frames' labels read (frames with bad labels left out when collecting errors)."""
    frames = []
    for frame in clip.frames:
        try:
            lanes = read_frame_labels(Path(root), frame.relpath)
        except InputError as error:
            if errors is None:
                raise
            errors.append(error)
            continue
        frames.append(replace(frame, lanes=lanes))
    return replace(clip, frames=tuple(frames))


def check_some_labels(root: Path, relpaths: list[str]) -> None:
    """Refuse a root where no listed frame has its `.lines.txt` (a wrong --data-root).

    A missing file means a frame without lanes, so a wrong root would otherwise score zero
    lanes silently. Stops at the first label file found: one stat for a right root.
    """
    for relpath in relpaths:
        try:
            os.stat(labels_path(root, relpath))
            return
        except (FileNotFoundError, NotADirectoryError):
            continue
        except (OSError, ValueError):
            return  # there, but unreadable: reading it names the problem
    if relpaths:
        first = labels_path(root, relpaths[0])
        raise InputError(root, f"no listed frame has its ground truth here (first missing: {first}); "
                               "is this the CULane root?")


def _no_list(root: Path) -> str:
    """Why the default list is missing and how to give one: a folder of frames without CULane's
    list/ (the RONELD authors' example clip) otherwise met a bare 'not found'."""
    try:
        with os.scandir(root) as entries:
            here = min((entry.name for entry in entries if entry.name.endswith(".lines.txt")), default=None)
    except OSError:
        here = None
    if here is None:
        example = "e.g. driver_37_30frame/05181432_0203.MP4/00000.jpg"
    else:  # frames in the root itself: a line is the image's name alone
        example = f"{here[:-len('.lines.txt')]}.jpg for this folder's {here}"
    return (f"list file not found: the frames to score are listed one a line, each as its image's path below "
            f"the data root ({example}), the .lines.txt beside the image; write that list to list/test.txt "
            "or give it with --list FILE")


def read_culane(root: str | Path, list_file: str | Path | None = None, limit: int | None = None,
                errors: list[InputError] | None = None, labels: bool = True,
                require_labels: bool = False) -> Dataset:
    """Read a CULane tree into clips of frames with their ground-truth lanes.

    With an `errors` list, a frame whose labels are bad is left out and its error appended;
    without one, the first bad file raises. With `labels=False` only the list is read and
    `with_labels` reads each clip's labels later (a run's workers do, in parallel).
    `require_labels` refuses a root where no listed frame has its `.lines.txt` (a wrong root
    would otherwise score zero lanes); `read_dataset` always asks for it.
    """
    root = Path(root)
    check_folder(root, "dataset root not found (expected a folder with list/test.txt)")
    list_path = Path(list_file) if list_file is not None else root / "list" / "test.txt"
    check_regular_file(list_path, "list file not found" if list_file is not None else _no_list(root))
    entries = read_list_file(list_path)

    seen: dict[str, tuple[int, str]] = {}  # image stem -> (line, relpath): 00000.jpg and 00000.png are one frame
    by_clip: dict[str, list[str]] = {}
    for number, relpath in entries:
        stem = image_stem(relpath)
        if stem in seen:
            first_line, first = seen[stem]
            also = "" if first == relpath else f" as {first}"
            raise InputError(list_path, f"{relpath} is listed twice (first on line {first_line}{also})", line=number)
        seen[stem] = (number, relpath)
        clip_id = posixpath.dirname(relpath)
        by_clip.setdefault(clip_id, []).append(relpath)

    clip_ids = list(by_clip)
    if limit is not None:
        clip_ids = clip_ids[:limit]
    if require_labels:
        check_some_labels(root, [relpath for clip_id in clip_ids for relpath in by_clip[clip_id]])
    clips = []
    for clip_id in clip_ids:
        ordered = sorted(by_clip[clip_id], key=frame_sort_key)
        clip = Clip(clip_id, tuple(Frame(relpath=relpath) for relpath in ordered))
        if labels:
            clip = with_labels(clip, root, errors)
        if clip.frames:
            clips.append(clip)

    return Dataset(
        name="culane",
        root=root,
        image_width=IMAGE_WIDTH,
        image_height=IMAGE_HEIGHT,
        clips=tuple(clips),
        categories=read_categories(root, {relpath: relpath for _, relpath in entries}),
        source_file=list_path,
        labels_loaded=labels,
    )
