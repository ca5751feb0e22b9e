"""The temporal metrics of video lane detection, as RVLD's evaluate_temporal.py computes them
(dongkwonjin/RVLD 4d90de1, Modeling/VIL-100/PLD/code/evaluation/evaluate_temporal.py; OMR and PHNet
run the same algorithm): over consecutive frames t-1, t of a video, each ground-truth lane at t is
linked to one at t-1 by Hungarian matching on their IoU, kept when that IoU > 0.5 (always 0.5,
whatever tau: matching_lane_instance's default, :274-290). A linked pair is stable, flickering
("jump") or missing from the IoUs of the predictions each of its two lanes was assigned (0 when
none): exactly one above tau and the other below is a jump, both below is missing, anything else
stable (:262-270). That `else` would take an IoU of exactly tau, but the IoU is divided by the union
+ 1e-10: an overlap of exactly tau of the union comes out just below tau (equality needs a union of
some 300,000 pixels, far beyond two 30 px lanes), so it counts as below. Rs, Rj and Rm are the
three counts over all pairs.

The IoU is that script's own, not the CULane evaluator's (:16-34, :49-55, :78-103): lanes of fewer
than two points are dropped when read; a lane's repeated points are dropped, the rest interpolated
by scipy's splprep (s=0, degree min(3, points - 1)) at 5 samples per point interval, truncated to
integers and drawn with cv2.line 30 px wide; IoU = |A & B| / (|A | B| + 1e-10) over the
(H, W, 3) canvas; matching by scipy's linear_sum_assignment on 1 - IoU.

Where the script stops (a listed frame without a prediction file: FileNotFoundError), such a
frame counts here as one without lanes; a lane whose points are all one point is dropped like a
one-point lane (the script's splprep raises on it).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Sequence

import numpy as np

from ...model import Lane
from ...metrics.line_masks import LaneMask, drawn_mask, intersection

LINK_IOU = 0.5  # matching_lane_instance(iou_threshold=0.5): ground truth linked across frames
LANE_WIDTH = 30
SAMPLES = 5  # interp(..., n=5)
CHANNELS = 3  # the script's canvas is (H, W, 3): its pixel counts are three times a plane's


def _points(lane: Lane) -> list[tuple[float, float]]:
    # tolist's floats are float(x) of each element: a tenth of the time of a loop over the array's rows
    return list(dict.fromkeys(map(tuple, lane.points.tolist())))


def usable(lanes: Sequence[Lane]) -> list[Lane]:
    """The lanes the script keeps: two points or more (load_culane_img_data), and (where its
    spline would raise) two distinct points or more."""
    return [lane for lane in lanes if len(lane.points) >= 2 and len(_points(lane)) >= 2]


def _interpolated(lane: Lane) -> np.ndarray:
    from scipy.interpolate import splev, splprep

    points = _points(lane)
    xs, ys = [x for x, _ in points], [y for _, y in points]
    tck, u = splprep([xs, ys], s=0, t=SAMPLES, k=min(3, len(points) - 1))
    u = np.linspace(0.0, 1.0, num=(len(u) - 1) * SAMPLES + 1)
    return np.array(splev(u, tck)).T


def lane_mask(lane: Lane, width: int, height: int) -> LaneMask:
    """The lane's pixels as the script draws them: its interpolation truncated to integers, each
    segment drawn 30 px wide with cv2.line on the (height, width) canvas (metrics.line_masks)."""
    return drawn_mask(_interpolated(lane).astype(np.int32), width, height, LANE_WIDTH)


def ious(first: Sequence[LaneMask], second: Sequence[LaneMask]) -> np.ndarray:
    """IoU of every lane of `first` with every lane of `second`, as the script's discrete_cross_iou."""
    out = np.zeros((len(first), len(second)))
    for i, a in enumerate(first):
        for j, b in enumerate(second):
            inter = intersection(a, b)
            union = a.area + b.area - inter
            out[i, j] = np.int64(CHANNELS * inter) / (np.int64(CHANNELS * union) + 1e-10)
    return out


def assigned_ious(truth: Sequence[LaneMask], predicted: Sequence[LaneMask]) -> np.ndarray:
    """Each ground-truth lane's IoU with the prediction the matching assigns it, 0 where none
    (culane_metric2, then metric_per_inter_frame's lookup)."""
    from scipy.optimize import linear_sum_assignment

    out = np.zeros(len(truth))
    if not truth or not predicted:
        return out
    matrix = ious(truth, predicted)
    rows, columns = linear_sum_assignment(1 - matrix)
    out[rows] = matrix[rows, columns]
    return out


def links(current: Sequence[LaneMask], previous: Sequence[LaneMask]) -> list[tuple[int, int]]:
    """(lane at t, lane at t-1) of the ground truth linked across two frames."""
    from scipy.optimize import linear_sum_assignment

    if not current or not previous:
        return []
    matrix = ious(current, previous)
    rows, columns = linear_sum_assignment(1 - matrix)
    return [(int(r), int(c)) for r, c in zip(rows, columns) if matrix[r, c] > LINK_IOU]


@dataclass(frozen=True)
class TemporalCounts:
    stable: int = 0
    jump: int = 0
    missing: int = 0

    def __add__(self, other: "TemporalCounts") -> "TemporalCounts":
        return TemporalCounts(self.stable + other.stable, self.jump + other.jump, self.missing + other.missing)

    @property
    def pairs(self) -> int:
        return self.stable + self.jump + self.missing

    @property
    def rates(self) -> tuple[float, float, float]:
        """Rs, Rj, Rm (NaN without pairs, where the script divides by zero)."""
        if not self.pairs:
            return (float("nan"),) * 3
        return self.stable / self.pairs, self.jump / self.pairs, self.missing / self.pairs


def classify(now: float, before: float, tau: float) -> TemporalCounts:
    if (now > tau and before < tau) or (now < tau and before > tau):
        return TemporalCounts(jump=1)
    if now < tau and before < tau:
        return TemporalCounts(missing=1)
    return TemporalCounts(stable=1)


def sequence_counts(frame_links: Sequence[list[tuple[int, int]]], frame_ious: Sequence[np.ndarray],
                    tau: float) -> TemporalCounts:
    """One video's counts: `frame_links[k]` links frame k's ground truth to frame k-1's (empty for
    the first frame), `frame_ious[k]` its ground-truth lanes' assigned IoUs."""
    total = TemporalCounts()
    for k in range(1, len(frame_ious)):
        for now, before in frame_links[k]:
            total = total + classify(float(frame_ious[k][now]), float(frame_ious[k - 1][before]), tau)
    return total
