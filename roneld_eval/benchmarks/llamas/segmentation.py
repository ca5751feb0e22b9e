"""LLAMAS's segmentation AP, as its multi-class evaluation computes it
(karstenBehrendt/unsupervised_llamas 9b99f46, evaluation/evaluate_segmentation.py and
segmentation_metrics.py):

- the label: every lane read_json keeps (datasets.llamas.marker_lanes) drawn marker by marker
  into a black 717x1276 BGR image in its lane's colour (dataset_constants.DICT_COLORS), each
  marker a quadrilateral from its world start and end projected by the label's matrix, 0.1 m
  wide at each end, rounded half to even, filled twice with cv2.fillConvexPoly(LINE_AA), and only
  where the projected rows of its start and end differ (label_file_scripts.project_lane_marker);
  class l1, l0, r0 or r1 is the pixels exactly its colour (anti-aliased edges are not);
- the prediction: `<recording>/<frame>.json_<c>.png` (c = 1..4 for l1, l0, r0, r1) read as
  cv2.imread(IMREAD_GRAYSCALE) / 255;
- binary_approx_auc: 101 thresholds t = (100 - i) / 100, a pixel predicted where value / 255 >= t;
  precision and recall (0 where undefined) from the pixel counts; AUC summed as
  (recall - previous recall) * previous precision from (recall 0, precision 1); the "corner" is
  the threshold with the largest precision * recall, the first one reached on ties;
- each of these four numbers averaged over the images, per class.

The pixel counts at every threshold come from one histogram of the 256 grey values per class,
which gives the same counts as thresholding the image 101 times.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Sequence

import numpy as np

IMAGE_WIDTH, IMAGE_HEIGHT = 1276, 717
CLASSES = ("l1", "l0", "r0", "r1")  # the files' classes 1..4 (0 is the background)
MARKER_WIDTH = 0.1  # create_segmentation_image: project_lane_marker(width=.1)
STEPS = 100  # binary_approx_auc: num_steps
THRESHOLDS = tuple((STEPS - i) / STEPS for i in range(STEPS + 1))

# dataset_constants.py: LANE_NAMES zipped with DCOLORS (BGR); zip drops the eighteenth colour
_NAMES = ('l7', 'l6', 'l5', 'l4', 'l3', 'l2', 'l1', 'l0', 'r0', 'r1', 'r2', 'r3', 'r4', 'r5', 'r6', 'r7', 'r8')
_COLOURS = ((110, 30, 30), (75, 25, 230), (75, 180, 60), (200, 130, 0), (48, 130, 245), (180, 30, 145),
            (0, 0, 255), (24, 140, 34), (255, 0, 0), (0, 255, 255), (40, 110, 170), (200, 250, 255),
            (255, 190, 230), (0, 0, 128), (195, 255, 170), (0, 128, 128), (195, 255, 170))
LANE_COLOURS = dict(zip(_NAMES, _COLOURS))


def _first_values() -> np.ndarray:
    """For each threshold, the smallest grey value v with v / 255 >= t (256 when none): the
    comparison made in floating point as the script makes it."""
    first = np.full(len(THRESHOLDS), 256, np.int64)
    for i, threshold in enumerate(THRESHOLDS):
        for value in range(256):
            if value / 255 >= threshold:
                first[i] = value
                break
    return first


FIRST_VALUES = _first_values()


def marker_quad(start, end, projection: np.ndarray) -> np.ndarray | None:
    """project_lane_marker's (4, 2) int32 corners, or None where it draws nothing."""
    p1, p2 = np.asarray(start), np.asarray(end)
    with np.errstate(all="ignore"):  # a point at z = 0 goes to infinity there too
        q1 = projection.dot(p1)
        q1 /= q1[2]
        q2 = projection.dot(p2)
        q2 /= q2[2]
        points = np.zeros((4, 2), dtype=np.float32)
        half1 = projection[0, 0] * MARKER_WIDTH / p1[2] / 2.0
        points[0, 0] = q1[0] - half1
        points[0, 1] = q1[1]
        points[1, 0] = q1[0] + half1
        points[1, 1] = q1[1]
        half2 = projection[0, 0] * MARKER_WIDTH / p2[2] / 2.0
        points[2, 0] = q2[0] + half2
        points[2, 1] = q2[1]
        points[3, 0] = q2[0] - half2
        points[3, 1] = q2[1]
        corners = np.round(points).astype(np.int32)
    if corners[0, 1] == corners[3, 1]:
        return None
    return corners


def class_masks(projection: np.ndarray, lanes: Sequence) -> np.ndarray:
    """(4, 717, 1276) bool: the pixels of classes l1, l0, r0, r1 (create_multi_class_segmentation_label).
    `lanes` are datasets.llamas.MarkerLane; a lane id without a colour is a KeyError there."""
    import cv2

    image = np.zeros((IMAGE_HEIGHT, IMAGE_WIDTH, 3), np.uint8)
    for lane in lanes:
        colour = LANE_COLOURS[lane.lane_id]
        for start, end in lane.markers:
            corners = marker_quad(start, end, projection)
            if corners is not None:
                cv2.fillConvexPoly(image, corners, colour, cv2.LINE_AA, 0)
                cv2.fillConvexPoly(image, corners, colour, cv2.LINE_AA, 0)
    # inRange with the colour as both bounds: the pixels exactly that colour (numpy's all(axis=2) is 15x slower)
    return np.stack([cv2.inRange(image, LANE_COLOURS[name], LANE_COLOURS[name]) != 0 for name in CLASSES])


@dataclass(frozen=True)
class ClassCurve:
    """binary_approx_auc of one class in one image."""

    recall: float
    precision: float
    threshold: float
    auc: float


def approx_auc(values: np.ndarray, truth: np.ndarray) -> ClassCurve:
    """binary_approx_auc of an (H, W) uint8 prediction against a bool label of the same shape."""
    positives = np.bincount(values[truth], minlength=256)
    negatives = np.bincount(values[~truth], minlength=256)
    # predicted pixels of each value and above: index v holds the count for values >= v
    above_pos = np.concatenate([np.cumsum(positives[::-1])[::-1], [0]]).tolist()
    above_neg = np.concatenate([np.cumsum(negatives[::-1])[::-1], [0]]).tolist()
    labelled = int(positives.sum())
    auc = 0.0
    corner_precision = corner_recall = corner_auc = corner_threshold = 0.0
    last_precision, last_recall = 1.0, 0.0
    for threshold, first in zip(THRESHOLDS, FIRST_VALUES.tolist()):
        tp, fp = above_pos[first], above_neg[first]
        fn = labelled - tp
        precision = 0 if (tp + fp) == 0 else tp / (tp + fp)
        recall = 0 if (tp + fn) == 0 else tp / (tp + fn)
        if (precision * recall) > corner_auc:
            corner_auc = precision * recall
            corner_precision, corner_recall, corner_threshold = precision, recall, threshold
        auc += (recall - last_recall) * last_precision
        last_precision, last_recall = precision, recall
    return ClassCurve(float(corner_recall), float(corner_precision), float(corner_threshold), float(auc))


def mean_curves(curves: Sequence[ClassCurve]) -> ClassCurve:
    """evaluate_set's reduce step: each number summed image by image in order, then divided."""
    sums = [0.0, 0.0, 0.0, 0.0]
    for curve in curves:
        for k, value in enumerate((curve.recall, curve.precision, curve.threshold, curve.auc)):
            sums[k] += value
    n = len(curves)
    return ClassCurve(*(value / n for value in sums)) if n else ClassCurve(*(float("nan"),) * 4)
