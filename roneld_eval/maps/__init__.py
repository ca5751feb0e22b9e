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
from .npy import load_npy, load_npz
from ..benchmarks.llamas.maps_png import llamas_png_paths, load_llamas_png
from .scnn_png import load_scnn_png, png_size, scnn_png_paths

FORMATS = ("npy", "npz", "scnn-png", "llamas-png")
# Formats whose maps this package's numba kernels decode (maps/_kernels.py): a run compiles them first.
DECODED_FORMATS = frozenset({"scnn-png", "llamas-png"})


def map_stem(root: Path, relpath: str) -> Path:
    """`<root>/<relpath without extension>`: the common prefix of a frame's map files."""
    return under_root(root, image_stem(relpath))


# The file that must exist for a frame's maps in each format: <stem> + suffix.
_FORMAT_SUFFIXES = {"npy": ".npy", "npz": ".npz", "scnn-png": ".exist.txt", "llamas-png": ".json_1.png"}


def format_files(stem: Path, fmt: str, lane_channels: int = 4) -> list[Path]:
    """The files by which a format's maps of one frame are recognised (any one suffices)."""
    if fmt == "scnn-png":
        pngs, exist = scnn_png_paths(stem, lane_channels)
        return [pngs[0], exist] + pngs[1:]
    if fmt == "llamas-png":
        return llamas_png_paths(stem, lane_channels)
    return [stem.with_name(stem.name + _FORMAT_SUFFIXES[fmt])]


def found_in_other_format(missing: Path, lane_channels: int = 4) -> str | None:
    """For a frame's missing map file (as `required_paths` names it): 'found <file>: use
    --maps-format <format>' when the frame's maps lie beside it in another format, else None."""
    missing = Path(missing)
    # Lane files wanted (a preset's format) may be maps in fact; the reverse is not said: .lines.txt
    # beside a frame are its ground truth as often as a detector's lanes.
    suffixes = {**_FORMAT_SUFFIXES, "lanes": ".lines.txt"}
    wanted = next((fmt for fmt, suffix in suffixes.items() if missing.name.endswith(suffix)), None)
    if wanted is None:
        return None
    stem = missing.with_name(missing.name[: -len(suffixes[wanted])])
    for fmt in FORMATS:
        if fmt == wanted:
            continue
        for path in format_files(stem, fmt, lane_channels):
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
    if config.format == "lanes":
        return _lane_format(lane_files).files(root, relpath)
    stem = map_stem(root, relpath)
    return [stem.with_name(stem.name + _FORMAT_SUFFIXES[config.format])]


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
    if config.format == "lanes":
        from .lanes import load_lane_maps

        if geometry is None:
            raise InputError(None, "lane files become maps only with the run's geometry")
        return load_lane_maps(root, relpath, _lane_format(lane_files), config, geometry, center_ratio)
    stem = map_stem(root, relpath)
    if config.format == "npy":
        return load_npy(stem.with_name(stem.name + _FORMAT_SUFFIXES["npy"]), config)
    if config.format == "npz":
        return load_npz(stem.with_name(stem.name + _FORMAT_SUFFIXES["npz"]), config)
    if config.format == "scnn-png":
        return load_scnn_png(stem, config)
    if config.format == "llamas-png":
        return load_llamas_png(stem, config)
    raise InputError(None, f"unknown maps format {config.format!r}")


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
        others = {fmt: sum(name.endswith(end) for name in names) for fmt, end in _FORMAT_SUFFIXES.items()}
        found = max(others, key=lambda fmt: others[fmt])
        hint = (f": it holds {others[found]} {_FORMAT_SUFFIXES[found]} files, use --maps-format {found}"
                if others[found] else "")
        raise InputError(folder, f"holds no {config.format} maps (files named <frame>{suffix}){hint}")
    return [stem + ".jpg" for stem in sorted(stems, key=_natural)]


def _folder_suffix(config: MapsConfig, lane_files) -> str:
    if config.format != "lanes":
        return _FORMAT_SUFFIXES[config.format]
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
    if config.format in ("scnn-png", "llamas-png"):
        stem = map_stem(root, relpath)
        paths = (scnn_png_paths(stem, config.lane_channels)[0] if config.format == "scnn-png"
                 else llamas_png_paths(stem, config.lane_channels))
        for path in paths:
            size = png_size(path)
            if size is not None:
                return size
    maps = load_maps(root, relpath, config, geometry, center_ratio, lane_files)
    return maps.width, maps.height


__all__ = ["load_maps", "map_size", "frames_in_folder", "required_paths", "map_stem", "found_in_other_format",
           "missing_reason",
           "FORMATS"]
