"""Loading stored probability maps into one form: (C, H, W) uint8, 0..255, lane channels only.

Maps mirror the dataset tree under a maps root: the maps of ``<rel>/00000.jpg`` are
``<maps-root>/<rel>/00000.npy`` (or ``.npz``, or SCNN's ``00000_<k>_avg.png`` +
``00000.exist.txt``). uint8 is the canonical scale because SCNN and ENet-SAD store 8-bit maps
and RONELD's thresholds are defined on 0..255; float maps in [0, 1] are rounded to it once.
"""

from __future__ import annotations

import os
import re
import stat
from pathlib import Path

from ..config import MapsConfig
from ..geometry import MapGeometry
from ..datasets._paths import under_root
from ..errors import InputError
from ..model import FrameMaps, image_stem
from .formats import LANE_FILES, map_format
from .formats import names as format_names
from .scnn_png import png_size, scnn_png_paths


def map_stem(root: Path, relpath: str) -> Path:
    """`<root>/<relpath without extension>`: the common prefix of a frame's map files."""
    return under_root(root, image_stem(relpath))


def _suffixes() -> dict[str, str]:
    """The file that must exist for a frame's maps in each format: <stem> + suffix."""
    return {name: map_format(name).suffix for name in format_names()}


def found_in_other_format(missing: Path, lane_channels: int = 4) -> str | None:
    """For a frame's missing map file (as `required_paths` names it): 'found <file>: use
    --maps-format <format>' when the frame's maps lie beside it in another format, else None."""
    missing = Path(missing)
    # Lane files wanted (a preset's format) may be maps in fact; the reverse is not said: .lines.txt
    # beside a frame are its ground truth as often as a detector's lanes.
    suffixes = {**_suffixes(), LANE_FILES: ".lines.txt"}
    wanted = next((fmt for fmt, suffix in suffixes.items() if missing.name.endswith(suffix)), None)
    if wanted is None:
        return None
    stem = missing.with_name(missing.name[: -len(suffixes[wanted])])
    for fmt in format_names():
        if fmt == wanted:
            continue
        for path in map_format(fmt).recognised_by(stem, lane_channels):
            try:
                if stat.S_ISREG(os.stat(path).st_mode):
                    return f"found {path.name}: use --maps-format {fmt}"
            except (OSError, ValueError):
                continue
    return None


def missing_reason(path: Path) -> str:
    """Why a map file `check`ed as absent cannot be read: '' when it simply does not exist."""
    try:
        os.stat(path)
    except (FileNotFoundError, NotADirectoryError):
        return ""
    except OSError as error:
        return f"cannot read: {error.strerror}"
    except ValueError:
        return "not a usable file name"
    return ""


def pngs_without_existence(exist: Path) -> str:
    """For a missing SCNN existence file whose probability PNGs are there: say so (the maps are
    not missing, the file that says which lanes exist is)."""
    exist = Path(exist)
    if not exist.name.endswith(".exist.txt"):
        return ""
    stem = exist.with_name(exist.name[: -len(".exist.txt")])
    pngs, _ = scnn_png_paths(stem, 1)
    try:
        if stat.S_ISREG(os.stat(pngs[0]).st_mode):
            return (f"{pngs[0].name} is there, its existence file is not: SCNN's and ENet-SAD's test "
                    "scripts write <frame>.exist.txt beside the PNGs")
    except (OSError, ValueError):
        pass
    return ""


def required_paths(root: Path, relpath: str, config: MapsConfig, lane_files=None) -> list[Path]:
    """Files that must exist for a frame's maps to load (PNGs of absent lanes may be missing);
    for lane files (format "lanes"), those of the benchmark's format `lane_files`
    (maps.lanes.LaneFileFormat)."""
    if config.format == LANE_FILES:
        return _lane_format(lane_files).files(root, relpath)
    return [map_format(config.format).required(map_stem(root, relpath))]


def _lane_format(lane_files):
    if lane_files is None:
        raise InputError(None, "--maps-format lanes: this benchmark declares no format for a detector's lane files")
    return lane_files


