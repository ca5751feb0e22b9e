"""`.npy` maps (memory-mapped) and `.npz` maps (array under `maps.npz_key`, optional `exist`)."""

from __future__ import annotations

import zipfile
from pathlib import Path

import numpy as np

from ..config import MapsConfig
from ..errors import InputError
from ..model import FrameMaps
from ._checks import canonical_existence, canonical_probabilities


def load_npy(path: Path, config: MapsConfig) -> FrameMaps:
    """A (C, H, W) array from `.npy`; uint8 files stay memory-mapped."""
    try:
        array = np.load(path, mmap_mode="r", allow_pickle=False)
    except FileNotFoundError:
        raise InputError(path, "maps file not found") from None
    except (ValueError, OSError, EOFError) as error:
        raise InputError(path, f"not a readable .npy array (truncated or corrupt?): {error}") from None
    return FrameMaps(probabilities=canonical_probabilities(array, path, config))


def load_npz(path: Path, config: MapsConfig) -> FrameMaps:
    """Maps under `config.npz_key` (or the only array) and `exist` when present."""
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
    except (ValueError, OSError, EOFError, zipfile.BadZipFile, KeyError) as error:
        raise InputError(path, f"not a readable .npz archive (truncated or corrupt?): {error}") from None
    probabilities = canonical_probabilities(array, path, config)
    if existence is not None:
        existence = canonical_existence(existence, path, config)
    return FrameMaps(probabilities=probabilities, existence=existence)
