"""Galleries of a diagnosed score: the worst frames per category and per error type, ground truth
and each method's lanes over the image (over a blank canvas of the frame's size without one).

`score ... --diagnose --out DIR` writes gallery.json: the frames chosen (for each method, the
GALLERY_FRAMES with most errors in each category and with most of each error type, at the first
headline threshold), each with its size, its ground truth and every method's lanes in image
pixels, and each method's counts there. `roneld-eval show --run DIR` draws them (a file read back
is untrusted: every field is checked). The lanes are kept so that drawing needs no benchmark
reader, only the images (`--image-root`, default the one the score was given where it names one).
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path
from typing import Mapping, Sequence

import numpy as np

from ..errors import InputError
from ..json_fields import is_finite_number
from ..lanes_io import parse_json
from ..model import Lane

GALLERY = "gallery.json"
GALLERY_FORMAT = "roneld-eval gallery"
GALLERY_FRAMES = 6  # kept per method and reason; `show --worst` draws up to this many
MAX_POINTS = 1 << 16  # in one lane of a gallery file
MAX_PICTURES = 2000
MAX_TEXT = 1000  # characters of a title, frame name, reason or method name read back
MAX_SIDE, MAX_ASPECT = 20000, 8  # a frame's sides in pixels, and how far from square a picture may be


def is_gallery(folder: Path) -> bool:
    """A score folder with a gallery (`score --diagnose --out`), not a run's folder."""
    return (folder / GALLERY).is_file() and not (folder / "config.toml").exists()


@dataclass(frozen=True)
class GalleryFrame:
    """A frame as a gallery shows it: its size and lanes in image pixels, and its image if any."""

    size: tuple[int, int]
    truth: Sequence[Lane]
    predicted: Mapping[str, Sequence[Lane]]  # method -> lanes
    image: str | None = None  # the image's path relative to the image root


def chosen_frames(diagnosed, label: str, per_reason: int = GALLERY_FRAMES) -> list[tuple[str, list[str]]]:
    """(frame, reasons) in order of choice: per method, the frames with most errors (FP + FN) in each
    category, then with most of each error type, at threshold `label`."""
    from ..metrics.lane_errors import ERROR_TYPES

    d = diagnosed.diagnoses
    t = diagnosed.labels.index(label)
    chosen: dict[int, list[str]] = {}
    for m, (method, matching) in enumerate(diagnosed.entries):
        name = diagnosed.name(method, matching)
        tp = d.tp[m, :, t]
        errors = (d.n_pred[m] - tp) + (d.n_gt - tp)
        groups = [group for group in diagnosed.groups if group[0] != "all"] or list(diagnosed.groups)
        reasons = [(f"{name}: most errors in {group}", np.where(inside, errors, 0)) for group, inside in groups]
        reasons += [(f"{name}: most {side.upper()} {kind}", d.errors[m, :, t, k])
                    for k, (side, kind) in ((k, ERROR_TYPES[k]) for k in diagnosed.types)]
        for reason, values in reasons:
            order = np.argsort(-values, kind="stable")[:per_reason]
            for k in order[values[order] > 0]:
                chosen.setdefault(int(k), []).append(reason)
    return [(d.frames[k], reasons) for k, reasons in chosen.items()]


def _lane_points(lane: Lane) -> list[list[float]]:
    return [[round(float(x), 1), round(float(y), 1)] for x, y in lane.points]


def gallery_record(diagnosed, label: str) -> dict:
    """gallery.json's content: each chosen frame's lanes read again (`diagnosed.frame_lanes`)."""
    d = diagnosed.diagnoses
    index = {frame: k for k, frame in enumerate(d.frames)}
    t = diagnosed.labels.index(label)
    pictures = []
    for frame, reasons in chosen_frames(diagnosed, label):
        found = diagnosed.frame_lanes(frame)
        k = index[frame]
        counts = {}
        for m, (method, matching) in enumerate(diagnosed.entries):
            tp = int(d.tp[m, k, t])
            counts[diagnosed.name(method, matching)] = [tp, int(d.n_pred[m, k]) - tp, int(d.n_gt[k]) - tp]
        pictures.append({"frame": frame, "reasons": reasons, "size": list(found.size), "image": found.image,
                         "truth": [_lane_points(lane) for lane in found.truth],
                         "predicted": {diagnosed.display.get(method, method): [_lane_points(lane) for lane in lanes]
                                       for method, lanes in found.predicted.items()},
                         "counts": counts})
    return {"format": GALLERY_FORMAT, "title": diagnosed.title, "threshold": label,
            "image_root": diagnosed.image_root, "pictures": pictures}


