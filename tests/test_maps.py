"""Map loaders: one canonical (C, H, W) uint8 stack from every stored format."""

import numpy as np
import pytest

from roneld_eval.config import MapsConfig
from roneld_eval.errors import InputError
from roneld_eval.maps import load_maps, map_size, required_paths


def _maps(channels=4, height=6, width=8, seed=0):
    return np.random.default_rng(seed).integers(0, 256, (channels, height, width)).astype(np.uint8)


def test_npy_uint8_is_memory_mapped(tmp_path):
    maps = _maps()
    (tmp_path / "v").mkdir()
    np.save(tmp_path / "v" / "00000.npy", maps)
    loaded = load_maps(tmp_path, "v/00000.jpg", MapsConfig())
    assert _is_file_mapping(loaded.probabilities) and not loaded.probabilities.flags.writeable
    assert loaded.probabilities.dtype == np.uint8
    np.testing.assert_array_equal(loaded.probabilities, maps)
    assert loaded.existence is None


def _is_file_mapping(array) -> bool:
    import mmap

    base = array
    while isinstance(base, np.ndarray) and not isinstance(base, np.memmap):
        base = base.base
    if isinstance(base, memoryview):
        base = base.obj
    return isinstance(base, (np.memmap, mmap.mmap))


def test_unusual_npy_headers_load_too(tmp_path):
    maps = _maps()
    np.save(tmp_path / "f.npy", np.asfortranarray(maps))  # Fortran order: np.load's path
    np.testing.assert_array_equal(load_maps(tmp_path, "f.jpg", MapsConfig()).probabilities, maps)
    np.save(tmp_path / "g.npy", maps.astype(np.float32) / 255)
    np.testing.assert_array_equal(load_maps(tmp_path, "g.jpg", MapsConfig()).probabilities, maps)


def test_background_channel_is_dropped(tmp_path):
    maps = _maps(channels=5)
    np.save(tmp_path / "f.npy", maps)
    loaded = load_maps(tmp_path, "f.jpg", MapsConfig(background_channel=True))
    np.testing.assert_array_equal(loaded.probabilities, maps[1:])
    with pytest.raises(InputError, match="has 5 channels, expected 4 .*background_channel"):
        load_maps(tmp_path, "f.jpg", MapsConfig())


@pytest.mark.parametrize("dtype", [np.float16, np.float32, np.float64])
def test_float_maps_round_to_the_uint8_scale(tmp_path, dtype):
    levels = np.array([0.0, 0.5, 1.0, 0.3, 0.002, 0.998, 0.25, 0.75], dtype)
    probabilities = levels[None, None, :].repeat(4, 0).repeat(2, 1)
    np.save(tmp_path / "f.npy", probabilities)
    loaded = load_maps(tmp_path, "f.jpg", MapsConfig())
    expected = np.rint(probabilities.astype(np.float32) * 255).astype(np.uint8)
    np.testing.assert_array_equal(loaded.probabilities, expected)
    assert loaded.probabilities[0, 0, :3].tolist() == [0, 128, 255]


@pytest.mark.parametrize("array, problem", [
    (np.full((4, 3, 3), np.nan, np.float32), "NaN or infinite"),
    (np.full((4, 3, 3), 1.5, np.float32), r"\[0, 1\], found 1.5"),
    (np.zeros((4, 3, 3), np.int32), "dtype int32"),
    (np.zeros((3, 3), np.uint8), "shape"),
    (np.zeros((3, 3, 3), np.uint8), "has 3 channels"),
])
def test_bad_arrays(tmp_path, array, problem):
    np.save(tmp_path / "f.npy", array)
    with pytest.raises(InputError, match=problem) as caught:
        load_maps(tmp_path, "f.jpg", MapsConfig())
    assert str(caught.value).startswith(str(tmp_path / "f.npy"))


