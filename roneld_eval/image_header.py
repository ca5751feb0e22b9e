"""An image's size from its file's first bytes (JPEG or PNG), without decoding it: what the
scorers that draw each image at its own size need of the dataset's images."""

from __future__ import annotations

# Where a JPEG's frame header lies: after its APPn segments (EXIF thumbnails included), within this.
HEADER_BYTES = 1 << 20


def png_header(data: bytes) -> tuple[int, int] | None:
    if len(data) < 24 or data[12:16] != b"IHDR":
        return None
    return int.from_bytes(data[16:20], "big"), int.from_bytes(data[20:24], "big")


def jpeg_header(data: bytes) -> tuple[int, int] | None:
    """The size in a JPEG's start-of-frame segment (SOF0..SOF15 but DHT, JPG, DAC)."""
    if not data.startswith(b"\xff\xd8"):
        return None
    at = 2
    while at + 4 <= len(data):
        if data[at] != 0xFF:
            return None
        marker = data[at + 1]
        if marker == 0xFF:  # fill byte
            at += 1
            continue
        if marker in (0x01, *range(0xD0, 0xD8)):  # segments without a length
            at += 2
            continue
        length = int.from_bytes(data[at + 2:at + 4], "big")
        if 0xC0 <= marker <= 0xCF and marker not in (0xC4, 0xC8, 0xCC):
            if at + 9 > len(data):
                return None
            return int.from_bytes(data[at + 7:at + 9], "big"), int.from_bytes(data[at + 5:at + 7], "big")
        if length < 2:
            return None
        at += 2 + length
    return None


def header_size(data: bytes) -> tuple[int, int] | None:
    """(width, height) of a JPEG or PNG from its first bytes; None if neither can be read."""
    return png_header(data) if data.startswith(b"\x89PNG\r\n\x1a\n") else jpeg_header(data)


def image_file_size(path) -> tuple[int, int]:
    """(width, height) of the image at `path`, from its header: an InputError naming the file
    when it is not a readable regular file or not a JPEG or PNG."""
    from .errors import InputError
    from .lanes_io import check_regular_file

    check_regular_file(path, "image not found")
    try:
        with open(path, "rb") as handle:
            size = header_size(handle.read(HEADER_BYTES))
    except OSError as error:
        raise InputError(path, f"cannot read: {error.strerror}") from None
    if size is None:
        raise InputError(path, "not a JPEG or PNG whose size can be read from its header")
    return size

