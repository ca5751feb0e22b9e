"""What RONELD needs on a vehicle beyond the run's tracker: frames checked as they come, Autoware
EgoLanes' channels, per-call latency, and every one-time cost paid before the first frame.

`RoneldTracker.update` (extract/roneld.py) is built from these. A frame is checked and brought
to the run's canonical form here, before the tracker's state is touched, so a refused frame
leaves the state as it was. Float maps become uint8 exactly as the run's map loader makes them
(maps/_checks.canonical_probabilities, the same function): float32(p) * 255 rounded half to even,
so a tracker fed the arrays a model wrote gives the lanes `run` gives on the same arrays stored.
"""

from __future__ import annotations

import functools
import math
import threading
from dataclasses import dataclass

import numpy as np

from ..config import MapsConfig
from ..errors import InputError
from ..maps._checks import canonical_probabilities

# "scnn": C lane channels in SCNN's order (outer left, ego left, ego right, outer right), what
# the run reads. "egolanes": Autoware EgoLanes' (ego left, ego right, other lanes), mapped into
# SCNN's order (egolanes_as_scnn).
CHANNEL_LAYOUTS = ("scnn", "egolanes")
EGOLANES_CHANNELS = 3


class FrameRefused(InputError, ValueError):
    """A frame `RoneldTracker.update` refused (wrong shape, dtype, values or size): the tracker's
    state is what it was before the call. A ValueError too, as a library's callers expect."""


class FrameBuffers:
    """Arrays one tracker reuses frame after frame (a float frame's conversion to uint8 levels):
    fresh multi-megabyte temporaries each frame cost more than the frame's own work where the
    allocator hands them back to the system and takes them again (page faults: float maps took
    9-14 ms a frame that way on the 2-core machine, 1 ms with the memory reused)."""

    def __init__(self) -> None:
        self._arrays: dict[str, np.ndarray] = {}

    def get(self, name: str, shape: tuple[int, ...], dtype) -> np.ndarray:
        array = self._arrays.get(name)
        if array is None or array.shape != shape or array.dtype != dtype:
            array = self._arrays[name] = np.zeros(shape, dtype)
        return array


FLOATS = (np.float16, np.float32, np.float64)


def checked_frame(maps: object, layout: str, lane_channels: int, where: str,
                  buffers: FrameBuffers | None = None) -> np.ndarray:
    """One frame's maps as the run's tracker takes them: (C, H, W) uint8, C-contiguous (the one
    layout the kernels are compiled for: any other would compile inside the call), or
    FrameRefused saying what is wrong. `where` names the frame in the message; float frames are
    converted into `buffers` (the returned array is then one of them, overwritten next frame)."""
    expected = EGOLANES_CHANNELS if layout == "egolanes" else lane_channels
    try:
        array = maps if isinstance(maps, np.ndarray) else np.asarray(maps)
    except Exception as error:  # anything np.asarray cannot take: name it, not numpy's internals
        raise FrameRefused(where, f"maps must be a NumPy array, got {type(maps).__name__} ({error})") from None
    if array.ndim != 3:
        hint = " (one frame's (C, H, W) maps, not a batch: pass maps[0])" if array.ndim == 4 else ""
        raise FrameRefused(where, f"maps must be a (channels, height, width) array, got shape {array.shape}{hint}")
    if array.shape[0] != expected:
        raise FrameRefused(where, f"maps have {array.shape[0]} channels, expected {expected}"
                                  f"{_channel_hint(array.shape, expected, layout)}")
    if array.dtype in FLOATS and min(array.shape[1:]) >= 2:
        return _float_levels(array, where, buffers or FrameBuffers())
    try:
        canonical = canonical_probabilities(array, where, _LAYOUTS[expected])
    except InputError as error:
        raise FrameRefused(where, error.problem) from None
    return np.ascontiguousarray(canonical)


def _float_levels(array: np.ndarray, where: str, buffers: FrameBuffers) -> np.ndarray:
    """Float probabilities as uint8 levels, bit for bit what the run's loader computes
    (canonical_probabilities: float32(p) * float32(255), rounded half to even, then cast), in
    reused buffers; a frame the loader would refuse is refused with the loader's own message."""
    values = array
    if array.dtype != np.float32:
        values = buffers.get("float32", array.shape, np.float32)
        np.copyto(values, array, casting="same_kind")  # the loader's np.asarray(..., float32)
    low, high = values.min(), values.max()  # NaN makes both NaN, infinities fall outside [0, 1]
    if not (low >= 0 and high <= 1):
        try:
            canonical_probabilities(array, where, _LAYOUTS[array.shape[0]])
        except InputError as error:
            raise FrameRefused(where, error.problem) from None
    scaled = buffers.get("scaled", array.shape, np.float32)
    np.multiply(values, np.float32(255), out=scaled)
    np.rint(scaled, out=scaled)
    levels = buffers.get("levels", array.shape, np.uint8)
    np.copyto(levels, scaled, casting="unsafe")
    return levels


def _channel_hint(shape: tuple[int, ...], expected: int, layout: str) -> str:
    if shape[-1] == expected and shape[0] > 16:
        return " (it looks like (height, width, channels): pass np.transpose(maps, (2, 0, 1)))"
    if layout == "scnn" and shape[0] == expected + 1:
        return " (drop a background channel first: maps[1:])"
    if layout == "scnn" and shape[0] == EGOLANES_CHANNELS:
        return ' (Autoware EgoLanes masks: build the tracker with channels="egolanes")'
    if layout == "egolanes":
        return " (EgoLanes: ego left, ego right, other lanes)"
    return " (lane channels in SCNN's order: outer left, ego left, ego right, outer right)"


