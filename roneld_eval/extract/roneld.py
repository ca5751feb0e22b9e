"""RONELD (Chng et al., ICPR 2020) as the authors' implementation runs it, per clip.

Per frame: adaptive point extraction per channel, the curve test, weighted least squares
with one pass of outlier removal for straight lanes, preceding-frame tracking (PFT) of every
lane seen, and the choice of the left and right active lanes. Every constant is stated in
shared/docs/roneld-method.md; `RoneldConstants` holds them. State lives in an immutable
`RoneldState` that `roneld_step` returns anew; `RoneldTracker` wraps it for one clip.
Not reproduced from the reference: its uint8 overflow in the RMS confidence and its random
jitter of vertical lanes (ours is deterministic).
"""

from __future__ import annotations

import numbers

import math
import time
from dataclasses import dataclass, field
from typing import Any, Mapping

import numpy as np

from ..config import RoneldParams
from ..errors import ConfigError
from ..geometry import MapGeometry, check_map_shape
from ..model import EGO_CHANNELS, FrameMaps, Lane, read_only
from ..signals import deferred_signals
from . import _kernels, online
from .protocol import Prediction, one_time_work


@dataclass(frozen=True)
class RoneldConstants:
    """The reference's fixed numbers (lane_detection_functions.py)."""

    min_straight_points: int = 3  # a lane needs more than this many points
    min_curve_points: int = 9  # curve test needs at least this many; curves drawn above this
    curve_top_points: int = 3  # the curve test drops this many top points
    outlier_fraction: float = 0.2  # drop floor(0.2*m)+1 farthest points, once
    rows_per_point: int = 20  # row stride = H // 20
    merge_width_divisor: float = 200.0  # same lane when RMS distance < W/200
    ego_channels: tuple[int, ...] = EGO_CHANNELS  # channels whose lanes weigh e^2 more
    ego_weight: float = math.e**2
    other_weight: float = 1.0
    decay: float = math.e  # weight of a missed lane is divided by e per frame
    min_weight: float = math.e**-10  # a missed lane below this weight is dropped
    curve_ring: int = 10  # frames of curve counts remembered
    curve_on: int = 15  # curve mode on when the ring sums to at least this
    curve_off: int = 10  # and off when it sums to at most this
    curve_step_px: int = 5  # curve samples every 5 map rows


CONSTANTS = RoneldConstants()


def _no_lanes() -> np.ndarray:
    return np.zeros((0, _kernels.N_FIELDS), np.float64)


@dataclass(frozen=True, eq=False)
class RoneldState:
    """What RONELD carries from one frame to the next within a clip.

    `fields` has one row per tracked lane (columns: _kernels.F_*), heaviest first; `points`
    holds each lane's raw points (xs, ys) in map pixels, top first.
    """

    fields: np.ndarray = field(default_factory=_no_lanes)
    points: tuple[tuple[np.ndarray, np.ndarray], ...] = ()
    curve_counts: tuple[int, ...] = (0,) * CONSTANTS.curve_ring
    curve_mode: bool = False

    @property
    def n_lanes(self) -> int:
        return self.fields.shape[0]


@dataclass(frozen=True, eq=False)
class ActiveLanes:
    """RONELD's output for one frame: left and right active lanes in image pixels (or None)."""

    left: Lane | None
    right: Lane | None
    curve_mode: bool = False

    def as_list(self) -> list[Lane]:
        """The lanes present, left first (the order written to CULane files)."""
        return [lane for lane in (self.left, self.right) if lane is not None]


def current_lanes(maps: np.ndarray, constants: RoneldConstants = CONSTANTS,
                  channels: online.ChannelPlanes | None = None):
    """The lanes RONELD sees in one frame's (C, H, W) uint8 maps, in channel order.

    `channels`: how the lane channels are read from the maps' planes (online.ChannelPlanes);
    None reads the C planes as the C channels. Returns (fields, points) as in RoneldState
    (weights 0).
    """
    if channels is None:
        channels = online.whole_planes(maps.shape[0], maps.shape[2])
    counts, xs, ys, fields = _kernels.frame_lanes(
        read_only(maps),  # one compiled specialisation for every kind of maps
        channels.planes,
        channels.lows,
        channels.highs,
        constants.rows_per_point,
        constants.min_straight_points,
        constants.min_curve_points,
        constants.curve_top_points,
        constants.outlier_fraction,
    )
    points = []
    offset = 0
    for n in counts.tolist():
        if n:
            points.append((xs[offset:offset + n], ys[offset:offset + n]))
        offset += n
    return fields, points


