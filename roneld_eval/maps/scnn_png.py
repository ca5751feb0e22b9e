"""SCNN / ENet-SAD output as their test scripts write it.

``<frame>_<k>_avg.png`` (k = 1..C, 8-bit grey = probability * 255) and ``<frame>.exist.txt``
(``1 1 1 0``). A channel whose existence is 0 may lack its PNG: its map is all zero.
"""

from __future__ import annotations

import zlib
from pathlib import Path

import numpy as np

try:  # libdeflate: zlib's output about 4x faster; decoding a map PNG is mostly inflating
    import deflate as _libdeflate
except ImportError:  # pragma: no cover - without it every PNG goes to OpenCV, as before
    _libdeflate = None  # type: ignore[assignment]

from ..config import MapsConfig
from ..errors import InputError
from ..lanes_io import decode_text, parse_number, read_bytes
from ..limits import MAP
from ..model import FrameMaps
from ._checks import canonical_existence
from .formats import MapFormat
from .. import _numba_cache  # noqa: F401  (numba imported first, a signal deferred meanwhile)
from ._kernels import unfilter_stream


def scnn_png_paths(stem: Path, channels: int) -> tuple[list[Path], Path]:
    """([<stem>_1_avg.png, ...], <stem>.exist.txt)."""
    pngs = [stem.with_name(f"{stem.name}_{k}_avg.png") for k in range(1, channels + 1)]
    return pngs, stem.with_name(stem.name + ".exist.txt")


def read_existence(path: Path, config: MapsConfig, data: bytes | None = None) -> np.ndarray:
    if data is None:
        data = read_bytes(path)
    tokens = decode_text(data, path).split()
    values = [parse_number(token, path, 1) for token in tokens]
    return canonical_existence(values, path, config)


_PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"


def check_png(data: bytes, path: Path) -> None:
    """Refuse a truncated or corrupt PNG before libpng sees it (libpng prints its own line to
    stderr for those): the signature, every chunk inside the file with its CRC, and an IEND."""
    if not data.startswith(_PNG_SIGNATURE):
        raise InputError(path, "not a PNG file")
    view = memoryview(data)
    offset, size = len(_PNG_SIGNATURE), len(data)
    while True:
        if offset + 12 > size:
            raise InputError(path, "truncated PNG (it ends before its IEND chunk)")
        length = int.from_bytes(view[offset:offset + 4], "big")
        end = offset + 12 + length
        if end > size:
            raise InputError(path, "truncated PNG (a chunk runs past the end of the file)")
        kind = bytes(view[offset + 4:offset + 8])
        if zlib.crc32(view[offset + 4:end - 4]) != int.from_bytes(view[end - 4:end], "big"):
            raise InputError(path, f"corrupt PNG ({kind.decode('latin-1')!r} chunk fails its CRC check)")
        if kind == b"IEND":
            return
        offset = end


# Chunks the usual map PNG holds (OpenCV writes IHDR, IDAT, IEND): others (palette,
# transparency, gamma, ...) may change what a decoder returns, so they go to OpenCV.
_PLAIN_CHUNKS = frozenset({b"IHDR", b"IDAT", b"IEND", b"tEXt", b"zTXt", b"iTXt", b"tIME", b"pHYs"})
_SAMPLES = {0: 1, 2: 3, 6: 4}  # colour type -> bytes per pixel at 8 bits: grey, RGB, RGBA
_PLAIN_MAX_PIXELS = 1 << 26


def _inflate(compressed: bytes, size: int) -> bytearray | None:
    """The zlib stream's `size` bytes (its Adler-32 checked), or None if it does not hold
    exactly that many or is corrupt (OpenCV then reports it)."""
    try:
        raw = _libdeflate.zlib_decompress(compressed, size + 1)
    except Exception:
        return None
    return raw if len(raw) == size else None


def _plain_chunks(data: bytes, allowed: frozenset) -> tuple[bytes, bytes | None, bytes] | None:
    """(IHDR, PLTE or None, the IDATs joined) of a PNG of `allowed` chunks only, in the order
    libpng insists on (one IHDR, first; IDATs one after another; PLTE before them); None for any
    other, which goes to the full decoder instead (which refuses what is out of order)."""
    offset, header, palette, after_data = 8, None, None, False
    parts: list[bytes] = []
    while offset + 8 <= len(data):
        length = int.from_bytes(data[offset:offset + 4], "big")
        kind = data[offset + 4:offset + 8]
        if kind not in allowed or (kind == b"IHDR") != (offset == 8):
            return None
        body = data[offset + 8:offset + 8 + length]
        if kind == b"IHDR":
            header = body
        elif kind == b"PLTE":
            if palette is not None or parts:
                return None
            palette = body
        elif kind == b"IDAT":
            if after_data:
                return None
            parts.append(body)
        elif kind == b"IEND":
            break
        elif parts:
            after_data = True
        offset += 12 + length
    if header is None or len(header) != 13 or not parts:
        return None
    return header, palette, b"".join(parts)