def write_gallery(staging, diagnosed, label: str) -> None:
    if diagnosed.frame_lanes is None:
        return
    record = gallery_record(diagnosed, label)
    staging.write_text(GALLERY, json.dumps(record, indent=None, separators=(",", ":")) + "\n")


# ---- reading one back, and drawing it ----------------------------------------------------------

def _bad(path: Path, what: str) -> InputError:
    return InputError(path, f"not a gallery `score --diagnose` writes: {what}")


def _lanes(value, path: Path) -> list[Lane]:
    if not isinstance(value, list) or len(value) > 1000:
        raise _bad(path, "lanes must be a list")
    lanes = []
    for lane in value:
        if not (isinstance(lane, list) and len(lane) <= MAX_POINTS and all(
                isinstance(p, list) and len(p) == 2 and all(is_finite_number(v) and abs(v) < 1 << 24 for v in p)
                for p in lane)):
            raise _bad(path, "a lane must be a list of [x, y] numbers")
        lanes.append(Lane(np.array(lane, np.float64).reshape(-1, 2)))
    return lanes


def _text(value) -> bool:
    return isinstance(value, str) and len(value) <= MAX_TEXT


def _image(value) -> bool:
    """An image path relative to the image root, inside it: no absolute path, no '..'."""
    if value is None:
        return True
    if not _text(value) or not value or value.startswith(("/", "\\")) or ":" in value.split("/")[0]:
        return False
    return all(part not in ("..", "") for part in value.replace("\\", "/").split("/"))


def read_gallery(folder: Path) -> dict:
    """A gallery.json, every field checked."""
    from ..lanes_io import read_bytes
    from ..limits import RUN_TABLE

    path = folder / GALLERY
    record = parse_json(read_bytes(path, limit=RUN_TABLE), path, "not a gallery `score --diagnose` writes",
                        "not a gallery `score --diagnose` writes")
    if not isinstance(record, dict) or record.get("format") != GALLERY_FORMAT:
        raise _bad(path, f"its format is not {GALLERY_FORMAT!r}")
    pictures = record.get("pictures")
    if not isinstance(pictures, list) or len(pictures) > MAX_PICTURES or not _text(record.get("title")) or not (
            record.get("threshold") is None or _text(record["threshold"])):
        raise _bad(path, "pictures must be a list, the title and threshold short texts")
    for picture in pictures:
        if not _picture_fields(picture):
            raise _bad(path, "each picture needs frame, reasons, size, image, truth, predicted, counts")
        picture["truth"] = _lanes(picture.get("truth"), path)
        picture["predicted"] = {str(method): _lanes(lanes, path) for method, lanes in picture["predicted"].items()}
    if record.get("image_root") is not None and not _text(record["image_root"]):
        raise _bad(path, "image_root must be a path or null")
    return record


def _picture_fields(picture) -> bool:
    """A picture's fields but its lanes are of the types gallery_record writes."""
    if not isinstance(picture, dict):
        return False
    return (_size(picture.get("size")) and _text(picture.get("frame")) and _texts(picture.get("reasons"))
            and _image(picture.get("image")) and isinstance(picture.get("predicted"), dict)
            and _texts(list(picture["predicted"])) and _counts(picture.get("counts")))