def lane_gains(fields: np.ndarray, constants: RoneldConstants = CONSTANTS) -> np.ndarray:
    """Weight a lane adds when seen: psi * points * RMS confidence, psi = e^2 on ego channels."""
    channels = fields[:, _kernels.F_CHANNEL]
    psi = np.where(np.isin(channels, constants.ego_channels), constants.ego_weight, constants.other_weight)
    return psi * fields[:, _kernels.F_POINTS] * fields[:, _kernels.F_RMS]


_make_interp_spline = None


def _interp_spline():
    """scipy's make_interp_spline, imported at the first curve drawn in this process: importing
    scipy.interpolate took 0.15 s, a third of a worker's warm-up, and most clips never reach
    curve mode (no frame of either bundled fixture does). Import and a first fit are one-time
    work, left out of the frame's time."""
    global _make_interp_spline
    if _make_interp_spline is None:
        # A signal waits for the import: cut by one, an extension module's initialisation fails
        # ("ImportError: initialization failed") and a module lock may stay taken.
        with one_time_work(), deferred_signals():
            from scipy.interpolate import make_interp_spline

            samples = np.arange(4, dtype=np.float64)
            make_interp_spline(samples, samples, k=2)(samples)  # its own first-call costs
            _make_interp_spline = make_interp_spline
    return _make_interp_spline


def lane_outline(xs: np.ndarray, ys: np.ndarray, slope: float, intercept: float, top_row: float,
                 height: int, width: int, curve_mode: bool, constants: RoneldConstants = CONSTANTS) -> np.ndarray:
    """The polyline RONELD draws for a chosen lane, in map pixels, top first.

    Curve mode and more than 9 points: an interpolating quadratic spline of x over y through
    the raw points, sampled every 5 rows from the top point while above the last. Otherwise
    the fitted line from the top row down to where it meets the bottom row (or the image side).
    """
    if curve_mode and xs.size > constants.min_curve_points:
        spline = _interp_spline()(ys.astype(np.float64), xs.astype(np.float64), k=2)
        rows = np.arange(ys[0], ys[-1], constants.curve_step_px, dtype=np.float64)
        return np.stack([spline(rows), rows], axis=1)
    x_bottom = (height - 1 - intercept) / slope
    if x_bottom < 0:
        bottom = (0.0, intercept)
    elif x_bottom >= width:
        bottom = (width - 1.0, intercept + width * slope)
    else:
        bottom = (x_bottom, height - 1.0)
    top = ((top_row - intercept) / slope, float(top_row))
    return np.array([top, bottom], np.float64)


def roneld_step(
    state: RoneldState, maps: np.ndarray, params: RoneldParams, constants: RoneldConstants = CONSTANTS,
    pft: bool = True, channels: online.ChannelPlanes | None = None,
) -> tuple[RoneldState, np.ndarray | None, np.ndarray | None, bool]:
    """One frame: new state, left and right polylines in map pixels (or None), curve mode.

    `pft=False` is RONELD without preceding-frame tracking (the method 'roneld-nopft').
    `channels`: the lane channels read from the maps' planes (current_lanes).
    """
    if not pft:
        # The ablation empties the state before every frame, curve memory included.
        state = RoneldState()
    _, height, width = maps.shape
    fields, points = current_lanes(maps, constants, channels)
    tracked, sources = _kernels.track_lanes(
        state.fields, fields, lane_gains(fields, constants), float(height),
        width / constants.merge_width_divisor, constants.decay, constants.min_weight,
    )
    every_points = points + list(state.points)
    tracked_points = tuple(every_points[source] for source in sources.tolist())
    left, right = _kernels.choose_active(tracked, float(height), params.center_ratio * width, state.curve_mode)
    chosen = [row for row in (left, right) if row >= 0]
    count = int(sum(tracked[row, _kernels.F_CURVE] for row in chosen))
    ring = state.curve_counts[1:] + (count,)
    curve_mode = state.curve_mode
    if sum(ring) >= constants.curve_on:
        curve_mode = True
    elif sum(ring) <= constants.curve_off:
        curve_mode = False
    top_row = height * (1 - params.lane_ratio)
    for row in chosen:
        top_row = min(top_row, tracked[row, _kernels.F_TOP_Y])
    outlines: list[np.ndarray | None] = []
    for row in (left, right):
        if row < 0:
            outlines.append(None)
            continue
        xs, ys = tracked_points[row]
        outlines.append(lane_outline(
            xs, ys, tracked[row, _kernels.F_SLOPE], tracked[row, _kernels.F_INTERCEPT],
            top_row, height, width, curve_mode, constants,
        ))
    return RoneldState(tracked, tracked_points, ring, curve_mode), outlines[0], outlines[1], curve_mode


