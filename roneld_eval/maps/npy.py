"""`.npy` maps (memory-mapped) and `.npz` maps (array under `maps.npz_key`, optional `exist`)."""

from __future__ import annotations

import mmap
import re
import zipfile
from pathlib import Path

import numpy as np

from ..config import MapsConfig
from ..errors import InputError
from ..lanes_io import check_regular_file
from ..model import FrameMaps
from ._checks import canonical_existence, canonical_probabilities

# The header numpy writes for a C-ordered uint8 array of 3 dimensions; anything else goes
# through np.load. np.load parses headers with ast.literal_eval, a third of a millisecond
# per frame, which matters at 400 frames per second.
_SIMPLE_HEADER = re.compile(
    rb"\{'descr': '\|u1', 'fortran_order': False, 'shape': \((\d+), (\d+), (\d+)\), \}\s*\n\Z"
)


def _map_simple_npy(path: Path) -> np.ndarray | None:
    """A read-only memory map of a plain uint8 (C, H, W) .npy file, or None if not that simple."""
    with open(path, "rb") as handle:
        start = handle.read(10)
        if len(start) < 10 or start[:6] != b"\x93NUMPY" or start[6] != 1:
            return None
        header_length = int.from_bytes(start[8:10], "little")
        match = _SIMPLE_HEADER.match(handle.read(header_length))
        if match is None:
            return None
        shape = tuple(int(v) for v in match.groups())
        offset = 10 + header_length
        size = shape[0] * shape[1] * shape[2]
        if size == 0 or handle.seek(0, 2) != offset + size:
            return None
        buffer = mmap.mmap(handle.fileno(), 0, access=mmap.ACCESS_READ)
    return np.frombuffer(buffer, np.uint8, count=size, offset=offset).reshape(shape)


def load_npy(path: Path, config: MapsConfig) -> FrameMaps:
    """A (C, H, W) array from `.npy`; uint8 files stay memory-mapped."""
    check_regular_file(path, "maps file not found")
    try:
        array = _map_simple_npy(path)
        if array is None:
            array = np.load(path, mmap_mode="r", allow_pickle=False)
    except FileNotFoundError:
        raise InputError(path, "maps file not found") from None
    except PermissionError as error:
        raise InputError(path, f"cannot read: {error.strerror}") from None
    except (ValueError, OSError, EOFError) as error:
        raise InputError(path, f"not a readable .npy array (truncated or corrupt?): {error}") from None
    return FrameMaps(probabilities=canonical_probabilities(array, path, config))


def load_npz(path: Path, config: MapsConfig) -> FrameMaps:
    """Maps under `config.npz_key` (or the only array) and `exist` when present."""
    check_regular_file(path, "maps file not found")
    try:
        with np.load(path, allow_pickle=False) as archive:
            names = list(archive.files)
            key = config.npz_key if config.npz_key in names else (names[0] if len(names) == 1 else None)
            if key is None:
                raise InputError(path, f"no array named {config.npz_key!r} (arrays: {', '.join(names) or 'none'})")
            array = archive[key]
            existence = archive["exist"] if "exist" in names and key != "exist" else None
    except FileNotFoundError:
        raise InputError(path, "maps file not found") from None
    except InputError:
        raise
    except PermissionError as error:
        raise InputError(path, f"cannot read: {error.strerror}") from None
    except (ValueError, OSError, EOFError, zipfile.BadZipFile, KeyError) as error:
        raise InputError(path, f"not a readable .npz archive (truncated or corrupt?): {error}") from None
    probabilities = canonical_probabilities(array, path, config)
    if existence is not None:
        existence = canonical_existence(existence, path, config)
    return FrameMaps(probabilities=probabilities, existence=existence)
