"""CULane ground truth drawn once: the label lanes of a list of frames as the official evaluator
draws them (metrics.raster.LaneRuns, run slots per row), kept on disk by content and reused by
every later `score culane` of the same frames, labels and protocol, whatever the methods.

The key is a SHA-256 of this version, the image size, the lane width and, frame by frame in
order, each frame's name and its label file's bytes: an edited label, another list or width is
another key, never a stale hit. An entry is a folder of plain .npy arrays (no pickles) with a
keyed checksum (HMAC-SHA256, the per-user secret of roneld_eval.secret_key) over their sizes and
digests; it is checked before use, field by field, and one that fails is drawn again with a note.
The sizes have a checksum of their own, checked before any array is opened: a file that is not
a regular file of the size written (a FIFO, a link to /dev/zero, a huge sparse file) is refused
unread. The newest few entries are kept (`MAX_ENTRIES`) in ~/.cache/roneld-eval/truth
($XDG_CACHE_HOME honoured); RONELD_EVAL_TRUTH_CACHE=DIR keeps them in DIR/roneld-eval-truth, or
is 0 to neither read nor write. Either folder is created and marked by the cache (CACHEDIR.TAG);
one without the mark that holds anything but entries is not used, and only entries of the
cache's own shape are ever removed, so a folder given by mistake loses nothing.
"""
from __future__ import annotations

import hashlib
import hmac
import contextlib
import errno
import json
import os
import re
import shutil
import stat
import tempfile
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Callable, Sequence

import numpy as np

from .signals import deferred_signals

if TYPE_CHECKING:
    from .metrics.raster import LaneRuns, MaskSet

FORMAT = 2  # 2: the arrays' sizes signed, entries in a marked folder
MAX_ENTRIES = 4
ARRAYS = ("n_gt", "lane_start", "meta", "row_start", "slots", "lo", "hi")
MAC_NAME = "mac.json"
ENTRY_FILES = frozenset([f"{name}.npy" for name in ARRAYS] + [MAC_NAME])
RUN_DTYPE = np.int16  # run bounds are pixel columns of the image (CULane's 1640): half the int32 bytes
FOLDER_NAME = "roneld-eval-truth"  # inside the folder RONELD_EVAL_TRUTH_CACHE names
MARKER_NAME = "CACHEDIR.TAG"  # https://bford.info/cachedir/: backup tools skip the folder, and it is ours
MARKER = (b"Signature: 8a477f597d28d172789f06886806bc55\n"
          b"# This file is a cache directory tag created by roneld-eval (its ground-truth cache).\n"
          b"# For information about cache directory tags see https://bford.info/cachedir/\n")
_ENTRY_NAME = re.compile(r"[0-9a-f]{64}")  # a key
_MAC_JSON_BYTES = 4096  # what save writes is some 300 bytes
_NOT_OURS = "it holds files this cache did not write"


def enabled() -> bool:
    return os.environ.get("RONELD_EVAL_TRUTH_CACHE", "") != "0"


def cache_root() -> Path:
    """The folder the entries are kept in: DIR/roneld-eval-truth for RONELD_EVAL_TRUTH_CACHE=DIR
    (a folder of the cache's own inside whatever folder is given), else the user's cache folder."""
    chosen = os.environ.get("RONELD_EVAL_TRUTH_CACHE", "")
    if chosen and chosen != "0":
        return Path(chosen) / FOLDER_NAME
    from .secret_key import cache_home

    return cache_home() / "truth"


def truth_key(root: Path, relpaths: Sequence[str], width: int, height: int, lane_width: int,
              labels_path: Callable[[Path, str], Path]) -> str:
    """The content key of these frames' ground truth (each label file read once, as bytes)."""
    from .lanes_io import read_bytes
    from .version import __version__

    hasher = hashlib.sha256(json.dumps([FORMAT, __version__, width, height, lane_width]).encode())
    for relpath in relpaths:
        data = read_bytes(labels_path(root, relpath), missing_ok=True)
        hasher.update(relpath.encode("utf-8", "surrogateescape") + b"\0")
        hasher.update(b"missing\0" if data is None else len(data).to_bytes(8, "little") + data)
    return hasher.hexdigest()