def _unfiltered(header: bytes, compressed: bytes, colours: dict[int, int]) -> tuple[np.ndarray, bool] | None:
    """unfilter_grey's (map, same) of an 8-bit, non-interlaced PNG of one of `colours` (colour
    type -> bytes per pixel) whose rows are filtered with None or Sub; None for any other."""
    width, height = int.from_bytes(header[0:4], "big"), int.from_bytes(header[4:8], "big")
    depth, colour, compression, filtering, interlace = header[8:13]
    samples = colours.get(colour)
    if (depth != 8 or samples is None or compression or filtering or interlace or not 0 < width * height
            or width * height > _PLAIN_MAX_PIXELS):
        return None
    raw = _inflate(compressed, height * (1 + width * samples))
    if raw is None:
        return None
    stream = np.frombuffer(raw, np.uint8)
    if int(stream[::1 + width * samples].max()) > 1:  # a row filtered Up, Average or Paeth: left to the full decoder
        return None
    return unfilter_stream(stream, height, width, samples)


def _decode_plain_png(data: bytes) -> np.ndarray | None:
    """The (H, W) map of an 8-bit grey, or grey-in-RGB(A), non-interlaced PNG whose rows are
    filtered with None or Sub (as OpenCV writes them), as OpenCV decodes it; None for any
    other PNG (or RGB whose channels differ), which goes to OpenCV instead.

    A PNG row is deflated after a filter byte; Sub stores each byte minus the byte one pixel
    to its left, so a row is the running sum (mod 256) of its bytes, channel by channel.
    Channels equal before the filter are equal after it and back, so grey-in-RGB is checked
    on the filtered bytes and only one channel is summed. check_png has checked the chunks.
    """
    chunks = _plain_chunks(data, _PLAIN_CHUNKS)
    if chunks is None:
        return None
    decoded = _unfiltered(chunks[0], chunks[2], _SAMPLES)
    if decoded is None:
        return None
    image, same = decoded
    return image if same else None


# A mask's chunks decoded here: what OpenCV (grey) and Pillow (palette) write; any other goes to Pillow.
_MASK_CHUNKS = frozenset({b"IHDR", b"PLTE", b"IDAT", b"IEND"})


def plain_png_samples(data: bytes) -> tuple[np.ndarray, np.ndarray | None] | None:
    """(samples, palette) of an 8-bit grey PNG (palette None) or an 8-bit palette PNG (its
    (N, 3) uint8 colours, every sample below N), non-interlaced and filtered with None or Sub,
    as Pillow decodes it: 0.9 ms a full-HD instance mask against Pillow's 7.5 ms. None for any
    other PNG, or without libdeflate: Pillow's to read. `data` must have passed check_png."""
    if _libdeflate is None:
        return None
    chunks = _plain_chunks(data, _MASK_CHUNKS)
    if chunks is None:
        return None
    header, palette, compressed = chunks
    if (header[9] == 3) != (palette is not None):  # a palette exactly where the colour type is one
        return None
    if palette is not None and not (0 < len(palette) <= 768 and len(palette) % 3 == 0):
        return None
    decoded = _unfiltered(header, compressed, {0: 1, 3: 1})
    if decoded is None:
        return None
    samples = decoded[0]
    if palette is None:
        return samples, None
    colours = np.frombuffer(palette, np.uint8).reshape(-1, 3)
    if int(samples.max()) >= len(colours):  # an index past the palette: Pillow's to say what it is
        return None
    return samples, colours


def png_size(path: Path) -> tuple[int, int] | None:
    """(width, height) from the header of a PNG that passes check_png, or None (missing, not a
    regular file, broken, or a size no map has): loading it then says what is wrong."""
    try:
        data = read_bytes(path, missing_ok=True, limit=MAP)
        if data is None:
            return None
        check_png(data, path)
    except InputError:
        return None
    width, height = int.from_bytes(data[16:20], "big"), int.from_bytes(data[20:24], "big")
    if data[12:16] != b"IHDR" or not (0 < width < 1 << 31 and 0 < height < 1 << 31):
        return None
    return width, height


# The most pixels a map image may claim: 8192 x 8192, about 50 times a CULane or TuSimple map.
# Checked on the header before anything is inflated, so a small file that claims a huge image
# (a decompression bomb, or a header OpenCV's own cap turns into an exception) is one line.
MAX_MAP_PIXELS = 1 << 26