def load_maps(root: Path, relpath: str, config: MapsConfig, geometry: MapGeometry | None = None,
              center_ratio: float = 0.5, lane_files=None) -> FrameMaps:
    """The maps of one frame in the canonical form, or an InputError naming the bad file.

    Lane files (format "lanes", in the benchmark's format `lane_files`) are drawn into maps of
    the configured size: they need the map-to-image `geometry` and the ego position
    (`center_ratio`) that orders the channels.
    """
    if config.format == LANE_FILES:
        from .lanes import load_lane_maps

        if geometry is None:
            raise InputError(None, "lane files become maps only with the run's geometry")
        return load_lane_maps(root, relpath, _lane_format(lane_files), config, geometry, center_ratio)
    try:
        fmt = map_format(config.format)
    except ValueError as error:
        raise InputError(None, str(error)) from None
    return fmt.load(map_stem(root, relpath), config)


def frames_in_folder(folder: Path, config: MapsConfig, lane_files=None) -> list[str]:
    """The frames whose maps one folder holds (one clip's, not a dataset tree), as relpaths
    `<name>.jpg` that `load_maps` finds them by, in name order (numbers by value: frame_2 before
    frame_10); InputError for a folder that is none, or that holds no maps in this format (naming
    the format its files are in, where they are in another)."""
    suffix = _folder_suffix(config, lane_files)
    try:
        entries = list(os.scandir(folder))
    except NotADirectoryError:
        raise InputError(folder, "not a folder (give the folder of one clip's maps)") from None
    except FileNotFoundError:
        raise InputError(folder, "no such folder") from None
    except OSError as error:
        raise InputError(folder, f"cannot read: {error.strerror}") from None
    for entry in entries:  # a frame's maps that are no file are refused, not passed over
        if entry.name.endswith(suffix) and not entry.is_file():
            raise InputError(Path(folder) / entry.name, "is not a regular file (a folder, a FIFO or a device)")
    names = sorted(entry.name for entry in entries if entry.is_file())
    stems = [name[:-len(suffix)] for name in names if name.endswith(suffix) and len(name) > len(suffix)]
    if not stems:
        hint = _format_hint(names) or _folders_hint(entries)
        raise InputError(folder, f"holds no {config.format} maps (files named <frame>{suffix}){hint}")
    return [stem + ".jpg" for stem in sorted(stems, key=_natural)]


def _folders_hint(entries: list[os.DirEntry]) -> str:
    """': it holds folders (e.g. X): ...' where a whole dataset's maps root was given for one clip's."""
    folders = sorted(entry.name for entry in entries if entry.is_dir())
    if not folders:
        return ""
    return (f": it holds folders (e.g. {folders[0]}), as a dataset's maps root does: give one clip's folder, or "
            "the dataset with --data-root and --clip")


def _format_hint(names: list[str]) -> str:
    """': it holds N <suffix> files, use --maps-format F' for the format most of `names` are in."""
    suffixes = _suffixes()
    others = {fmt: sum(name.endswith(end) for name in names) for fmt, end in suffixes.items()}
    found = max(others, key=lambda fmt: others[fmt])
    return f": it holds {others[found]} {suffixes[found]} files, use --maps-format {found}" if others[found] else ""


def _folder_suffix(config: MapsConfig, lane_files) -> str:
    if config.format != LANE_FILES:
        return map_format(config.format).suffix
    from .lanes import LinesPerFrame

    files = _lane_format(lane_files)
    if not isinstance(files, LinesPerFrame) or files.name_of is not None:
        raise InputError(None, "this benchmark's lane files do not name their frames one file each: give the "
                               "dataset (--data-root) that lists them")
    return files.suffix


def _natural(name: str) -> list:
    return [(0, int(part), "") if part.isdigit() else (1, 0, part) for part in re.split(r"(\d+)", name)]


def map_size(root: Path, relpath: str, config: MapsConfig, geometry: MapGeometry | None = None,
             center_ratio: float = 0.5, lane_files=None) -> tuple[int, int]:
    """(width, height) of a frame's maps, as `load_maps` would give them. For PNG maps, from the
    first PNG's header: nothing is decoded, so a process that only asks this (the run's main
    process) never loads the decoding kernel, nor numba with it (0.3 s and 50 MB)."""
    fmt = None if config.format == LANE_FILES else map_format(config.format)
    if fmt is not None and fmt.images is not None:
        for path in fmt.images(map_stem(root, relpath), config.lane_channels):
            size = png_size(path)
            if size is not None:
                return size
    maps = load_maps(root, relpath, config, geometry, center_ratio, lane_files)
    return maps.width, maps.height


__all__ = ["load_maps", "map_size", "frames_in_folder", "required_paths", "map_stem", "found_in_other_format",
           "missing_reason"]