@dataclass(frozen=True)
class TruthRuns:
    """The ground truth of frames in order, as LaneRuns per frame (arrays end to end)."""

    n_gt: np.ndarray  # (F,) lanes of each frame
    lane_start: np.ndarray  # (F + 1,) each frame's first row of meta
    meta: np.ndarray  # (L, 7) LaneRuns.meta rows, `first` counted within the frame's rows
    row_start: np.ndarray  # (F + 1,) each frame's first run slot in the flat lo and hi (rows x slots before it)
    slots: np.ndarray  # (F,) run slots per row of each frame
    lo: np.ndarray  # (sum of rows x slots,) run starts, flat
    hi: np.ndarray

    def __len__(self) -> int:
        return len(self.n_gt)

    def frame(self, k: int) -> tuple[int, LaneRuns]:
        """Frame k's (number of lanes, LaneRuns), as official_masks draws them."""
        from .metrics.raster import LaneRuns

        meta = np.array(self.meta[self.lane_start[k]:self.lane_start[k + 1]], np.int64)
        first, end, slots = int(self.row_start[k]), int(self.row_start[k + 1]), int(self.slots[k])
        shape = ((end - first) // slots if slots else 0, slots)
        lo = np.array(self.lo[first:end], np.int64).reshape(shape)
        hi = np.array(self.hi[first:end], np.int64).reshape(shape)
        return int(self.n_gt[k]), LaneRuns(meta, lo, hi)



def joined(parts: Sequence[TruthRuns]) -> TruthRuns:
    """Consecutive frames' parts as one."""
    def offsets(name: str) -> np.ndarray:
        out, base = [np.zeros(1, np.int64)], 0
        for part in parts:
            starts = getattr(part, name)
            out.append(starts[1:] + base)
            base += int(starts[-1])
        return np.concatenate(out)

    return TruthRuns(np.concatenate([p.n_gt for p in parts] or [np.zeros(0, np.int64)]), offsets("lane_start"),
                     np.concatenate([p.meta for p in parts] or [np.zeros((0, 7), np.int64)]), offsets("row_start"),
                     np.concatenate([p.slots for p in parts] or [np.zeros(0, np.int64)]),
                     np.concatenate([p.lo for p in parts] or [np.zeros(0, RUN_DTYPE)]),
                     np.concatenate([p.hi for p in parts] or [np.zeros(0, RUN_DTYPE)]))


def from_frames(frames: Sequence[tuple[int, MaskSet | None]]) -> TruthRuns:
    """(number of lanes, LaneRuns or None for a frame without lanes) per frame, end to end."""
    from .metrics.raster import LaneRuns

    n_gt = np.array([n for n, _ in frames], np.int64)
    metas, los, his, lane_counts, row_counts, slots = [], [], [], [], [], []
    for _, runs in frames:
        if runs is None:  # a frame without lanes
            lane_counts.append(0)
            row_counts.append(0)
            slots.append(0)
            continue
        if not isinstance(runs, LaneRuns):
            raise TypeError("the ground truth is cached as official_masks draws it: LaneRuns")
        metas.append(runs.meta)
        los.append(runs.lo.reshape(-1))
        his.append(runs.hi.reshape(-1))
        lane_counts.append(len(runs.meta))
        row_counts.append(runs.lo.size)
        slots.append(runs.lo.shape[1])
    lo = np.concatenate(los) if los else np.zeros(0, np.int64)
    hi = np.concatenate(his) if his else np.zeros(0, np.int64)
    if lo.size and (lo.min() < np.iinfo(RUN_DTYPE).min or hi.max() > np.iinfo(RUN_DTYPE).max):
        raise OverflowError("run bounds beyond int16")
    return TruthRuns(n_gt, np.concatenate([[0], np.cumsum(lane_counts)]).astype(np.int64),
                     np.concatenate(metas).astype(np.int64) if metas else np.zeros((0, 7), np.int64),
                     np.concatenate([[0], np.cumsum(row_counts)]).astype(np.int64), np.array(slots, np.int64),
                     lo.astype(RUN_DTYPE), hi.astype(RUN_DTYPE))


def _open_regular(path: Path) -> tuple[int, int]:
    """(descriptor, size) of a regular file, opened without following a link and without
    blocking (a FIFO must not stall the command); ValueError saying what it is otherwise."""
    try:
        descriptor = os.open(path, os.O_RDONLY | os.O_NONBLOCK | os.O_NOFOLLOW | getattr(os, "O_CLOEXEC", 0))
    except OSError as error:
        if error.errno == errno.ELOOP:
            raise ValueError(f"{path.name} is a link") from None
        raise ValueError(f"{path.name}: {error.strerror or error}") from None
    try:
        info = os.fstat(descriptor)
    except OSError as error:
        os.close(descriptor)
        raise ValueError(f"{path.name}: {error.strerror or error}") from None
    if not stat.S_ISREG(info.st_mode):
        os.close(descriptor)
        raise ValueError(f"{path.name} is not a regular file")
    return descriptor, info.st_size


def _read_small(path: Path, most: int) -> bytes:
    """A small regular file of the cache's own (mac.json, the marker), refused unread when larger."""
    descriptor, size = _open_regular(path)
    with os.fdopen(descriptor, "rb") as handle:
        if size > most:
            raise ValueError(f"{path.name} is too large ({size:,} bytes)")
        return handle.read(most + 1)


def _digest(path: Path, size: int) -> str:
    """SHA-256 of an array file, which must be a regular file of exactly `size` bytes (checked
    before it is read, so that no more than what was written is ever read)."""
    descriptor, found = _open_regular(path)
    with os.fdopen(descriptor, "rb") as handle:
        if found != size:
            raise ValueError(f"{path.name} has {found:,} bytes, not the {size:,} written")
        hasher, left = hashlib.sha256(), size
        while left:  # never past the size written, should the file grow meanwhile
            block = handle.read(min(left, 1 << 20))
            if not block:
                break
            hasher.update(block)
            left -= len(block)
    return hasher.hexdigest()


def _sizes_mac(sizes: dict, secret: bytes) -> str:
    return hmac.new(secret, json.dumps(sizes, sort_keys=True).encode(), hashlib.sha256).hexdigest()


def _arrays_mac(folder: Path, sizes: dict, secret: bytes) -> str:
    digests = [_digest(folder / f"{name}.npy", sizes[name]) for name in ARRAYS]
    return hmac.new(secret, "\n".join(digests).encode(), hashlib.sha256).hexdigest()


def _signature(folder: Path, secret: bytes) -> dict:
    """What mac.json holds for the arrays just written into `folder`."""
    sizes = {name: os.stat(folder / f"{name}.npy").st_size for name in ARRAYS}
    return {"sizes": sizes, "sizes_mac": _sizes_mac(sizes, secret), "mac": _arrays_mac(folder, sizes, secret)}


def _verify(folder: Path, secret: bytes) -> None:
    """ValueError unless the entry's arrays are the ones this user's key signed: the sizes'
    checksum first, then each file's type and size, and only then their bytes."""
    recorded = json.loads(_read_small(folder / MAC_NAME, _MAC_JSON_BYTES))
    if not isinstance(recorded, dict) or not isinstance(recorded.get("sizes"), dict):
        raise ValueError("not a checksum of this cache")
    sizes = recorded["sizes"]
    if set(sizes) != set(ARRAYS) or not all(type(size) is int and size >= 0 for size in sizes.values()):
        raise ValueError("not a checksum of this cache")
    if not hmac.compare_digest(str(recorded.get("sizes_mac")), _sizes_mac(sizes, secret)):
        raise ValueError("its checksum does not match its arrays")
    if not hmac.compare_digest(str(recorded.get("mac")), _arrays_mac(folder, sizes, secret)):
        raise ValueError("its checksum does not match its arrays")


def open_entry(folder: str | Path) -> TruthRuns:
    """An entry's arrays, mapped rather than read (a worker takes the frames of its chunk); the
    entry was checked by `load` in the command's process."""
    return TruthRuns(**{name: _array(Path(folder) / f"{name}.npy") for name in ARRAYS})


def _array(path: Path) -> np.ndarray:
    if not stat.S_ISREG(os.lstat(path).st_mode):  # swapped since it was checked: never a FIFO's open
        raise ValueError(f"{path.name} is not a regular file")
    try:
        return np.load(path, mmap_mode="r", allow_pickle=False)
    except ValueError:  # an empty array has nothing to map
        return np.load(path, allow_pickle=False)


# ---- the folder of entries: created and marked by the cache, nothing else in it touched ----------


def _marked(folder: Path) -> bool:
    try:
        return _read_small(folder / MARKER_NAME, len(MARKER)) == MARKER
    except ValueError:
        return False


def own_entry(path: Path) -> bool:
    """Whether `path` has the shape of an entry this cache writes: a folder (not a link) named by
    a key, holding nothing but files of the names it writes."""
    try:
        if not _ENTRY_NAME.fullmatch(path.name) or not stat.S_ISDIR(os.lstat(path).st_mode):
            return False
        return all(child.name in ENTRY_FILES and not stat.S_ISDIR(os.lstat(child).st_mode)
                   for child in path.iterdir())
    except OSError:
        return False


def _remove_entry(path: Path) -> None:
    """An entry of the cache's own shape, file by file (never a tree walk): anything else is left."""
    if not own_entry(path):
        return
    with contextlib.suppress(OSError):
        for name in ENTRY_FILES:
            with contextlib.suppress(FileNotFoundError):
                os.unlink(path / name)
        path.rmdir()


def _adoptable(folder: Path) -> bool:
    """An unmarked folder the cache may mark as its own: empty (created, then cut short before the
    marker), or holding only entries (the default folder of a version before the marker)."""
    return all(child.name == MARKER_NAME or child.name.startswith(f".{MARKER_NAME}.") or own_entry(child)
               for child in folder.iterdir())


def _write_marker(folder: Path) -> None:
    temporary = folder / f".{MARKER_NAME}.{os.getpid()}.tmp"
    try:
        temporary.write_bytes(MARKER)
        os.replace(temporary, folder / MARKER_NAME)
    finally:
        with contextlib.suppress(OSError):
            temporary.unlink()


def _entries_folder(create: bool) -> Path | None:
    """The cache's marked folder (created and marked when `create`), else None: absent, or not
    the cache's (ValueError saying why, when `create`)."""
    folder = cache_root()
    if create:
        folder.mkdir(parents=True, exist_ok=True)
    if folder.is_symlink() or not folder.is_dir():
        if create:
            raise ValueError("not a folder")
        return None
    if _marked(folder):
        return folder
    if create and _adoptable(folder):
        _write_marker(folder)
        return folder
    if create:
        raise ValueError(_NOT_OURS)
    return None


def load(key: str, n_frames: int, width: int, height: int, note: Callable[[str], None]) -> Path | None:
    """The folder of the entry of `key`, checked (None when absent, or with a note when it fails
    a check: it is removed if it has the shape of an entry of this cache, else left alone)."""
    from .secret_key import secret_key

    entries = _entries_folder(create=False) if enabled() else None
    if entries is None or not os.path.lexists(entries / key):
        return None
    folder = entries / key
    try:
        if folder.is_symlink() or not folder.is_dir():
            raise ValueError("not a folder")
        _verify(folder, secret_key(note))
        _check(open_entry(folder), n_frames, width, height)
    except (OSError, ValueError, KeyError, TypeError, RecursionError) as error:
        note(f"note: {folder}: the cached ground truth is not used ({error}); drawn again")
        _remove_entry(folder)
        return None
    os.utime(folder)  # the newest entries are kept
    return folder


def _check(truth: TruthRuns, n_frames: int, width: int, height: int) -> None:
    """Every array's type, shape and range, as from_frames writes them."""
    _check_layout(truth, n_frames)
    lanes, runs = _check_offsets(truth)
    frame_rows = np.repeat(runs // np.maximum(truth.slots, 1), lanes)
    y0, first, count, area, drawn, x0, x1 = (truth.meta[:, c] for c in range(7))
    if ((first < 0) | (count < 0) | (first + count > frame_rows) | (y0 < 0) | (y0 + count > height)
            | (area < 0) | ~np.isin(drawn, (0, 1)) | (x0 < 0) | (x1 < x0) | (x1 > width)).any():
        raise ValueError("lanes outside their frame")
    if truth.lo.size and (truth.lo.min() < 0 or truth.hi.max() > width):
        raise ValueError("runs outside the image")


def _check_layout(truth: TruthRuns, n_frames: int) -> None:
    """The arrays' types and shapes for `n_frames` frames."""
    counters = (truth.n_gt, truth.lane_start, truth.meta, truth.row_start, truth.slots)
    if not all(a.dtype == np.int64 for a in counters) or truth.lo.dtype != RUN_DTYPE or truth.hi.dtype != RUN_DTYPE:
        raise ValueError("arrays of other types than this version writes")
    shapes = [(truth.n_gt, (n_frames,)), (truth.slots, (n_frames,)), (truth.lane_start, (n_frames + 1,)),
              (truth.row_start, (n_frames + 1,))]
    if (any(array.shape != wanted for array, wanted in shapes) or truth.meta.ndim != 2
            or truth.meta.shape[1] != 7 or truth.lo.shape != truth.hi.shape or truth.lo.ndim != 1):
        raise ValueError(f"arrays of other shapes than {n_frames:,} frames need")


def _check_offsets(truth: TruthRuns) -> tuple[np.ndarray, np.ndarray]:
    """Each frame's lane count and run count, from offsets that must add up."""
    lane_start, row_start, slots = truth.lane_start, truth.row_start, truth.slots
    lanes, runs = np.diff(lane_start), np.diff(row_start)
    if (lane_start[0] != 0 or row_start[0] != 0 or (lanes < 0).any() or (runs < 0).any()
            or lane_start[-1] != len(truth.meta) or row_start[-1] != truth.lo.size or (slots < 0).any()
            or (lanes != truth.n_gt).any() or ((runs > 0) & (slots == 0)).any()
            or (runs % np.maximum(slots, 1)).any()):
        raise ValueError("offsets that do not add up")
    return lanes, runs


def save(key: str, truth: TruthRuns, note: Callable[[str], None]) -> None:
    """Write the entry of `key` (atomically: a folder renamed into place), the oldest entries
    beyond MAX_ENTRIES removed (only those of the cache's own shape, in its marked folder). A
    cache that cannot be written is a note, never an error."""
    from .secret_key import secret_key

    if not enabled():
        return
    root = cache_root()
    try:
        entries = _entries_folder(create=True)
        assert entries is not None
        staging: Path | None = None
        try:
            with deferred_signals():  # made and known together: a signal between left it behind
                staging = Path(tempfile.mkdtemp(prefix=f".{key[:16]}.", dir=entries))
            for name in ARRAYS:
                np.save(staging / f"{name}.npy", np.ascontiguousarray(getattr(truth, name)), allow_pickle=False)
            (staging / MAC_NAME).write_text(json.dumps(_signature(staging, secret_key(note))), encoding="utf-8")
            try:
                os.rename(staging, entries / key)
            except OSError:  # another command wrote the same entry first
                pass
        finally:
            if staging is not None:
                shutil.rmtree(staging, ignore_errors=True)
        kept = sorted((path for path in entries.iterdir() if own_entry(path)),
                      key=lambda path: os.lstat(path).st_mtime_ns, reverse=True)
        for old in kept[MAX_ENTRIES:]:
            _remove_entry(old)
    except OSError as error:
        note(f"note: {root}: the ground truth cannot be cached ({error.strerror or error}); it is drawn each time")
    except ValueError as error:
        note(f"note: {root}: not used for the ground-truth cache ({error}); the ground truth is drawn each time")
