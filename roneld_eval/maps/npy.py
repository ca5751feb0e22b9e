"""`.npy` maps (memory-mapped) and `.npz` maps (array under `maps.npz_key`, optional `exist`)."""

from __future__ import annotations

import contextlib
import io
import math
import mmap
import re
import zipfile
from pathlib import Path

import numpy as np

try:  # libdeflate: a member inflates about 4x faster than through zipfile's zlib
    import deflate as _libdeflate
except ImportError:  # pragma: no cover - without it every .npz goes through np.load, as before
    _libdeflate = None  # type: ignore[assignment]

from ..config import MapsConfig
from ..errors import InputError
from .formats import MapFormat
from ..lanes_io import check_regular_file
from ..limits import MAP
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


_PICKLED = "holds Python objects (a pickled array), not numbers: save the maps as a numeric (uint8 or float) array"


def _header(stream) -> tuple[tuple[int, ...], np.dtype]:
    """(shape, dtype) a .npy stream's header declares, the stream left where the data starts
    (ValueError or EOFError where it has no readable header)."""
    version = np.lib.format.read_magic(stream)
    read = np.lib.format.read_array_header_1_0 if version == (1, 0) else np.lib.format.read_array_header_2_0
    shape, _, dtype = read(stream)
    return tuple(shape), dtype


def _holds_objects(handle) -> bool:
    """Whether the .npy stream at `handle` declares a dtype of Python objects (which np.load
    refuses with advice about allow_pickle, an option this tool never sets)."""
    try:
        return bool(_header(handle)[1].hasobject)
    except Exception:  # not even a readable header: the caller's own error stands
        return False


def load_npy(path: Path, config: MapsConfig) -> FrameMaps:
    """A (C, H, W) array from `.npy`; uint8 files stay memory-mapped."""
    check_regular_file(path, "maps file not found", MAP)
    try:
        array = _map_simple_npy(path)
        if array is None:
            array = np.load(path, mmap_mode="r", allow_pickle=False)
    except FileNotFoundError:
        raise InputError(path, "maps file not found") from None
    except PermissionError as error:
        raise InputError(path, f"cannot read: {error.strerror}") from None
    except (ValueError, OSError, EOFError, zipfile.BadZipFile) as error:
        with contextlib.suppress(OSError), open(path, "rb") as handle:
            start = handle.read(6)
            handle.seek(0)
            if start != b"\x93NUMPY" and not start.startswith(b"PK"):
                # np.load takes any other file for a pickle and says so: it is not an array at all.
                raise InputError(path, "not a .npy array (it does not start with numpy's magic bytes)") from None
            if _holds_objects(handle):
                raise InputError(path, _PICKLED) from None
        # np.load takes a file that starts like a zip archive for an .npz (BadZipFile if it is not one)
        raise InputError(path, f"not a readable .npy array (truncated or corrupt?): {error}") from None
    if not isinstance(array, np.ndarray):  # an .npz archive under a .npy name
        array.close()
        raise InputError(path, "is an .npz archive, not a .npy array (use --maps-format npz)")
    return FrameMaps(probabilities=canonical_probabilities(array, path, config))


def _member(data: bytes, info: zipfile.ZipInfo) -> bytes | bytearray | None:
    """A stored or deflated member's bytes, read from the archive's bytes with libdeflate
    (length and CRC-32 checked as zipfile checks them); None for anything unusual."""
    start = info.header_offset
    if data[start:start + 4] != b"PK\x03\x04" or info.flag_bits & 0x1:  # not a local header, or encrypted
        return None
    name_length = int.from_bytes(data[start + 26:start + 28], "little")
    extra_length = int.from_bytes(data[start + 28:start + 30], "little")
    start += 30 + name_length + extra_length
    stored = data[start:start + info.compress_size]
    if len(stored) != info.compress_size:
        return None
    if info.compress_type == zipfile.ZIP_STORED:
        raw: bytes | bytearray = stored
    elif info.compress_type == zipfile.ZIP_DEFLATED:
        raw = _libdeflate.deflate_decompress(stored, info.file_size + 1)
    else:
        return None
    if len(raw) != info.file_size or _libdeflate.crc32(raw) != info.CRC:
        return None
    return raw


