"""Pictures of single frames, as the paper's Fig. 3: ground truth blue, baseline red, RONELD green.

Each picture is the camera image when the dataset has it, else the maps as a heat map, with
each method's left and right lanes and their IoU beside them. Colours differ in lightness
(dark blue, mid red, light green) and in line style (baseline dashed), so greyscale prints stay
readable. `worst_frames` picks the frames where the methods differ most; `contact_sheet`
gathers pictures on one page. Nothing here computes a metric.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import cv2
import numpy as np
import pandas as pd

from ..methods import METHOD_TABLE, PAPER
from ..model import Lane
from .tables import display_name

OUTPUT_WIDTH = 1000  # pixels of one picture
BLUE, CYAN = (200, 90, 20), (235, 200, 60)  # BGR: ground truth, and plug-in methods
STYLES = {  # colour, thickness at OUTPUT_WIDTH, dashed
    "ground truth": (BLUE, 9, False),
    **{name: (facts.overlay_bgr, facts.overlay_thickness, facts.overlay_dashed)
       for name, facts in METHOD_TABLE.items()},
}
FONT = cv2.FONT_HERSHEY_SIMPLEX
LegendEntry = tuple[str, tuple[int, int, int] | None, bool]  # text, line colour (None: text only), dashed
LEGEND_ROW = 24  # pixels per legend line
CAPTION_SCALE, CAPTION_LINE = 1.0, 36  # caption font scale, and pixels per caption line


@dataclass(frozen=True)
class FramePicture:
    """What one picture shows: a frame, its ego ground truth and each method's lanes and IoUs."""

    relpath: str
    ground_truth: tuple[Lane | None, Lane | None]
    lanes: dict[str, tuple[Lane | None, Lane | None]]  # method -> (left, right)
    ious: dict[str, dict[str, float]]  # method -> side -> IoU
    other_ground_truth: tuple[Lane, ...] = ()


@dataclass(frozen=True)
class Overlays:
    """Drawn frames without a legend, (relpath, picture) each, and the legend they share."""

    pictures: list[tuple[str, np.ndarray]]
    legend: list[LegendEntry]


def worst_frames(per_frame: pd.DataFrame, count: int, first: str = PAPER.reference,
                 second: str | None = None) -> list[str]:
    """The `count` frames where two methods' IoUs differ most (summed over sides), largest first.

    `second` defaults to the RONELD the run has (with PFT, else without); with one method
    alone, its lowest-IoU frames come first.
    """
    present = set(per_frame["method"])
    if second is None:
        second = next((m for m in (PAPER.ours, PAPER.without_tracking) if m in present), None)
    if first not in present or second not in present:
        alone = next(iter(sorted(present & {first, second or ""}) or sorted(present)), None)
        if alone is None:
            return []
        scores = per_frame[per_frame["method"] == alone].groupby("frame")["iou"].sum()
        return [str(frame) for frame, _ in sorted(scores.items(), key=lambda item: (item[1], item[0]))[:count]]
    table = per_frame[per_frame["method"].isin([first, second])].pivot_table(
        index=["frame", "side"], columns="method", values="iou", aggfunc="first")
    difference = (table[first] - table[second]).abs().groupby(level="frame").sum()
    ranked = sorted(difference.items(), key=lambda item: (-item[1], item[0]))
    return [str(frame) for frame, _ in ranked[:count]]


def heat_map(probabilities: np.ndarray, width: int, height: int, crop_top: int, crop_bottom: int) -> np.ndarray:
    """The maps' strongest channel as a dim colour image of the whole frame (BGR)."""
    strongest = probabilities.max(axis=0)
    image = np.zeros((height, width), np.uint8)
    image[crop_top:crop_bottom] = cv2.resize(strongest, (width, crop_bottom - crop_top), interpolation=cv2.INTER_LINEAR)
    coloured = cv2.applyColorMap(image, cv2.COLORMAP_BONE)
    return (coloured * 0.75 + 20).astype(np.uint8)