class _Layouts(dict):
    """MapsConfig per channel count, built once (its checks cost more than a frame's own)."""

    def __missing__(self, channels: int) -> MapsConfig:
        config = self[channels] = MapsConfig(lane_channels=channels)
        return config


_LAYOUTS = _Layouts()


def egolanes_split_column(width: int, center_ratio: float) -> int:
    """The first map column counted right of the vehicle: RONELD's active-lane choice puts a lane
    left when its x at the bottom is < center_ratio * width, the same line."""
    return min(max(math.ceil(center_ratio * width), 0), width)


@dataclass(frozen=True, eq=False)
class ChannelPlanes:
    """How RONELD's lane channels are read from a frame's planes: channel c is plane planes[c]
    with its columns outside [lows[c], highs[c]) read as 0 (the kernels' frame_lanes)."""

    planes: np.ndarray
    lows: np.ndarray
    highs: np.ndarray


def _frozen(values: list[int]) -> np.ndarray:
    array = np.array(values, np.int64)
    array.flags.writeable = False
    return array


@functools.lru_cache(maxsize=64)
def whole_planes(channels: int, width: int) -> ChannelPlanes:
    """The C planes read as they are, as the run reads them."""
    return ChannelPlanes(_frozen(list(range(channels))), _frozen([0] * channels), _frozen([width] * channels))


@functools.lru_cache(maxsize=64)
def egolanes_planes(width: int, center_ratio: float) -> ChannelPlanes:
    """EgoLanes' three masks read as egolanes_as_scnn's four channels, in place: the tracker
    reads them this way, the copy costing a fifth of a 640x320 frame's work (32 us of 166)."""
    split = egolanes_split_column(width, center_ratio)
    return ChannelPlanes(_frozen([2, 0, 1, 2]), _frozen([0, 0, 0, split]), _frozen([split, width, width, width]))


def egolanes_as_scnn(maps: np.ndarray, center_ratio: float) -> np.ndarray:
    """Autoware EgoLanes' (ego left, ego right, other lanes) masks as SCNN's four channels.

    Ego left -> channel 1 and ego right -> channel 2: the ego channels, weighed e^2 as SCNN's.
    Other lanes -> split at the vehicle's column (egolanes_split_column): the part left of it is
    channel 0 (outer left), the part right of it channel 3 (outer right). RONELD follows one lane
    per channel (a window of W/4 either side of its last point), so the other-lanes mask cannot
    stay one channel: lanes of both sides would be joined into one. Outer lanes weigh 1, as SCNN's;
    they are tracked so that a lane change finds its new ego lane with a history. Where the other
    lanes of one side are several, the channel follows the one RONELD's scan meets first.
    The tracker reads the masks this way without building the array (egolanes_planes).
    """
    _, height, width = maps.shape
    out = np.zeros((4, height, width), np.uint8)
    split = egolanes_split_column(width, center_ratio)
    out[1] = maps[0]
    out[2] = maps[1]
    out[0, :, :split] = maps[2, :, :split]
    out[3, :, split:] = maps[2, :, split:]
    return out


@dataclass(frozen=True)
class Latency:
    """Milliseconds per `update` over the last `frames` calls (NaN before the first)."""

    p50_ms: float
    p99_ms: float
    max_ms: float
    frames: int

    def __str__(self) -> str:
        return f"p50 {self.p50_ms:.3f} ms, p99 {self.p99_ms:.3f} ms, max {self.max_ms:.3f} ms over {self.frames} frames"


class LatencyRing:
    """The last `size` call times, in a fixed array: recording allocates nothing, so a tracker
    running for days holds the same memory as after its first `size` frames."""

    def __init__(self, size: int):
        if isinstance(size, bool) or not isinstance(size, int) or size < 1:
            raise ValueError(f"the latency ring needs at least 1 frame, got {size!r}")
        self._ms = np.zeros(size, np.float64)
        self._count = 0

    def add(self, milliseconds: float) -> None:
        self._ms[self._count % self._ms.size] = milliseconds
        self._count += 1

    def summary(self) -> Latency:
        held = self._ms[:min(self._count, self._ms.size)]
        if not held.size:
            return Latency(math.nan, math.nan, math.nan, 0)
        p50, p99 = np.percentile(held, [50, 99])
        return Latency(float(p50), float(p99), float(held.max()), int(held.size))


_warm_lock = threading.Lock()
_warm = [False]


def warm_up() -> None:
    """Pay, once per process, what RONELD would otherwise pay inside a frame: compiling its numba
    kernels (or loading them from numba's cache, where an earlier process compiled them), importing
    SciPy's spline (0.15 s) and running every code path of `RoneldTracker.update` once, curve mode,
    float maps and EgoLanes' channels included. `RoneldTracker.from_preset` calls it; call it
    yourself before the first frame of a tracker built directly. Thread-safe; the later calls
    return at once."""
    with _warm_lock:
        if _warm[0]:
            return
        from . import curving_clip
        from . import warm_up as warm_kernels
        from .roneld import RoneldTracker, _interp_spline

        warm_kernels(("roneld",))
        _interp_spline()
        clip = curving_clip()  # reaches curve mode: its spline is drawn
        for channels, frames in (("scnn", clip), ("egolanes", [maps[1:] for maps in clip[:2]])):
            tracker = RoneldTracker(channels=channels)
            for maps in frames:
                tracker.update(maps)
            tracker.update(frames[0].astype(np.float32) / 255)
            tracker.latency()
        _warm[0] = True