def _member_array(raw: bytes | bytearray) -> np.ndarray:
    """The array of a member's .npy bytes, as np.load gives it (a plain uint8 (C, H, W)
    without np.load's header parsing)."""
    if raw[:6] == b"\x93NUMPY" and raw[6] == 1:
        header_length = int.from_bytes(raw[8:10], "little")
        match = _SIMPLE_HEADER.match(bytes(raw[10:10 + header_length]))
        if match is not None:
            shape = tuple(int(v) for v in match.groups())
            size = shape[0] * shape[1] * shape[2]
            if size and len(raw) == 10 + header_length + size:
                return np.frombuffer(raw, np.uint8, count=size, offset=10 + header_length).reshape(shape)
    stream = io.BytesIO(raw)
    shape, dtype = _header(stream)
    if math.prod(shape) * dtype.itemsize > len(raw) - stream.tell():
        raise ValueError("the header claims more data than the member holds")  # read_array would allocate it
    stream.seek(0)
    return np.lib.format.read_array(stream, allow_pickle=False)


def _read_plain_npz(path: Path, config: MapsConfig) -> tuple[np.ndarray, np.ndarray | None] | None:
    """(maps array, existence array or None) of a well-formed archive of .npy members, as
    load_npz's np.load reads them, or None for anything else (np.load then says what is wrong)."""
    try:
        data = path.read_bytes()
        if not data.startswith(b"PK\x03\x04"):
            return None
        with zipfile.ZipFile(io.BytesIO(data)) as archive:
            infos = {info.filename: info for info in archive.infolist()}
        _check_members(path, infos.values())
        if not infos or any(not name.endswith(".npy") for name in infos):
            return None
        arrays = _plain_members(data, infos, config)
    except InputError:
        raise
    except Exception:  # whatever it is, np.load meets it again and reports it
        return None
    if arrays is None:
        return None
    return arrays[0], arrays[1] if len(arrays) > 1 else None


def _plain_members(data: bytes, infos: dict, config: MapsConfig) -> list[np.ndarray] | None:
    """The maps member and `exist` (where there is one) decoded, or None where the archive is
    not plainly one of .npy members with a maps member of its own name."""
    names = [name[:-4] for name in infos]
    key = config.npz_key if config.npz_key in names else (names[0] if len(names) == 1 else None)
    if key is None or len(set(names)) != len(names):
        return None
    arrays = []
    for name in [key] + (["exist"] if "exist" in names and key != "exist" else []):
        raw = _member(data, infos[name + ".npy"])
        if raw is None:
            return None
        arrays.append(_member_array(raw))
    return arrays


def _check_declared_size(path: Path, name: str, archive: zipfile.ZipFile) -> None:
    """Refuse a member whose .npy header claims more data than the member holds: np.load would
    allocate the claimed size first (a 191-byte archive claiming 40 GB)."""
    try:
        info = archive.getinfo(name + ".npy")
        with archive.open(info) as member:
            shape, dtype = _header(member)
            header = member.tell()
    except (KeyError, OSError, ValueError, EOFError, zipfile.BadZipFile):
        return  # np.load meets it and says what is wrong
    claimed = math.prod(shape) * dtype.itemsize
    if claimed > info.file_size - header:
        raise InputError(path, f"its array {name!r} claims shape {shape} ({claimed:,} bytes) but holds "
                               f"{max(0, info.file_size - header):,}")