def _size(size) -> bool:
    """[width, height]: whole pixels, at most MAX_SIDE, at most MAX_ASPECT times longer than wide or so."""
    return (isinstance(size, list) and len(size) == 2 and all(type(v) is int and 1 <= v <= MAX_SIDE for v in size)
            and max(size) <= MAX_ASPECT * min(size))


def _texts(value) -> bool:
    return isinstance(value, list) and len(value) <= 100 and all(_text(v) for v in value)


def _counts(value) -> bool:
    """{method: [tp, fp, fn]} of whole numbers, for at most 100 methods."""
    return (isinstance(value, dict) and _texts(list(value))
            and all(isinstance(c, list) and len(c) == 3 and all(type(v) is int for v in c) for c in value.values()))


COLOURS = [(60, 60, 230), (60, 200, 60), (235, 200, 60), (200, 60, 200), (40, 160, 240), (160, 160, 160)]  # BGR


def draw_gallery(record: dict, image_root: Path | None, worst: int) -> list[tuple[str, np.ndarray]]:
    """(name, picture) of the first `worst` frames of each reason, in the record's order."""
    import cv2

    from .overlays import BLUE, OUTPUT_WIDTH, _polyline, caption_bar

    taken: dict[str, int] = {}
    out = []
    for number, picture in enumerate(record["pictures"]):
        wanted = [r for r in picture["reasons"] if taken.get(r, 0) < worst]
        if not wanted:
            continue
        for reason in wanted:
            taken[reason] = taken.get(reason, 0) + 1
        width, height = picture["size"]
        scale = OUTPUT_WIDTH / width
        size = (OUTPUT_WIDTH, max(1, round(height * scale)))  # at most MAX_ASPECT x OUTPUT_WIDTH high
        background = _background(image_root, picture.get("image"), width, height)
        image = (np.full((size[1], size[0], 3), 40, np.uint8) if background is None
                 else cv2.resize(background, size, interpolation=cv2.INTER_AREA))
        for lane in picture["truth"]:
            _polyline(image, lane.points * scale, BLUE, 9, False)
        for rank, lanes in enumerate(picture["predicted"].values()):
            for lane in lanes:
                _polyline(image, lane.points * scale, COLOURS[rank % len(COLOURS)], 3, rank % 2 == 1)
        lines = [picture["frame"], "; ".join(wanted)]
        lines += [f"{method}: TP {c[0]}  FP {c[1]}  FN {c[2]}" for method, c in picture["counts"].items()]
        lines.append(f"blue: ground truth; {', '.join(picture['predicted'])} in turn red, green, ... "
                     f"({record['title']}, IoU > {record.get('threshold')})")
        out.append((f"{number:03d}", np.vstack([image, caption_bar(lines)])))
    return out


def stage_gallery(staging, record: dict, image_root: Path | None, worst: int) -> None:
    """gallery/<k>.png and the contact sheet gallery.png of `record` (read_gallery's), drawn into a
    staging folder (output.Staging)."""
    import cv2

    from .overlays import contact_sheet

    pictures = draw_gallery(record, image_root, worst)
    for name, image in pictures:
        if not cv2.imwrite(str(staging.file(f"gallery/{name}.png")), image):
            raise InputError(staging.out_dir / "gallery" / f"{name}.png", "cannot write")
    if pictures and not cv2.imwrite(str(staging.file("gallery.png")), contact_sheet([p for _, p in pictures])):
        raise InputError(staging.out_dir / "gallery.png", "cannot write")


def _background(image_root: Path | None, image: str | None, width: int, height: int) -> np.ndarray | None:
    """The frame's image when the root holds it at the frame's size (a regular file of at most
    the map files' size, its header read first), else None: a dark canvas is drawn instead."""
    if image_root is None or image is None:
        return None
    import cv2

    from ..datasets._paths import under_root
    from ..image_header import image_file_size
    from ..limits import MAP

    path = under_root(image_root, image)
    try:
        if not path.is_file() or path.stat().st_size > MAP.bytes or image_file_size(path) != (width, height):
            return None
    except (OSError, ValueError, InputError):
        return None
    return cv2.imread(str(path), cv2.IMREAD_COLOR)