def _checked_plain(path: Path, data: bytes) -> np.ndarray | None:
    """check_png, the pixel cap on the header, and the plain PNG's map (None: not plain)."""
    check_png(data, path)
    if data[12:16] == b"IHDR":
        width, height = int.from_bytes(data[16:20], "big"), int.from_bytes(data[20:24], "big")
        if width * height > MAX_MAP_PIXELS:
            raise InputError(path, f"its header claims {width}x{height} pixels; maps of more than "
                                   f"{MAX_MAP_PIXELS:,} pixels are refused (8192 x 8192)")
    # Without libdeflate, zlib would inflate no faster than OpenCV decodes the whole PNG.
    return _decode_plain_png(data) if _libdeflate is not None else None


def read_grey_png(path: Path) -> np.ndarray:
    """A PNG as cv2.imread(path, IMREAD_GRAYSCALE) gives it, (H, W) uint8 (colour weighted to
    grey, 16 bits cut to 8, as OpenCV does): how LLAMAS's evaluation reads its probability maps.
    An InputError naming the file when it is missing, broken or too large."""
    data = read_bytes(path, limit=MAP)
    assert data is not None
    plain = _checked_plain(path, data)
    if plain is not None:  # grey, or RGB(A) whose channels agree: the grey OpenCV's weights give too
        return plain
    import cv2  # only for what the plain path refuses: importing it took 22 ms of every run's start

    try:
        image = cv2.imdecode(np.frombuffer(data, np.uint8), cv2.IMREAD_GRAYSCALE)
    except cv2.error as error:
        raise InputError(path, f"not a readable image ({str(error).strip().splitlines()[-1]})") from None
    if image is None:
        raise InputError(path, "not a readable image (truncated or not a PNG?)")
    return image


def _read_png(path: Path, data: bytes) -> np.ndarray:
    plain = _checked_plain(path, data)
    if plain is not None:
        return plain
    import cv2  # as in read_grey_png

    try:
        image = cv2.imdecode(np.frombuffer(data, np.uint8), cv2.IMREAD_UNCHANGED)
    except cv2.error as error:  # OpenCV refuses what libpng would not decode sensibly
        raise InputError(path, f"not a readable image ({str(error).strip().splitlines()[-1]})") from None
    if image is None:
        raise InputError(path, "not a readable image (truncated or not a PNG?)")
    if image.dtype != np.uint8:
        raise InputError(path, f"expected an 8-bit greyscale map, got {image.dtype}")
    if image.ndim == 3:
        channels = image.shape[2]
        if channels in (3, 4) and (image[..., 0] == image[..., 1]).all() and (image[..., 1] == image[..., 2]).all():
            return np.ascontiguousarray(image[..., 0])
        raise InputError(path, f"expected a greyscale map, got {channels} colour channels")
    return image


def load_scnn_png(stem: Path, config: MapsConfig) -> FrameMaps:
    """Stack the per-channel PNGs of one frame; missing PNGs of absent lanes are zeros."""
    pngs, exist_path = scnn_png_paths(stem, config.lane_channels)
    exist_data = read_bytes(exist_path, missing_ok=True)
    existence = None if exist_data is None else read_existence(exist_path, config, exist_data)
    maps: list[np.ndarray | None] = []
    for channel, path in enumerate(pngs):
        data = read_bytes(path, missing_ok=True, limit=MAP)
        if data is not None:
            maps.append(_read_png(path, data))
        elif existence is not None and existence[channel] <= 0:
            maps.append(None)
        else:
            reason = ("missing" if existence is None
                      else f"missing although {exist_path.name} says lane {channel + 1} exists")
            raise InputError(path, f"probability map {reason}")
    shapes = {m.shape for m in maps if m is not None}
    if len(shapes) > 1:
        raise InputError(stem.with_name(stem.name + "_*_avg.png"), f"channel maps differ in size: {sorted(shapes)}")
    shape = shapes.pop() if shapes else (config.height, config.width)
    stack = np.zeros((config.lane_channels,) + shape, np.uint8)
    for channel, image in enumerate(maps):
        if image is not None:
            stack[channel] = image
    return FrameMaps(probabilities=stack, existence=existence)


def _scnn_png_files(stem: Path, channels: int) -> list[Path]:
    pngs, exist = scnn_png_paths(stem, channels)
    return [pngs[0], exist] + pngs[1:]


# The existence file must be there; the PNGs of absent lanes may be missing.
def _scnn_pngs(stem: Path, channels: int) -> list[Path]:
    return scnn_png_paths(stem, channels)[0]


SCNN_PNG = MapFormat("scnn-png", ".exist.txt", load_scnn_png, images=_scnn_pngs, files=_scnn_png_files,
                     kernel_groups=("maps",))
