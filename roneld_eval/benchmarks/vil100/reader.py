"""VIL-100 (Zhang et al., ICCV 2021) as MMA-Net's evaluator reads it: ground truth as
`<labels>/<sequence>/<frame>.lines.txt` (its `evaluation/txt/anno_txt` layout), one list of
`<sequence>/<frame>` entries, and each sequence at its own image size (the dataset ships eight
resolutions, from 640x368 to 1920x1080).

The size of a sequence is that of its first listed frame, as MMA-Net's evaluate_iou.py takes it
(8f95908, evaluation/evaluate_iou.py:48-49): from its image under the dataset's `JPEGImages`,
from its JSON annotation (`info.width`, `info.height`), or from a JSON file of sizes.
A sequence's name starts with its scenario codes (dataset/README.md:127-155).
"""

from __future__ import annotations

import os
import posixpath
from dataclasses import dataclass
from pathlib import Path
from typing import Mapping, NamedTuple, Sequence

from ...errors import ConfigError, InputError
from ...lanes_io import check_inside_image, parse_json, read_bytes, read_lines_txt, read_text, split_lines
from ...limits import CONFIG
from ...image_header import image_file_size
from ...model import Frame, image_stem
from ...datasets._paths import check_folder, frame_sort_key, normalise_relpath, under_root

# dataset/README.md of yujun0-0/MMA-Net (8f95908), lines 127-155: the digits before a sequence
# name's first "_" are its scenarios.
SCENARIOS = ("normal", "crowded", "curved road", "damaged road", "shadows", "road markings", "dazzle light",
             "haze", "night", "crossroad")
IMAGE_SUFFIXES = (".jpg", ".png", ".jpeg")


@dataclass(frozen=True)
class Vil100Set:
    """The frames to score, by sequence in list order, and each sequence's (width, height)."""

    labels: Path
    sequences: Mapping[str, tuple[str, ...]]  # sequence -> frame relpaths "<sequence>/<frame>", list order
    sizes: Mapping[str, tuple[int, int]]
    unlabelled: tuple[str, ...] = ()  # listed frames without a ground-truth file (no lanes, as the C++ reads them)

    @property
    def n_frames(self) -> int:
        return sum(len(frames) for frames in self.sequences.values())


def scenarios_of(sequence: str) -> tuple[int, ...]:
    """The scenario codes in a sequence's name ('1269_Road023_Trim003_frames': 1, 2, 6, 9)."""
    head = sequence.split("_", 1)[0]
    return tuple(dict.fromkeys(int(digit) for digit in head)) if head.isascii() and head.isdigit() else ()


def labels_path(labels: Path, relpath: str) -> Path:
    return under_root(labels, f"{image_stem(relpath)}.lines.txt")


def _entry(text: str, path: Path, line: int) -> str:
    """'<sequence>/<frame>' from a list line: that, '<sequence>/<frame>.jpg', or MMA-Net's
    '/JPEGImages/<sequence>/<frame>.jpg'."""
    relpath = image_stem(normalise_relpath(text.split()[0], path, line))
    parts = relpath.split("/")
    if parts[0] == "JPEGImages":
        parts = parts[1:]
    if len(parts) != 2:
        raise InputError(path, f"{text.split()[0]!r} is not <sequence>/<frame>", line=line)
    return "/".join(parts)


def read_list(path: Path) -> list[str]:
    entries: list[str] = []
    seen: dict[str, int] = {}
    for number, line in enumerate(split_lines(read_text(path)), start=1):
        if not line.strip():
            continue
        relpath = _entry(line, path, number)
        if relpath in seen:
            raise InputError(path, f"{relpath} is listed twice (first on line {seen[relpath]})", line=number)
        seen[relpath] = number
        entries.append(relpath)
    if not entries:
        raise InputError(path, "the list names no frames")
    return entries


def every_labelled_frame(labels: Path) -> list[str]:
    """'<sequence>/<frame>' of every `.lines.txt` two levels under `labels`, sequences and frames sorted."""
    entries = []
    for sequence in sorted(entry.name for entry in os.scandir(labels) if entry.is_dir()):
        names = [name[:-len(".lines.txt")] for name in os.listdir(labels / sequence) if name.endswith(".lines.txt")]
        entries += sorted((f"{sequence}/{name}" for name in names), key=frame_sort_key)
    if not entries:
        hint = f" (did you mean {labels / LABELS_FOLDER}?)" if _holds_sequences(labels / LABELS_FOLDER) else ""
        raise InputError(labels, f"no <sequence>/<frame>.lines.txt here: is this MMA-Net's anno_txt folder?{hint}")
    return entries


def _holds_sequences(folder: Path) -> bool:
    """Whether one of the folder's first subfolders holds .lines.txt files (a labels folder)."""
    try:
        for entry in sorted(os.scandir(folder), key=lambda entry: entry.name)[:20]:
            if entry.is_dir() and any(name.endswith(".lines.txt") for name in os.listdir(entry.path)[:200]):
                return True
    except OSError:
        return False
    return False