def _polyline(image, points: np.ndarray, colour, thickness: int, dashed: bool) -> None:
    points = np.asarray(points, np.float64)
    if len(points) < 2:
        return
    if not dashed:
        cv2.polylines(image, [np.rint(points).astype(np.int32)], False, colour, thickness, cv2.LINE_AA)
        return
    # Dashes of ~14 px along the polyline.
    steps = np.hypot(*np.diff(points, axis=0).T)
    length = np.concatenate([[0.0], np.cumsum(steps)])
    samples = np.arange(0.0, length[-1], 2.0)
    xs = np.interp(samples, length, points[:, 0])
    ys = np.interp(samples, length, points[:, 1])
    for start in range(0, len(samples) - 1, 11):
        piece = np.stack([xs[start:start + 7], ys[start:start + 7]], axis=1)
        if len(piece) >= 2:
            cv2.polylines(image, [np.rint(piece).astype(np.int32)], False, colour, thickness, cv2.LINE_AA)


def _label(image, text: str, anchor: tuple[float, float], colour) -> None:
    """Text in a dark box next to a point, kept inside the picture."""
    scale, weight = 0.62, 2
    (width, height), base = cv2.getTextSize(text, FONT, scale, weight)
    x = int(min(max(anchor[0] + 10, 4), image.shape[1] - width - 8))
    y = int(min(max(anchor[1], height + 8), image.shape[0] - base - 6))
    overlay = image.copy()
    cv2.rectangle(overlay, (x - 4, y - height - 5), (x + width + 4, y + base + 3), (0, 0, 0), -1)
    cv2.addWeighted(overlay, 0.65, image, 0.35, 0, dst=image)
    cv2.putText(image, text, (x, y), FONT, scale, colour, weight, cv2.LINE_AA)


def _point_at_height(points: np.ndarray, y: float) -> tuple[float, float]:
    order = np.argsort(points[:, 1])
    ys, xs = points[order, 1], points[order, 0]
    y = min(max(y, ys[0]), ys[-1])
    return float(np.interp(y, ys, xs)), float(y)


def legend_entries(methods: list[str], model: str, protocol: str = "") -> list[LegendEntry]:
    """What a legend says: each line style's name, and what the numbers are: each lane's IoU
    under the paper's protocol, `protocol` saying how it was drawn (e.g. "ground truth 16 px,
    predictions 30 px on 800x288 maps")."""
    entries: list[LegendEntry] = [("ground truth", STYLES["ground truth"][0], False)]
    entries += [(display_name(method, model), *STYLES.get(method, (CYAN, 3, True))[::2]) for method in methods]
    entries.append((f"numbers: each lane's IoU ({protocol or 'the paper' + chr(39) + 's protocol'})", None, False))
    return entries


def draw_legend(image: np.ndarray, entries: list[LegendEntry], scale: int = 1) -> np.ndarray:
    """The legend drawn into the top left of `image` (changed in place, and returned), `scale`
    times its size in a picture of its own."""
    for row, (text, sample_colour, dashed) in enumerate(entries):
        y = (LEGEND_ROW + LEGEND_ROW * row) * scale
        x = (52 if sample_colour is not None else 12) * scale
        overlay = image.copy()
        right = max(250 * scale, x + cv2.getTextSize(text, FONT, 0.55 * scale, scale)[0][0] + 8 * scale)
        cv2.rectangle(overlay, (6 * scale, y - 17 * scale), (right, y + 7 * scale), (0, 0, 0), -1)
        cv2.addWeighted(overlay, 0.6, image, 0.4, 0, dst=image)
        if sample_colour is not None:  # a sample of the line, dashed as drawn
            _polyline(image, np.array([[12.0, y - 5], [44.0, y - 5]]) * [scale, 1], sample_colour, 4 * scale, dashed)
        cv2.putText(image, text, (x, y), FONT, 0.55 * scale, (255, 255, 255), scale, cv2.LINE_AA)
    return image


