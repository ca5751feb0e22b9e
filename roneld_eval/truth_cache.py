"""CULane ground truth drawn once: the label lanes of a list of frames as the official evaluator
draws them (metrics.raster.LaneRuns, run slots per row), kept on disk by content and reused by
every later `score culane` of the same frames, labels and protocol, whatever the methods.

The key is a SHA-256 of this version, the image size, the lane width and, frame by frame in
order, each frame's name and its label file's bytes: an edited label, another list or width is
another key, never a stale hit. An entry is a folder of plain .npy arrays (no pickles) with a
keyed checksum (HMAC-SHA256, the per-user secret of roneld_eval.secret_key) over their digests; it is
checked before use, field by field, and one that fails is drawn again with a note. The newest
few entries are kept (`MAX_ENTRIES`) in ~/.cache/roneld-eval/truth ($XDG_CACHE_HOME honoured);
RONELD_EVAL_TRUTH_CACHE names another folder, or is 0 to neither read nor write.
"""

from __future__ import annotations

import hashlib
import hmac
import json
import os
import shutil
import tempfile
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Callable, Sequence

import numpy as np

if TYPE_CHECKING:
    from .metrics.raster import LaneRuns, MaskSet

FORMAT = 1
MAX_ENTRIES = 4
ARRAYS = ("n_gt", "lane_start", "meta", "row_start", "slots", "lo", "hi")
MAC_NAME = "mac.json"
RUN_DTYPE = np.int16  # run bounds are pixel columns of the image (CULane's 1640): half the int32 bytes


def enabled() -> bool:
    return os.environ.get("RONELD_EVAL_TRUTH_CACHE", "") != "0"


def cache_root() -> Path:
    chosen = os.environ.get("RONELD_EVAL_TRUTH_CACHE", "")
    if chosen and chosen != "0":
        return Path(chosen)
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


def _mac(folder: Path, secret: bytes) -> str:
    digests = []
    for name in ARRAYS:
        with open(folder / f"{name}.npy", "rb") as handle:
            digests.append(hashlib.file_digest(handle, "sha256").hexdigest()
                           if hasattr(hashlib, "file_digest") else hashlib.sha256(handle.read()).hexdigest())
    return hmac.new(secret, "\n".join(digests).encode(), hashlib.sha256).hexdigest()


def open_entry(folder: str | Path) -> TruthRuns:
    """An entry's arrays, mapped rather than read (a worker takes the frames of its chunk); the
    entry was checked by `load` in the command's process."""
    return TruthRuns(**{name: _array(Path(folder) / f"{name}.npy") for name in ARRAYS})


def _array(path: Path) -> np.ndarray:
    try:
        return np.load(path, mmap_mode="r", allow_pickle=False)
    except ValueError:  # an empty array has nothing to map
        return np.load(path, allow_pickle=False)


def load(key: str, n_frames: int, width: int, height: int, note: Callable[[str], None]) -> Path | None:
    """The folder of the entry of `key`, checked (None when absent, or with a note when it fails
    a check)."""
    from .secret_key import secret_key

    folder = cache_root() / key
    if not enabled() or not folder.is_dir():
        return None
    try:
        recorded = json.loads((folder / MAC_NAME).read_text(encoding="utf-8"))
        if not isinstance(recorded, dict) or not hmac.compare_digest(str(recorded.get("mac")),
                                                                     _mac(folder, secret_key(note))):
            raise ValueError("its checksum does not match its arrays")
        _check(open_entry(folder), n_frames, width, height)
    except (OSError, ValueError, KeyError, TypeError) as error:
        note(f"note: {folder}: the cached ground truth is not used ({error}); drawn again")
        shutil.rmtree(folder, ignore_errors=True)
        return None
    os.utime(folder)  # the newest entries are kept
    return folder


def _check(truth: TruthRuns, n_frames: int, width: int, height: int) -> None:
    """Every array's type, shape and range, as from_frames writes them."""
    n_gt, lane_start, meta, row_start, slots, lo, hi = (truth.n_gt, truth.lane_start, truth.meta, truth.row_start,
                                                        truth.slots, truth.lo, truth.hi)
    kinds = [a.dtype == np.int64 for a in (n_gt, lane_start, meta, row_start, slots)]
    if not all(kinds) or lo.dtype != RUN_DTYPE or hi.dtype != RUN_DTYPE:
        raise ValueError("arrays of other types than this version writes")
    if (n_gt.shape != (n_frames,) or lane_start.shape != (n_frames + 1,) or row_start.shape != (n_frames + 1,)
            or slots.shape != (n_frames,) or meta.ndim != 2 or meta.shape[1] != 7 or lo.shape != hi.shape
            or lo.ndim != 1):
        raise ValueError(f"arrays of other shapes than {n_frames:,} frames need")
    lanes, runs = np.diff(lane_start), np.diff(row_start)
    if (lane_start[0] != 0 or row_start[0] != 0 or (lanes < 0).any() or (runs < 0).any()
            or lane_start[-1] != len(meta) or row_start[-1] != lo.size or (slots < 0).any() or (lanes != n_gt).any()
            or ((runs > 0) & (slots == 0)).any() or (runs % np.maximum(slots, 1)).any()):
        raise ValueError("offsets that do not add up")
    frame_rows = np.repeat(runs // np.maximum(slots, 1), lanes)
    y0, first, count, area, drawn, x0, x1 = (meta[:, c] for c in range(7))
    if ((first < 0) | (count < 0) | (first + count > frame_rows) | (y0 < 0) | (y0 + count > height)
            | (area < 0) | ~np.isin(drawn, (0, 1)) | (x0 < 0) | (x1 < x0) | (x1 > width)).any():
        raise ValueError("lanes outside their frame")
    if lo.size and (lo.min() < 0 or hi.max() > width):
        raise ValueError("runs outside the image")


def save(key: str, truth: TruthRuns, note: Callable[[str], None]) -> None:
    """Write the entry of `key` (atomically: a folder renamed into place), oldest entries beyond
    MAX_ENTRIES removed. A cache that cannot be written is a note, never an error."""
    from .secret_key import secret_key

    if not enabled():
        return
    root = cache_root()
    try:
        root.mkdir(parents=True, exist_ok=True)
        staging = Path(tempfile.mkdtemp(prefix=f".{key[:16]}.", dir=root))
        try:
            for name in ARRAYS:
                np.save(staging / f"{name}.npy", np.ascontiguousarray(getattr(truth, name)), allow_pickle=False)
            (staging / MAC_NAME).write_text(json.dumps({"mac": _mac(staging, secret_key(note))}), encoding="utf-8")
            try:
                os.rename(staging, root / key)
            except OSError:  # another command wrote the same entry first
                pass
        finally:
            shutil.rmtree(staging, ignore_errors=True)
        entries = sorted((p for p in root.iterdir() if p.is_dir() and not p.name.startswith(".")),
                         key=lambda p: p.stat().st_mtime_ns, reverse=True)
        for old in entries[MAX_ENTRIES:]:
            shutil.rmtree(old, ignore_errors=True)
    except OSError as error:
        note(f"note: {root}: the ground truth cannot be cached ({error.strerror or error}); it is drawn each time")