def read_sizes_file(path: Path) -> dict[str, tuple[int, int]]:
    """{sequence: {"width": W, "height": H}} or {sequence: [W, H]}."""
    data = parse_json(read_bytes(path, limit=CONFIG), path, "not JSON", "not a file of sizes")
    if not isinstance(data, dict):
        raise InputError(path, "must map each sequence to its width and height")
    return {str(name): _size(value, path, str(name)) for name, value in data.items()}


# The largest frame side accepted (VIL-100's largest is 1920): a sequence is drawn at its size.
MAX_SIDE = 16384


def _size(value, path: Path, where: str) -> tuple[int, int]:
    if isinstance(value, dict):
        value = [value.get("width"), value.get("height")]
    if (not isinstance(value, list) or len(value) != 2
            or not all(isinstance(v, int) and not isinstance(v, bool) and 1 <= v <= MAX_SIDE for v in value)):
        raise InputError(path, f"{where}: a size is a width and a height in pixels (1..{MAX_SIDE}), got {value!r}")
    return value[0], value[1]


def _image_size(root: Path, relpath: str) -> tuple[int, int]:
    """(width, height) from the image's header (JPEG or PNG), without decoding it."""
    for suffix in IMAGE_SUFFIXES:
        path = under_root(root, relpath + suffix)
        if os.path.lexists(path):
            size = image_file_size(path)
            return _size(list(size), path, "image")
    raise InputError(under_root(root, relpath + IMAGE_SUFFIXES[0]), "image not found (needed for the sequence's size)")


def _json_size(root: Path, relpath: str) -> tuple[int, int]:
    for name in (relpath + ".jpg.json", relpath + ".json"):
        path = under_root(root, name)
        if os.path.lexists(path):  # there: a folder or a FIFO is refused as such by read_bytes
            record = parse_json(read_bytes(path, limit=CONFIG), path, "not a VIL-100 annotation",
                                "not a VIL-100 annotation")
            info = record.get("info") if isinstance(record, dict) else None
            if not isinstance(info, dict):
                raise InputError(path, "not a VIL-100 annotation: no `info` object with the image's width and height")
            return _size(info, path, "info")
    raise InputError(under_root(root, relpath + ".jpg.json"), "annotation not found (needed for the sequence's size)")


def read_vil100(labels: str | Path, list_file: str | Path | None = None, image_root: str | Path | None = None,
                json_root: str | Path | None = None, sizes_file: str | Path | None = None) -> Vil100Set:
    """The frames to score and each sequence's size; exactly one source of sizes must be given."""
    labels = Path(labels)
    check_folder(labels, "ground-truth folder not found (expected <sequence>/<frame>.lines.txt below it)")
    sources = [source for source in (image_root, json_root, sizes_file) if source is not None]
    if len(sources) != 1:
        raise ConfigError("give the sequences' image sizes once: --image-root (the dataset's JPEGImages), "
                          "--json-root (its Json folder) or --sizes FILE")
    entries = read_list(Path(list_file)) if list_file is not None else every_labelled_frame(labels)
    sequences: dict[str, list[str]] = {}
    for relpath in entries:
        sequences.setdefault(relpath.split("/")[0], []).append(relpath)
    for name in sequences:
        if name == "all" or name.startswith("scenario "):  # the rows official.csv adds
            raise InputError(Path(list_file) if list_file is not None else labels,
                             f"a sequence named {name!r} would be mistaken for official.csv's own rows")
    _check_some_labels(labels, entries)
    unlabelled = tuple(relpath for relpath in entries if not labels_path(labels, relpath).exists())
    sizes = _sequence_sizes(sequences, image_root, json_root, sizes_file)
    return Vil100Set(labels, {name: tuple(frames) for name, frames in sequences.items()}, sizes, unlabelled)


def _sequence_sizes(sequences: dict[str, list[str]], image_root: str | Path | None, json_root: str | Path | None,
                    sizes_file: str | Path | None) -> dict[str, tuple[int, int]]:
    """Each sequence's (width, height), from the one source given: the sizes file, its first
    frame's image, or its first frame's annotation."""
    if sizes_file is not None:
        known = read_sizes_file(Path(sizes_file))
        missing = [name for name in sequences if name not in known]
        if missing:
            raise InputError(Path(sizes_file), f"no size for sequence {missing[0]}"
                                               + (f" and {len(missing) - 1} more" if len(missing) > 1 else ""))
        return {name: known[name] for name in sequences}
    if image_root is not None:
        check_folder(Path(image_root), "image folder not found")
        return {name: _image_size(Path(image_root), frames[0]) for name, frames in sequences.items()}
    assert json_root is not None
    check_folder(Path(json_root), "annotation folder not found")
    return {name: _json_size(Path(json_root), frames[0]) for name, frames in sequences.items()}


