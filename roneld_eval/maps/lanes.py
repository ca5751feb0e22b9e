"""Another detector's lanes, drawn into the probability maps RONELD reads (`--maps-format lanes`).

Detectors that output lane lists (CLRNet, LaneATT, UFLD) have no maps. This reads their lanes
in their benchmark's official prediction format and draws each into a map channel, so that
RONELD runs on them as on a segmentation model's output. A benchmark declares its format
(`Benchmark.detector_lanes`), one of the two forms the benchmarks' formats take:

- `LinesPerFrame`: ``<maps-root>/<name>.lines.txt`` per frame, mirrored as `run --save-lanes`
  writes it (`name` the image path without extension, or what the benchmark names a frame by),
  with an optional ``<name>.scores.txt`` beside it (one confidence in [0, 1] per lane line).
- `JsonLinesFile`: ``<maps-root>/<file>``, one JSON line per frame (``raw_file``, ``lanes``,
  ``h_samples``, optionally ``"scores": [...]`` per lane); a frame with no line has no lanes.

Drawing: maps of the configured size (`maps.width` x `maps.height` over the crop rows). In each
map row that a lane spans, its x is interpolated linearly between its points and a ridge is
drawn there: the lane's confidence x 255 at the centre pixel, falling linearly to zero
`RIDGE_HALF_WIDTH_PX` + 1 pixels away (scaled with the map width from 800 px), so that a map's
row maximum lies on the lane. Channels follow the models' order: lanes left of the ego position
(`roneld.center_ratio`, judged at the bottom row) go to the ego-left channel, then outwards;
lanes right of it to the ego-right channel, then outwards; lanes beyond the channels are not
drawn. `FrameMaps.lanes` keeps every lane as read: it is the detector's own output, what the
method 'baseline' reports.
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path
from typing import Callable, Sequence

import numpy as np

from ..config import MapsConfig
from ..datasets._paths import under_root
from ..errors import InputError
from ..geometry import MapGeometry
from ..lanes_io import SCORES_SUFFIX, check_coordinates, decode_text, parse_lines_txt, read_bytes, read_lane_scores
from ..model import EGO_CHANNELS, FrameMaps, Lane, image_stem

# Half the width of a drawn lane, beyond its centre pixel, on an 800-px-wide map.
RIDGE_HALF_WIDTH_PX = 4

LanesAndScores = tuple[tuple[Lane, ...], tuple[float, ...]]


@dataclass(frozen=True)
class LinesPerFrame:
    """A `.lines.txt` per frame under the root: one lane per line, `x y x y ...` in image pixels."""

    # what a frame's file is named by, from its image path (default: the path without extension)
    name_of: Callable[[str], str] | None = None
    suffix: str = ".lines.txt"

    def _stem(self, root: Path, relpath: str) -> Path:
        return under_root(root, self.name_of(relpath) if self.name_of else image_stem(relpath))

    def files(self, root: Path, relpath: str) -> list[Path]:
        """The file that must exist for a frame's lanes."""
        stem = self._stem(root, relpath)
        return [stem.with_name(stem.name + self.suffix)]

    def read(self, root: Path, relpath: str) -> LanesAndScores:
        stem = self._stem(root, relpath)
        path = stem.with_name(stem.name + self.suffix)
        lanes = parse_lines_txt(decode_text(read_bytes(path), path), path)
        check_coordinates(lanes, path)
        return lanes, read_lane_scores(stem.with_name(stem.name + SCORES_SUFFIX), len(lanes))

    def check_coverage(self, root: Path, labelled: Sequence[str], say: Callable[[str], None]) -> None:
        """Nothing to check ahead: a missing file is refused as missing maps are."""


@dataclass(frozen=True)
class JsonLinesFile:
    """One file under the root holding a JSON line per frame, its image path in `raw_file`:
    `frames(path)` reads it into relpath -> (lanes, scores) (the benchmark's format), once per
    process and file (the same size and modification time)."""

    name: str
    frames: Callable[[Path], dict[str, LanesAndScores]]

    def files(self, root: Path, relpath: str) -> list[Path]:
        return [root / self.name]

    def read(self, root: Path, relpath: str) -> LanesAndScores:
        return _json_frames(root / self.name, self.frames).get(relpath, ((), ()))

    def check_coverage(self, root: Path, labelled: Sequence[str], say: Callable[[str], None]) -> None:
        """The file must hold lanes for the frames that are scored: none found is a wrong file or
        raw_file paths in another form (an InputError), fewer than half a warning."""
        path = root / self.name
        if not path.is_file() or not labelled:
            return
        frames = _json_frames(path, self.frames)
        missing = [relpath for relpath in labelled if relpath not in frames]
        if len(missing) == len(labelled):
            example = next(iter(frames), None)
            found = f"; its first line is for {example!r}" if example is not None else "; it holds no line"
            raise InputError(path, f"no line for any of the {len(labelled)} labelled frames (first looked for: "
                                   f"{missing[0]!r}){found}: raw_file must be the image path relative to the "
                                   f"dataset root")
        if len(missing) * 2 > len(labelled):
            say(f"warning: {path} has lanes for only {len(labelled) - len(missing)} of {len(labelled)} labelled "
                f"frames (first without: {missing[0]}); the others count as frames without lanes")