def _check_members(path: Path, infos) -> None:
    """Refuse an archive whose members inflate beyond the map bound (a zip bomb), before inflating."""
    for info in infos:
        if info.file_size > MAP.bytes:
            raise InputError(path, f"its member {info.filename!r} inflates to {info.file_size:,} bytes: {MAP.rule()}")


def _check_archive_start(path: Path) -> None:
    """Refuse a file that does not start as a zip archive: np.load returns a .npy array as it is
    (not an archive), and takes any other file for a pickle, advising to load it unsafely."""
    with open(path, "rb") as handle:
        start = handle.read(6)
    if start == b"\x93NUMPY":  # --maps-format npy looks for .npy names: the file must be renamed too
        raise InputError(path, "is a .npy array under an .npz name: save it as .npy (and use --maps-format npy)")
    if not start.startswith((b"PK\x03\x04", b"PK\x05\x06")):  # a zip's first member, or an empty zip
        raise InputError(path, "not an .npz archive (it does not start as a zip archive does)")


def load_npz(path: Path, config: MapsConfig) -> FrameMaps:
    """Maps under `config.npz_key` (or the only array) and `exist` when present."""
    check_regular_file(path, "maps file not found", MAP)
    plain = _read_plain_npz(path, config) if _libdeflate is not None else None
    array, existence = plain if plain is not None else _read_npz(path, config)
    probabilities = canonical_probabilities(array, path, config)
    if existence is not None:
        existence = canonical_existence(existence, path, config)
    return FrameMaps(probabilities=probabilities, existence=existence)


def _read_npz(path: Path, config: MapsConfig) -> tuple[np.ndarray, np.ndarray | None]:
    """The maps array and `exist` (None without one), as numpy reads any .npz archive, each
    member checked before it is decoded."""
    try:
        _check_archive_start(path)
        with np.load(path, allow_pickle=False) as archive:
            _check_members(path, archive.zip.infolist())
            names = list(archive.files)
            key = _maps_key(path, config, archive)
            wanted = [key] + (["exist"] if "exist" in names and key != "exist" else [])
            for name in wanted:
                _check_declared_size(path, name, archive.zip)
            array = archive[key]
            existence = archive["exist"] if "exist" in wanted else None
            for name, value in ((key, array), ("exist", existence)):
                if value is not None and not isinstance(value, np.ndarray):  # np.load hands such a member's bytes
                    raise InputError(path, f"its member {name}.npy is not a .npy array (it does not start with "
                                           "numpy's magic bytes)")
            return array, existence
    except FileNotFoundError:
        raise InputError(path, "maps file not found") from None
    except InputError:
        raise
    except PermissionError as error:
        raise InputError(path, f"cannot read: {error.strerror}") from None
    except (ValueError, OSError, EOFError, zipfile.BadZipFile, KeyError) as error:
        raise InputError(path, f"not a readable .npz archive (truncated or corrupt?): {error}") from None


def _maps_key(path: Path, config: MapsConfig, archive) -> str:
    """The archive's member holding the maps: `config.npz_key`, or its only array; not one of
    pickled objects."""
    names = list(archive.files)
    key = config.npz_key if config.npz_key in names else (names[0] if len(names) == 1 else None)
    if key is None:
        raise InputError(path, f"no array named {config.npz_key!r} (arrays: {', '.join(names) or 'none'})")
    with contextlib.suppress(KeyError, OSError, zipfile.BadZipFile), archive.zip.open(key + ".npy") as member:
        if _holds_objects(member):
            raise InputError(path, f"its array {key!r} {_PICKLED}")
    return key


def _npy_of_stem(stem: Path, config: MapsConfig) -> FrameMaps:
    return load_npy(stem.with_name(stem.name + ".npy"), config)


def _npz_of_stem(stem: Path, config: MapsConfig) -> FrameMaps:
    return load_npz(stem.with_name(stem.name + ".npz"), config)


NPY = MapFormat("npy", ".npy", _npy_of_stem)
NPZ = MapFormat("npz", ".npz", _npz_of_stem)
