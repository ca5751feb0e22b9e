"""TuSimple as it lies on disk: `test_label.json` (one JSON object per line) beside `clips/`.

Each label names the last frame of a 20-frame clip (``clips/0530/<id>/20.jpg``); the clip is
that folder, frames 1..20, and only the last is labelled. Lanes keep their points with
x >= 0 (x = -2 means no point) in h_samples order, top to bottom. Images are optional.
"""

from __future__ import annotations

import posixpath
from pathlib import Path

from ..errors import InputError
from ..lanes_io import lane_from_tusimple, read_tusimple_records
from ..model import Clip, Dataset, Frame
from ._paths import normalise_relpath

IMAGE_WIDTH, IMAGE_HEIGHT = 1280, 720


def read_tusimple(root: str | Path, label_file: str | Path | None = None, limit: int | None = None,
                  errors: list[InputError] | None = None) -> Dataset:
    """Read TuSimple labels into 20-frame clips whose last frame carries the ground truth.

    With an `errors` list, a bad label line is left out (its clip with it) and its error
    appended; without one, it raises.
    """
    root = Path(root)
    if not root.is_dir():
        raise InputError(root, "dataset root not found (expected a folder with test_label.json)")
    label_path = Path(label_file) if label_file is not None else root / "test_label.json"
    if not label_path.is_file():
        raise InputError(label_path, "label file not found" if not label_path.exists() else "label file is not a file")
    records = read_tusimple_records(label_path, errors=errors)
    if not records:
        raise InputError(label_path, "the label file holds no usable labels")

    clips = []
    seen: dict[str, int] = {}
    for number, record in records:
        try:
            relpath = normalise_relpath(record["raw_file"], label_path, number)
            if relpath in seen:
                raise InputError(label_path, f"{relpath} is labelled twice (first on line {seen[relpath]})", line=number)
            too_far = [x for lane in record["lanes"] for x in lane if x > 2 * IMAGE_WIDTH]
            if too_far:
                raise InputError(label_path, f"x = {too_far[0]:g} lies far outside the {IMAGE_WIDTH}-px-wide image",
                                 line=number)
        except InputError as error:
            if errors is None:
                raise
            errors.append(error)
            continue
        seen[relpath] = number
        h_samples = tuple(int(y) if float(y).is_integer() else y for y in record["h_samples"])
        lanes = tuple(lane_from_tusimple(xs, record["h_samples"]) for xs in record["lanes"])
        clip_id = posixpath.dirname(relpath)
        name = posixpath.basename(relpath)
        stem, dot, extension = name.rpartition(".")
        labelled = Frame(relpath=relpath, lanes=lanes, labelled=True, h_samples=h_samples)
        if dot and stem.isdigit() and int(stem) >= 1:
            # The clip's frames 1..N precede its labelled frame N.
            earlier = tuple(
                Frame(relpath=posixpath.join(clip_id, f"{k}.{extension}"), labelled=False)
                for k in range(1, int(stem))
            )
        else:
            earlier = ()
        clips.append(Clip(clip_id=clip_id, frames=earlier + (labelled,)))
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