LaneFileFormat = LinesPerFrame | JsonLinesFile


def load_lane_maps(root: Path, relpath: str, lane_files: LaneFileFormat, config: MapsConfig,
                   geometry: MapGeometry, center_ratio: float) -> FrameMaps:
    """One frame's lanes drawn into (C, H, W) uint8 maps."""
    lanes, scores = lane_files.read(root, relpath)
    return draw_lane_maps(lanes, scores, config, geometry, center_ratio)


def draw_lane_maps(lanes: tuple[Lane, ...], scores: tuple[float, ...], config: MapsConfig,
                   geometry: MapGeometry, center_ratio: float) -> FrameMaps:
    """Lanes in image pixels -> maps at the configured size (see the module docstring)."""
    height, width, channels = config.height, config.width, config.lane_channels
    maps = np.zeros((channels, height, width), np.uint8)
    existence = np.zeros(channels, np.float64)
    half = max(1, round(RIDGE_HALF_WIDTH_PX * width / 800))
    for channel, lane, score in _channels(lanes, scores, channels, geometry.image_width, geometry.image_height,
                                          center_ratio):
        _draw_ridge(maps[channel], geometry.image_to_map(lane.points), score, half)
        existence[channel] = 1.0
    return FrameMaps(maps, existence, tuple(lanes))


def _channels(lanes, scores, channels: int, image_width: int, image_height: int, center_ratio: float):
    """(channel, lane, score) for the lanes that get a channel, in the models' channel order."""
    centre = center_ratio * image_width
    left: list[tuple[float, Lane, float]] = []
    right: list[tuple[float, Lane, float]] = []
    for lane, score in zip(lanes, scores):
        if len(lane) < 2:
            continue
        x = lane.bottom_x(image_height - 1)
        (left if x < centre else right).append((x, lane, score))
    left.sort(key=lambda item: -item[0])  # nearest the ego position first
    right.sort(key=lambda item: item[0])
    ego_left, ego_right = EGO_CHANNELS
    out = []
    for offset, (_, lane, score) in enumerate(left):
        if ego_left - offset >= 0:
            out.append((ego_left - offset, lane, score))
    for offset, (_, lane, score) in enumerate(right):
        if ego_right + offset < channels:
            out.append((ego_right + offset, lane, score))
    return out


def _draw_ridge(channel: np.ndarray, points: np.ndarray, score: float, half: int) -> None:
    height, width = channel.shape
    order = np.argsort(points[:, 1], kind="stable")
    ys, xs = points[order, 1], points[order, 0]
    keep = np.concatenate([[True], np.diff(ys) > 0])  # one x per row: the first point's
    ys, xs = ys[keep], xs[keep]
    if ys.size < 2:
        return
    rows = np.arange(max(0, int(np.ceil(ys[0]))), min(height - 1, int(np.floor(ys[-1]))) + 1)
    if rows.size == 0:
        return
    centres = np.floor(np.interp(rows, ys, xs) + 0.5).astype(np.int64)
    offsets = np.arange(-half, half + 1)
    columns = centres[:, None] + offsets[None, :]
    values = np.rint(score * 255.0 * (1.0 - np.abs(offsets) / (half + 1))).astype(np.uint8)
    values = np.broadcast_to(values, columns.shape)
    inside = (columns >= 0) & (columns < width)
    row_index = np.broadcast_to(rows[:, None], columns.shape)
    np.maximum.at(channel, (row_index[inside], columns[inside]), values[inside])


@dataclass(frozen=True)
class _FileKey:
    path: str
    size: int
    modified_ns: int


_JSON_CACHE: dict[_FileKey, dict[str, LanesAndScores]] = {}


def _json_frames(path: Path, read: Callable[[Path], dict[str, LanesAndScores]]) -> dict[str, LanesAndScores]:
    """relpath -> (lanes, scores) of a JSON-lines prediction file, read once per process."""
    info = os.stat(path)
    key = _FileKey(str(path), info.st_size, info.st_mtime_ns)
    frames = _JSON_CACHE.get(key)
    if frames is not None:
        return frames
    frames = read(path)
    _JSON_CACHE.clear()  # one file at a time: memory stays flat
    _JSON_CACHE[key] = frames
    return frames