@dataclass
class RoneldTracker:
    """RONELD over one clip (one camera): feed frames in order; `reset()` between clips.

    `pft` is preceding-frame tracking: on for the method 'roneld', off for 'roneld-nopft'.
    `geometry` places the maps in the camera image (None: lanes stay in map pixels); maps of
    another size than its own are rescaled as `run` rescales them. The run calls the tracker
    (`tracker(maps) -> ActiveLanes`) with maps its loader checked; a vehicle calls `update`,
    which checks each frame, maps `channels="egolanes"` masks into SCNN's order, keeps the
    clip's map size, and times itself (`latency()`). Built by `from_preset`, or after
    `roneld_eval.warm_up()`, `update` compiles and imports nothing. A tracker holds no global
    state: trackers of several cameras are independent, each used by one thread at a time.
    """

    params: RoneldParams = field(default_factory=RoneldParams)
    geometry: MapGeometry | None = None
    state: RoneldState = field(default_factory=RoneldState)
    pft: bool = True
    channels: str = "scnn"  # "scnn", or "egolanes": Autoware EgoLanes' (ego left, ego right, other)
    lane_channels: int = 4  # channels `update` takes in SCNN's order
    latency_frames: int = 1000  # calls `latency()` summarises
    _clip_size: tuple[int, int] | None = field(default=None, init=False, repr=False)
    _clip_geometry: MapGeometry | None = field(default=None, init=False, repr=False)
    _frames: int = field(default=0, init=False, repr=False)  # accepted since reset(), for messages

    def __post_init__(self):
        if self.channels not in online.CHANNEL_LAYOUTS:
            raise ConfigError(f"channels must be one of {', '.join(online.CHANNEL_LAYOUTS)}, got {self.channels!r}")
        self._latency = online.LatencyRing(self.latency_frames)
        self._buffers = online.FrameBuffers()

    @classmethod
    def from_preset(cls, name: str, pft: bool = True, channels: str = "scnn",
                    image_size: tuple[int, int] | None = None, latency_frames: int = 1000,
                    warm: bool = True) -> "RoneldTracker":
        """A tracker with a preset's (or a configuration file's) image size, crop and RONELD
        parameters; maps of any size are placed in the image as `run` places them (their aspect
        checked at the first frame). `image_size` (width, height): a camera of another size (the
        crop rows scale with it, as for VIL-100's videos). `warm`: pay numba's compile and
        SciPy's import now (`roneld_eval.warm_up`), not in the first `update`."""
        from ..config import EvalConfig
        from ..resolve import configured

        config, _ = configured(EvalConfig.from_toml(name))  # the benchmark's image size where the file gives none
        geometry = config.geometry if image_size is None else config.geometry.at_image_size(*_pixels(image_size))
        tracker = cls(config.roneld, geometry, pft=pft, channels=channels,
                      lane_channels=config.maps.lane_channels, latency_frames=latency_frames)
        if warm:
            online.warm_up()
        return tracker

    def reset(self) -> None:
        """Start a new clip: no lanes tracked, and the next frame may have another map size."""
        self.state = RoneldState()
        self._clip_size = self._clip_geometry = None
        self._frames = 0

    def __call__(self, frame: FrameMaps | np.ndarray) -> ActiveLanes:
        maps = frame.probabilities if isinstance(frame, FrameMaps) else frame
        height, width = maps.shape[1:]
        # Without a geometry, lanes stay in map pixels.
        geometry = (self.geometry or MapGeometry(width, height, width, height)).with_map_size(width, height)
        self.state, lanes = self._step(maps, geometry)
        return lanes

    def _step(self, maps: np.ndarray, geometry: MapGeometry,
              channels: online.ChannelPlanes | None = None) -> tuple[RoneldState, ActiveLanes]:
        state, left, right, curve_mode = roneld_step(self.state, maps, self.params, pft=self.pft, channels=channels)
        return state, ActiveLanes(
            left=None if left is None else Lane(geometry.map_to_image(left)),
            right=None if right is None else Lane(geometry.map_to_image(right)),
            curve_mode=curve_mode,
        )

    def update(self, maps: Any, exist: Any = None) -> Prediction:
        """One frame of the clip: its lanes and its left and right active lanes in image pixels,
        the `Prediction` the run's RONELD gives for the same maps.

        `maps`: a (C, H, W) NumPy array, uint8 0..255 or float probabilities in [0, 1] (converted
        as the run's loader converts them: float32(p) * 255, rounded half to even), C lane channels
        in SCNN's order, or EgoLanes' three with `channels="egolanes"`. `exist` (the model's lane
        existence) is accepted and ignored, as the authors' RONELD ignores it. A frame with another
        shape, dtype, NaN, values outside [0, 1], or a map size other than the clip's first is
        refused (`FrameRefused`, a ValueError) and the tracker's state stays as it was.
        """
        start = time.perf_counter()
        where = f"frame {self._frames + 1}"
        checked = online.checked_frame(maps, self.channels, self.lane_channels, where, self._buffers)
        height, width = checked.shape[1:]
        geometry = self._geometry_for(width, height, where)
        planes = None
        if self.channels == "egolanes":  # read as SCNN's channels in place (egolanes_planes), not copied
            planes = online.egolanes_planes(width, self.params.center_ratio)
        self.state, lanes = self._step(read_only(checked), geometry, planes)
        self._clip_size, self._clip_geometry = (width, height), geometry
        self._frames += 1
        prediction = Prediction(tuple(lanes.as_list()), (lanes.left, lanes.right), spline=False)
        self._latency.add((time.perf_counter() - start) * 1e3)
        return prediction

    def _geometry_for(self, width: int, height: int, where: str) -> MapGeometry:
        """The clip's geometry: set by its first frame (its aspect checked against the configured
        maps', as the run checks a clip's first frame), the same size required after it."""
        if self._clip_geometry is not None:
            if (width, height) != self._clip_size:
                known_width, known_height = self._clip_size or (0, 0)
                raise online.FrameRefused(where, f"maps of {width}x{height} differ from this clip's {known_width}x"
                                                 f"{known_height} (call reset() to start a clip of another size)")
            return self._clip_geometry
        if self.geometry is None:
            return MapGeometry(width, height, width, height)
        try:
            check_map_shape(self.geometry, width, height, where)
        except ConfigError as error:  # its remedy is the command line's: say the tracker's
            found = str(error).split("; ")[0]
            raise online.FrameRefused(None, f"{found}; build the tracker from the preset of the model that wrote "
                                            "them, or give it a MapGeometry of these maps") from None
        return self.geometry.with_map_size(width, height)

    def latency(self) -> online.Latency:
        """p50, p99 and max of `update`'s milliseconds over the last `latency_frames` calls
        (refused frames not counted; reset() keeps them: they time the tracker, not the clip)."""
        return self._latency.summary()


