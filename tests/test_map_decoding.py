"""Map files decoded without OpenCV or np.load (libdeflate and numpy) give the same arrays and
the same errors; whatever the short paths do not handle goes to OpenCV or np.load as before."""

import io
import struct
import zipfile
import zlib

import cv2
import numpy as np
import pytest

from roneld_eval.config import EvalConfig
from roneld_eval.errors import InputError
from roneld_eval.maps import npy, scnn_png

pytestmark = pytest.mark.skipif(scnn_png._libdeflate is None, reason="deflate (libdeflate) is not installed")
MAPS = EvalConfig.preset("scnn-culane").maps


def chunk(kind: bytes, body: bytes) -> bytes:
    return struct.pack(">I", len(body)) + kind + body + struct.pack(">I", zlib.crc32(kind + body))


def png(image: np.ndarray, filters, colour: int | None = None, depth: int = 8, interlace: int = 0,
        extra: bytes = b"", idat_parts: int = 1) -> bytes:
    """A PNG of an (H, W) or (H, W, C) uint8 image, row y filtered with filters[y % len] (0..4),
    written by the book (PNG specification, section 9)."""
    pixels = image.reshape(image.shape[0], image.shape[1], -1).astype(np.int64)
    height, width, samples = pixels.shape
    colour = {1: 0, 2: 4, 3: 2, 4: 6}[samples] if colour is None else colour
    rows, previous = [], np.zeros(width * samples, np.int64)
    for y in range(height):
        line = pixels[y].reshape(-1)
        left = np.concatenate([np.zeros(samples, np.int64), line[:-samples]])
        up_left = np.concatenate([np.zeros(samples, np.int64), previous[:-samples]])
        kind = filters[y % len(filters)]
        if kind == 0:
            out = line
        elif kind == 1:
            out = line - left
        elif kind == 2:
            out = line - previous
        elif kind == 3:
            out = line - (left + previous) // 2
        else:
            p = left + previous - up_left
            pa, pb, pc = np.abs(p - left), np.abs(p - previous), np.abs(p - up_left)
            out = line - np.where((pa <= pb) & (pa <= pc), left, np.where(pb <= pc, previous, up_left))
        rows.append(bytes([kind]) + (out % 256).astype(np.uint8).tobytes())
        previous = line
    stream = zlib.compress(b"".join(rows), 6)
    cut = [len(stream) * k // idat_parts for k in range(idat_parts + 1)]
    header = struct.pack(">IIBBBBB", width, height, depth, colour, 0, 0, interlace)
    return (b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", header) + extra
            + b"".join(chunk(b"IDAT", stream[a:b]) for a, b in zip(cut, cut[1:])) + chunk(b"IEND", b""))


def opencv(data: bytes) -> np.ndarray:
    image = cv2.imdecode(np.frombuffer(data, np.uint8), cv2.IMREAD_UNCHANGED)
    return np.ascontiguousarray(image[..., 0]) if image.ndim == 3 else image


def smooth_map(rng, height=37, width=53) -> np.ndarray:
    """A probability-map-like image: a blurred ridge, zeros, a few 255s."""
    image = np.zeros((height, width), np.float64)
    xs = rng.uniform(0, width, height).cumsum() % width
    for y, x in enumerate(xs):
        image[y] = 255 * np.exp(-((np.arange(width) - x) ** 2) / 18)
    image[rng.random((height, width)) < 0.02] = 255
    return np.rint(image).astype(np.uint8)


@pytest.mark.parametrize("filters", [[1], [0], [0, 1, 1], [1, 0]])
@pytest.mark.parametrize("samples", [1, 3, 4])
def test_plain_pngs_decode_as_opencv_decodes_them(filters, samples):
    rng = np.random.default_rng(samples * 10 + len(filters))
    grey = smooth_map(rng)
    image = grey if samples == 1 else np.stack([grey] * 3 + [rng.integers(0, 256, grey.shape, np.uint8)] *
                                               (samples - 3), axis=2)
    for parts in (1, 3):
        data = png(image, filters, idat_parts=parts)
        plain = scnn_png._decode_plain_png(data)
        assert plain is not None and plain.dtype == np.uint8 and plain.flags.c_contiguous
        np.testing.assert_array_equal(plain, opencv(data))
        np.testing.assert_array_equal(plain, grey)
        np.testing.assert_array_equal(scnn_png._read_png(None, data), grey)


def test_opencvs_own_files_and_the_real_clip_take_the_short_path(tmp_path, shared_data):
    rng = np.random.default_rng(7)
    for image in (smooth_map(rng, 288, 800), np.dstack([smooth_map(rng, 351, 976)] * 3)):
        path = tmp_path / "map.png"
        cv2.imwrite(str(path), image)
        data = path.read_bytes()
        np.testing.assert_array_equal(scnn_png._decode_plain_png(data), opencv(data))
    for path in sorted((shared_data / "culane-scnn-clip").glob("*_avg.png"))[:40]:
        data = path.read_bytes()
        plain = scnn_png._decode_plain_png(data)
        assert plain is not None
        np.testing.assert_array_equal(plain, opencv(data))


@pytest.mark.parametrize("case", ["up", "average", "paeth", "interlaced", "16 bit", "grey+alpha", "palette",
                                  "transparency", "gamma", "colours differ"])
def test_other_pngs_go_to_opencv(case):
    rng = np.random.default_rng(3)
    grey = smooth_map(rng)
    rgb = np.dstack([grey] * 3)
    data = {
        "up": lambda: png(grey, [1, 2]),
        "average": lambda: png(rgb, [3]),
        "paeth": lambda: png(grey, [4, 1]),
        "interlaced": lambda: png(grey, [0], interlace=1),
        "16 bit": lambda: png(grey.astype(np.uint8), [0], depth=16),
        "grey+alpha": lambda: png(np.dstack([grey, grey]), [1]),
        "palette": lambda: png(grey, [1], colour=3, extra=chunk(b"PLTE", bytes(range(256)) * 3)),
        "transparency": lambda: png(grey, [1], extra=chunk(b"tRNS", b"\x00\x00")),
        "gamma": lambda: png(grey, [1], extra=chunk(b"gAMA", struct.pack(">I", 45455))),
        "colours differ": lambda: png(np.dstack([grey, grey, 255 - grey]), [1]),
    }[case]()
    assert scnn_png._decode_plain_png(data) is None
    # and _read_png answers exactly as OpenCV's path did before
    try:
        expected = ("value", scnn_png._read_png(None, data).tobytes())
    except InputError as error:
        expected = ("error", str(error))
    saved = scnn_png._libdeflate
    scnn_png._libdeflate = None
    try:
        try:
            before = ("value", scnn_png._read_png(None, data).tobytes())
        except InputError as error:
            before = ("error", str(error))
    finally:
        scnn_png._libdeflate = saved
    assert expected == before
    if case == "colours differ":
        assert expected == ("error", "expected a greyscale map, got 3 colour channels")


def test_a_broken_stream_goes_to_opencv():
    grey = smooth_map(np.random.default_rng(4))
    good = png(grey, [1])
    start = good.index(b"IDAT") + 4
    body = bytearray(good[start:start + int.from_bytes(good[start - 8:start - 4], "big")])
    body[-1] ^= 0xFF  # the Adler-32 no longer matches; the chunk's CRC is made right again
    broken = good[:start] + bytes(body) + struct.pack(">I", zlib.crc32(b"IDAT" + bytes(body))) + good[
        start + len(body) + 4:]
    assert scnn_png._decode_plain_png(broken) is None
    short = png(grey[:, :-1], [1])  # a stream shorter than its header promises
    lying = short.replace(struct.pack(">I", grey.shape[1] - 1), struct.pack(">I", grey.shape[1]), 1)
    header_start = lying.index(b"IHDR")
    header = lying[header_start:header_start + 17]
    lying = lying[:header_start + 17] + struct.pack(">I", zlib.crc32(header)) + lying[header_start + 21:]
    assert scnn_png._decode_plain_png(lying) is None


# ---- .npz ---------------------------------------------------------------------------------------


def archives(tmp_path, rng) -> dict[str, object]:
    maps = rng.integers(0, 256, (4, 30, 50), np.uint8)
    exist = np.array([1, 1, 0, 1], np.float32)
    out = {}
    for name, save in (("stored", np.savez), ("deflated", np.savez_compressed)):
        path = tmp_path / f"{name}.npz"
        save(path, probs=maps, exist=exist)
        out[name] = path
    path = tmp_path / "float.npz"
    np.savez_compressed(path, probs=rng.random((4, 30, 50)).astype(np.float32))
    out["float"] = path
    path = tmp_path / "only.npz"
    np.savez(path, maps)
    out["only"] = path
    path = tmp_path / "fortran.npz"
    np.savez(path, probs=np.asfortranarray(maps))
    out["fortran"] = path
    path = tmp_path / "other.npz"
    np.savez(path, a=maps, b=maps)
    out["other"] = path
    path = tmp_path / "synth.npz"  # as roneld-eval synth writes it
    from roneld_eval.synth import _save_npz_deterministic

    _save_npz_deterministic(path, probs=maps, exist=exist)
    out["synth"] = path
    data = out["deflated"].read_bytes()
    for name, broken in (("truncated", data[:len(data) // 2]), ("empty", b""), ("not a zip", b"hello" * 30)):
        path = tmp_path / f"{name}.npz"
        path.write_bytes(broken)
        out[name] = path
    corrupt = bytearray(out["stored"].read_bytes())
    corrupt[200] ^= 0xFF  # inside the stored maps: the CRC-32 no longer matches
    path = tmp_path / "crc.npz"
    path.write_bytes(bytes(corrupt))
    out["crc"] = path
    return out


def outcome(path):
    try:
        maps = npy.load_npz(path, MAPS)
    except InputError as error:
        return "error", str(error)
    existence = None if maps.existence is None else (maps.existence.dtype.str, maps.existence.tolist())
    return maps.probabilities.dtype.str, maps.probabilities.shape, maps.probabilities.tobytes(), existence


def test_npz_reads_as_np_load_reads_it(tmp_path, monkeypatch):
    paths = archives(tmp_path, np.random.default_rng(1))
    fast = {name: outcome(path) for name, path in paths.items()}
    assert npy._read_plain_npz(paths["deflated"], MAPS) is not None
    assert npy._read_plain_npz(paths["synth"], MAPS) is not None
    assert npy._read_plain_npz(paths["crc"], MAPS) is None
    monkeypatch.setattr(npy, "_libdeflate", None)
    slow = {name: outcome(path) for name, path in paths.items()}
    assert fast == slow
    assert fast["crc"][0] == "error" and fast["truncated"][0] == "error"


def test_npz_members_are_checked_like_zipfile_checks_them(tmp_path):
    stream = io.BytesIO()
    with zipfile.ZipFile(stream, "w", zipfile.ZIP_BZIP2) as archive:  # another compression: np.load's
        buffer = io.BytesIO()
        np.lib.format.write_array(buffer, np.zeros((4, 3, 5), np.uint8))
        archive.writestr("probs.npy", buffer.getvalue())
    path = tmp_path / "bzip.npz"
    path.write_bytes(stream.getvalue())
    assert npy._read_plain_npz(path, MAPS) is None
    assert npy.load_npz(path, MAPS).probabilities.shape == (4, 3, 5)


def test_an_archive_or_zip_garbage_under_a_npy_name_is_an_input_error(tmp_path):
    np.savez(tmp_path / "maps.npz", probs=np.zeros((4, 3, 5), np.uint8))
    (tmp_path / "archive.npy").write_bytes((tmp_path / "maps.npz").read_bytes())
    (tmp_path / "garbage.npy").write_bytes(b"PK\x03\x04" + bytes(60))
    with pytest.raises(InputError, match="is an .npz archive, not a .npy array"):
        npy.load_npy(tmp_path / "archive.npy", MAPS)
    with pytest.raises(InputError, match="not a readable .npy array"):
        npy.load_npy(tmp_path / "garbage.npy", MAPS)


@pytest.mark.parametrize("case", ["IHDR after IDAT", "two IHDRs", "IDATs apart"])
def test_chunks_out_of_order_go_to_opencv(case):
    # libpng refuses these files; read here, they would give a map where OpenCV gives an error.
    grey = smooth_map(np.random.default_rng(5))
    good = png(grey, [1], idat_parts=2)
    header = good[8:8 + 25]
    first_idat = good.index(b"IDAT") - 4
    second_idat = good.index(b"IDAT", first_idat + 8) - 4
    text = chunk(b"tEXt", b"Comment\x00between")
    data = {
        "IHDR after IDAT": good[:8] + good[33:second_idat] + header + good[second_idat:],
        "two IHDRs": good[:8] + chunk(b"IHDR", struct.pack(">IIBBBBB", 9, 9, 8, 0, 0, 0, 0)) + good[8:],
        "IDATs apart": good[:second_idat] + text + good[second_idat:],
    }[case]
    assert scnn_png._decode_plain_png(data) is None
    assert scnn_png._decode_plain_png(good) is not None
