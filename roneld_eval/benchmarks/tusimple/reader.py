"""TuSimple as it lies on disk: `test_label.json` (one JSON object per line) beside `clips/`.

Each label names the last frame of a 20-frame clip (``clips/0530/<id>/20.jpg``); the clip is
that folder, frames 1..20, and only the last is labelled. Lanes keep their points with
x >= 0 (x = -2 means no point) in h_samples order, top to bottom. Images are optional.
"""

from __future__ import annotations

import posixpath
from pathlib import Path

from ...errors import InputError
from ...lanes_io import check_regular_file
from .lane_format import check_h_samples, lane_from_tusimple, read_tusimple_records
from ...model import Clip, Dataset, Frame, image_stem
from ...datasets._paths import check_folder, normalise_relpath

IMAGE_WIDTH, IMAGE_HEIGHT = 1280, 720  # every TuSimple frame (tusimple-benchmark)
# A label names the last frame N of its clip and the clip is read as frames 1..N: a larger N
# is a mistake in the label file (TuSimple's clips hold 20 frames), not thousands of frames.
MAX_FRAME_NUMBER = 1000


def _frame_number(relpath: str) -> int | None:
    """20 for 'clips/0530/x/20.jpg' (or '.../20'); None when the file name is not a number."""
    name = posixpath.basename(image_stem(relpath))
    return int(name) if name.isascii() and name.isdigit() else None


def _checked_label(record: dict, label_path: Path, number: int, seen: dict[str, int]) -> tuple[str, str, int | None]:
    """(relpath, stem, frame number or None) of a label line, its rows and lanes checked against
    the image, and its frame not labelled before (`seen`: stem -> line)."""
    relpath = normalise_relpath(record["raw_file"], label_path, number)
    stem = image_stem(relpath)  # 20.jpg and 20.png are the same frame
    if stem in seen:
        raise InputError(label_path, f"{relpath} is labelled twice (first on line {seen[stem]})", line=number)
    check_h_samples(record["h_samples"], label_path, number, IMAGE_HEIGHT)
    too_far = [x for lane in record["lanes"] for x in lane if x > 2 * IMAGE_WIDTH]
    if too_far:
        raise InputError(label_path, f"x = {too_far[0]:g} lies far outside the {IMAGE_WIDTH}-px-wide image",
                         line=number)
    frame_number = _frame_number(relpath)
    if frame_number is not None and frame_number > MAX_FRAME_NUMBER:
        raise InputError(
            label_path, f"{relpath}: frame number {frame_number} would make a clip of {frame_number} frames "
                        f"(TuSimple clips hold 20; at most {MAX_FRAME_NUMBER} are read)", line=number)
    return relpath, stem, frame_number


def _clip_of(record: dict, relpath: str, stem: str, frame_number: int | None) -> Clip:
    """The clip of a labelled frame N: its frames 1..N-1, unlabelled, then the labelled one."""
    h_samples = tuple(int(y) if float(y).is_integer() else y for y in record["h_samples"])
    lanes = tuple(lane_from_tusimple(xs, record["h_samples"]) for xs in record["lanes"])
    clip_id = posixpath.dirname(relpath)
    extension = relpath[len(stem):]  # '.jpg', or '' for a name without one
    labelled = Frame(relpath=relpath, lanes=lanes, labelled=True, h_samples=h_samples)
    earlier: tuple[Frame, ...] = ()
    if frame_number is not None and frame_number >= 1:
        earlier = tuple(Frame(relpath=posixpath.join(clip_id, f"{k}{extension}"), labelled=False)
                        for k in range(1, frame_number))
    return Clip(clip_id=clip_id, frames=earlier + (labelled,))


def read_tusimple(root: str | Path, label_file: str | Path | None = None, limit: int | None = None,
                  errors: list[InputError] | None = None) -> Dataset:
    """Read TuSimple labels into 20-frame clips whose last frame carries the ground truth.

    With an `errors` list, a bad label line is left out (its clip with it) and its error
    appended; without one, it raises.
    """
    root = Path(root)
    check_folder(root, "dataset root not found (expected a folder with test_label.json)")
    label_path = Path(label_file) if label_file is not None else root / "test_label.json"
    check_regular_file(label_path, "label file not found")
    records = read_tusimple_records(label_path, errors=errors)
    if not records:
        raise InputError(label_path, "the label file holds no usable labels")

    clips = []
    seen: dict[str, int] = {}
    for number, record in records:
        try:
            relpath, stem, frame_number = _checked_label(record, label_path, number, seen)
        except InputError as error:
            if errors is None:
                raise
            errors.append(error)
            continue
        seen[stem] = number
        clips.append(_clip_of(record, relpath, stem, frame_number))
        if limit is not None and len(clips) >= limit:
            break

    ids = [clip.clip_id for clip in clips]
    if len(set(ids)) != len(ids):
        duplicate = next(i for i in ids if ids.count(i) > 1)
        raise InputError(label_path, f"clip {duplicate} is labelled more than once")
    return Dataset(
        name="tusimple",
        root=root,
        image_width=IMAGE_WIDTH,
        image_height=IMAGE_HEIGHT,
        clips=tuple(clips),
        source_file=label_path,
    )