def legend_strip(entries: list[LegendEntry], width: int, scale: int) -> np.ndarray:
    """The legend alone on white, `width` wide, `scale` times its size in a picture: the one
    legend of a contact sheet, as legible there as the pictures' captions."""
    strip = np.full(((LEGEND_ROW * len(entries) + LEGEND_ROW // 2) * scale, width, 3), 255, np.uint8)
    return draw_legend(strip, entries, scale)


def draw_frame(picture: FramePicture, background: np.ndarray, caption: str = "") -> np.ndarray:
    """One annotated picture (BGR), OUTPUT_WIDTH wide, with a caption bar and no legend: a
    figure of its own gets one with draw_legend, a contact sheet one for all its pictures."""
    height, width = background.shape[:2]
    scale = OUTPUT_WIDTH / width
    image = cv2.resize(background, (OUTPUT_WIDTH, round(height * scale)), interpolation=cv2.INTER_AREA)
    out_height = image.shape[0]
    colour, thickness, dashed = STYLES["ground truth"]
    for other in picture.other_ground_truth:
        _polyline(image, other.points * scale, colour, 2, False)
    for lane in picture.ground_truth:
        if lane is not None and len(lane) >= 2:
            _polyline(image, lane.points * scale, colour, thickness, dashed)
    for rank, (method, sides) in enumerate(picture.lanes.items()):
        colour, thickness, dashed = STYLES.get(method, (CYAN, 3, True))
        for side, lane in zip(("left", "right"), sides):
            if lane is None or len(lane) < 2:
                continue
            points = lane.points * scale
            _polyline(image, points, colour, thickness, dashed)
            iou = picture.ious.get(method, {}).get(side)
            if iou is not None:
                anchor = _point_at_height(points, out_height * (0.62 + 0.12 * rank))
                _label(image, f"{iou:.2f}", anchor, colour)
    return np.vstack([image, caption_bar((caption or picture.relpath).split("\n"))])


def caption_bar(lines: list[str]) -> np.ndarray:
    """The white bar under a picture, OUTPUT_WIDTH wide, a line of black text each, every line
    shrunk to fit. Capitals 20 px high in the picture: still 10.9 px where report.html shows two
    pictures side by side in its 1,100 px column (one line at scale 0.55 came out 7.6 px there)."""
    bar = np.full((CAPTION_LINE * len(lines) + 12, OUTPUT_WIDTH, 3), 255, np.uint8)
    for row, text in enumerate(lines):
        cv2.putText(bar, text, (8, CAPTION_LINE * (row + 1)), FONT, _fitting_scale(text, OUTPUT_WIDTH - 16), (0, 0, 0),
                    2, cv2.LINE_AA)
    return bar


def _fitting_scale(text: str, width: int, weight: int = 2) -> float:
    """The caption's font scale, at most CAPTION_SCALE, at which `text` is at most `width` px
    wide: never cut off. Text width is not proportional to the scale (OpenCV rounds each glyph):
    a caption shrunk by the ratio alone still ran 15 px past the picture's edge."""
    def fits(scale: float) -> bool:
        return cv2.getTextSize(text, FONT, scale, weight)[0][0] <= width

    if fits(CAPTION_SCALE):
        return CAPTION_SCALE
    low, high = 0.05, CAPTION_SCALE  # the largest scale that fits, to 1/4096 of the range
    for _ in range(12):
        middle = (low + high) / 2
        low, high = (middle, high) if fits(middle) else (low, middle)
    return low


def contact_sheet(pictures: list[np.ndarray], legend: np.ndarray | None = None, columns: int = 2,
                  gap: int = 8) -> np.ndarray:
    """Pictures in a grid on white, each scaled to the same width, under one `legend` strip."""
    if not pictures:
        return np.full((10, 10, 3), 255, np.uint8)
    width = OUTPUT_WIDTH
    scaled = [cv2.resize(p, (width, round(p.shape[0] * width / p.shape[1])), interpolation=cv2.INTER_AREA)
              for p in pictures]
    cell = max(p.shape[0] for p in scaled)
    rows = math.ceil(len(scaled) / columns)
    sheet = np.full((rows * (cell + gap) + gap, columns * (width + gap) + gap, 3), 255, np.uint8)
    for k, picture in enumerate(scaled):
        r, c = divmod(k, columns)
        y, x = gap + r * (cell + gap), gap + c * (width + gap)
        sheet[y:y + picture.shape[0], x:x + width] = picture
    if legend is not None:
        top = np.full((legend.shape[0], sheet.shape[1], 3), 255, np.uint8)
        top[:, gap:gap + legend.shape[1]] = legend[:, :sheet.shape[1] - gap]
        sheet = np.vstack([top, sheet])
    return sheet