def _check_some_labels(labels: Path, entries: Sequence[str]) -> None:
    """A folder holding none of the listed frames' labels is the wrong folder, not frames without lanes."""
    if not any(labels_path(labels, relpath).exists() for relpath in entries):
        first = labels_path(labels, entries[0])
        raise InputError(labels, f"no listed frame has its ground truth here (first missing: {first})")


def sequence_of(relpath: str) -> str:
    return posixpath.dirname(relpath)


# ---- the layout `run` reads --------------------------------------------------------------------

LABELS_FOLDER = "anno_txt"  # MMA-Net's evaluation/txt/anno_txt, placed in the dataset's root
SIZES_FILE = "sizes.json"  # what `synth` writes where there are no images
DEFAULT_LIST = "data/test.txt"  # the dataset's own list (MMA-Net's evaluate_iou.py:25)
RUN_LAYOUT = (f"a VIL-100 root holds {LABELS_FOLDER}/<sequence>/<frame>.lines.txt and the sequences' sizes "
              f"in JPEGImages/, Json/ or {SIZES_FILE}")


def size_files(root: Path, relpath: str) -> list[Path]:
    """The files a video's size is read from, given its first frame (what a resumed run must see
    unchanged): its image or annotation, or the sizes file."""
    stem = image_stem(relpath)
    if (root / SIZES_FILE).is_file() and not (root / "JPEGImages").is_dir() and not (root / "Json").is_dir():
        return [root / SIZES_FILE]
    for folder, suffixes in (("JPEGImages", IMAGE_SUFFIXES), ("Json", (".jpg.json", ".json"))):
        if (root / folder).is_dir():
            return [path for path in (under_root(root / folder, stem + suffix) for suffix in suffixes)
                    if os.path.lexists(path)]
    return []


class RunSources(NamedTuple):
    """What `run` reads under a dataset root, as read_vil100 (and `score vil100`) take it: the
    labels, the list (None: every labelled frame) and one source of the videos' sizes."""

    labels: Path
    list_file: Path | None
    image_root: Path | None = None
    json_root: Path | None = None
    sizes_file: Path | None = None

    def read(self) -> Vil100Set:
        return read_vil100(self.labels, self.list_file, self.image_root, self.json_root, self.sizes_file)


def run_sources(root: Path, list_file: Path | None) -> RunSources:
    """The labels under a dataset root, `list_file` (else data/test.txt where there is one) and the
    first of JPEGImages/, Json/ and sizes.json there for the videos' sizes."""
    check_folder(root, f"dataset root not found ({RUN_LAYOUT})")
    labels = root / LABELS_FOLDER
    if not labels.is_dir():
        hint = ""
        if _holds_sequences(root):
            hint = f"; {root} looks like the anno_txt folder itself: give the folder that holds it"
        raise InputError(labels, f"ground-truth folder not found: {RUN_LAYOUT}{hint}")
    if list_file is None and (root / DEFAULT_LIST).is_file():
        list_file = root / DEFAULT_LIST
    if (root / "JPEGImages").is_dir():
        return RunSources(labels, list_file, image_root=root / "JPEGImages")
    if (root / "Json").is_dir():
        return RunSources(labels, list_file, json_root=root / "Json")
    if (root / SIZES_FILE).is_file():
        return RunSources(labels, list_file, sizes_file=root / SIZES_FILE)
    raise InputError(root, f"no image sizes: {RUN_LAYOUT}")


def read_vil100_run(root: Path, list_file: Path | None, limit: int | None,
                    errors: list[InputError] | None) -> tuple[list[tuple[str, tuple[Frame, ...]]], Path]:
    """(sequence, its frames in video order with lanes and size) for `run`, and the list or
    labels folder the frames came from. A listed frame must have its ground truth (with an
    `errors` list, a bad or missing one is left out and appended)."""
    sources = run_sources(root, list_file)
    found = sources.read()
    clips = []
    for name, relpaths in list(found.sequences.items())[:limit]:
        width, height = found.sizes[name]
        frames = []
        for relpath in sorted(relpaths, key=frame_sort_key):
            path = labels_path(found.labels, relpath)
            try:
                if not os.path.lexists(path):
                    raise InputError(path, "ground truth not found (every listed frame needs its .lines.txt)")
                lanes = read_lines_txt(path)
                check_inside_image(lanes, path, width, height)
            except InputError as error:
                if errors is None:
                    raise
                errors.append(error)
                continue
            frames.append(Frame(relpath=relpath + ".jpg", lanes=tuple(lanes), image_size=(width, height)))
        if frames:
            clips.append((name, tuple(frames)))
    return clips, sources.list_file if sources.list_file is not None else found.labels