class RoneldExtractor:
    """RONELD as an extractor: one tracker per clip; its two active lanes are all it outputs."""

    stateless = False  # preceding-frame tracking needs every frame, in order

    def __init__(self, geometry: MapGeometry, params: Mapping[str, Any], pft: bool = True):
        self.tracker = RoneldTracker(RoneldParams(**params), geometry, pft=pft)

    def __call__(self, maps: FrameMaps) -> Prediction:
        lanes = self.tracker(maps)
        return Prediction(tuple(lanes.as_list()), (lanes.left, lanes.right), spline=False)


def with_pft(geometry: MapGeometry, params: Mapping[str, Any]) -> RoneldExtractor:
    """The method 'roneld': RONELD with preceding-frame tracking."""
    return RoneldExtractor(geometry, params, pft=True)


def without_pft(geometry: MapGeometry, params: Mapping[str, Any]) -> RoneldExtractor:
    """The method 'roneld-nopft': RONELD without preceding-frame tracking (the ablation)."""
    return RoneldExtractor(geometry, params, pft=False)


def _pixels(image_size: Any) -> tuple[int, int]:
    """(width, height) as whole pixels within the configuration's bounds; a ConfigError saying
    what was given otherwise (a NaN or a string raised int()'s bare ValueError)."""
    from ..thresholds import TALLEST_IMAGE
    from ..errors import ConfigError

    try:
        width, height = image_size
    except (TypeError, ValueError):
        raise ConfigError(f"image_size must be (width, height) in pixels, got {image_size!r}") from None
    if any(isinstance(value, bool) or not isinstance(value, numbers.Integral) or not 1 <= int(value) <= TALLEST_IMAGE
           for value in (width, height)):
        raise ConfigError(f"image_size must be (width, height) in whole pixels from 1 to {TALLEST_IMAGE:,}, "
                          f"got {image_size!r}")
    return int(width), int(height)