def test_truncated_and_foreign_files(tmp_path):
    np.save(tmp_path / "f.npy", _maps(height=50, width=50))
    data = (tmp_path / "f.npy").read_bytes()
    (tmp_path / "f.npy").write_bytes(data[: len(data) // 2])
    with pytest.raises(InputError, match="truncated or corrupt"):
        load_maps(tmp_path, "f.jpg", MapsConfig())
    (tmp_path / "f.npy").write_text("hello")
    with pytest.raises(InputError, match="not a .npy array .it does not start with numpy's magic bytes"):
        load_maps(tmp_path, "f.jpg", MapsConfig())


def test_npz_with_existence(tmp_path):
    maps = _maps()
    np.savez_compressed(tmp_path / "f.npz", probs=maps, exist=np.array([0, 1, 1, 0.2]))
    loaded = load_maps(tmp_path, "f.jpg", MapsConfig(format="npz"))
    np.testing.assert_array_equal(loaded.probabilities, maps)
    assert loaded.existence.tolist() == [0, 1, 1, 0.2]
    np.savez_compressed(tmp_path / "g.npz", other=maps, more=maps)
    with pytest.raises(InputError, match="no array named 'probs'"):
        load_maps(tmp_path, "g.jpg", MapsConfig(format="npz"))


def test_scnn_png_with_missing_absent_lane(tmp_path):
    import cv2

    maps = _maps()
    for k in (2, 3, 4):
        cv2.imwrite(str(tmp_path / f"00000_{k}_avg.png"), maps[k - 1])
    (tmp_path / "00000.exist.txt").write_text("0 1 1 1 ")
    loaded = load_maps(tmp_path, "00000.jpg", MapsConfig(format="scnn-png"))
    assert loaded.existence.tolist() == [0, 1, 1, 1]
    assert not loaded.probabilities[0].any()
    np.testing.assert_array_equal(loaded.probabilities[1:], maps[1:])
    (tmp_path / "00000.exist.txt").write_text("1 1 1 1")
    with pytest.raises(InputError, match="lane 1 exists"):
        load_maps(tmp_path, "00000.jpg", MapsConfig(format="scnn-png"))
    (tmp_path / "00000.exist.txt").write_text("1 1 1")
    with pytest.raises(InputError, match="existence has 3 values"):
        load_maps(tmp_path, "00000.jpg", MapsConfig(format="scnn-png"))
    (tmp_path / "00000.exist.txt").write_text("1 yes 1 1")
    with pytest.raises(InputError, match="'yes' is not a number"):
        load_maps(tmp_path, "00000.jpg", MapsConfig(format="scnn-png"))


def test_required_paths():
    assert [p.name for p in required_paths("m", "a/b/00000.jpg", MapsConfig())] == ["00000.npy"]
    assert [p.name for p in required_paths("m", "a/b/00000.jpg", MapsConfig(format="scnn-png"))] == ["00000.exist.txt"]


def test_real_clip_pngs(real_clip):
    loaded = load_maps(real_clip, "00000.jpg", MapsConfig(format="scnn-png", width=976, height=351))
    assert loaded.probabilities.shape == (4, 351, 976) and loaded.probabilities.dtype == np.uint8
    assert loaded.existence.tolist() == [0, 1, 1, 1]
    assert loaded.probabilities[1].max() > 200


def _write_pngs(folder, maps, exist="1 1 1 1", skip=()):
    import cv2

    folder.mkdir(parents=True, exist_ok=True)
    for k, image in enumerate(maps, start=1):
        if k not in skip:
            cv2.imwrite(str(folder / f"00000_{k}_avg.png"), image)
    (folder / "00000.exist.txt").write_text(exist)


def _size(maps) -> tuple[int, int]:
    return maps.width, maps.height


def test_map_size_reads_png_headers_as_load_maps_would_size_them(tmp_path):
    config = MapsConfig(format="scnn-png", width=8, height=6)
    _write_pngs(tmp_path / "a", _maps(height=5, width=7))
    assert map_size(tmp_path, "a/00000.jpg", config) == (7, 5) == _size(load_maps(tmp_path, "a/00000.jpg", config))
    # The first channel's PNG absent (its lane too): the next one's header.
    _write_pngs(tmp_path / "b", _maps(height=5, width=7), exist="0 1 1 1", skip=(1,))
    assert map_size(tmp_path, "b/00000.jpg", config) == (7, 5)
    # No PNG at all (no lane exists): zeros of the configured size, as load_maps gives them.
    _write_pngs(tmp_path / "c", _maps(), exist="0 0 0 0", skip=(1, 2, 3, 4))
    assert map_size(tmp_path, "c/00000.jpg", config) == (8, 6) == _size(load_maps(tmp_path, "c/00000.jpg", config))
    # One file is not a PNG: the size is another's (loading the frame reports the bad one) ...
    _write_pngs(tmp_path / "d", _maps(height=5, width=7))
    (tmp_path / "d" / "00000_1_avg.png").write_bytes(b"not a png at all, but long enough")
    assert map_size(tmp_path, "d/00000.jpg", config) == (7, 5)
    # ... none is: load_maps' own error.
    for k in range(2, 5):
        (tmp_path / "d" / f"00000_{k}_avg.png").write_bytes(b"\x89PNG")
    with pytest.raises(InputError, match="not a PNG"):
        map_size(tmp_path, "d/00000.jpg", config)


def test_map_size_of_other_formats_is_their_loaded_size(tmp_path):
    np.save(tmp_path / "00000.npy", _maps(height=5, width=7))
    assert map_size(tmp_path, "00000.jpg", MapsConfig()) == (7, 5)


def test_map_size_leaves_odd_pngs_to_load_maps(tmp_path):
    # A header claiming no rows, a FIFO: no size from them (the worker's load names the problem),
    # never a division by zero or a hang here.
    import os
    import struct
    import zlib

    config = MapsConfig(format="scnn-png", width=8, height=6)
    _write_pngs(tmp_path / "a", _maps(height=5, width=7))
    data = bytearray((tmp_path / "a" / "00000_1_avg.png").read_bytes())
    data[20:24] = struct.pack(">I", 0)
    data[29:33] = struct.pack(">I", zlib.crc32(bytes(data[12:29])))  # a consistent, but empty, header
    for k in range(1, 5):
        (tmp_path / "a" / f"00000_{k}_avg.png").write_bytes(bytes(data))
    with pytest.raises(InputError):
        map_size(tmp_path, "a/00000.jpg", config)
    if hasattr(os, "mkfifo"):
        _write_pngs(tmp_path / "b", _maps(height=5, width=7))
        (tmp_path / "b" / "00000_1_avg.png").unlink()
        os.mkfifo(tmp_path / "b" / "00000_1_avg.png")
        assert map_size(tmp_path, "b/00000.jpg", config) == (7, 5)


@pytest.mark.parametrize("fmt", ["npy", "npz"])
def test_an_array_of_python_objects_is_named_as_such(tmp_path, fmt):
    # np.load's own message advises allow_pickle, an option of the reader's code, not the user's.
    objects = np.array([{"lane": 1}], dtype=object)
    if fmt == "npy":
        np.save(tmp_path / "00000.npy", objects, allow_pickle=True)
    else:
        np.savez(tmp_path / "00000.npz", probs=objects)
    with pytest.raises(InputError, match="holds Python objects") as raised:
        load_maps(tmp_path, "00000.jpg", MapsConfig(format=fmt))
    assert "allow_pickle" not in str(raised.value)
