"""The official TuSimple protocol (tusimple-benchmark evaluate/lane.py), number for number.

Per labelled frame: a ground-truth lane's threshold is 20 / cos(atan(k)), k the least-squares
slope of x over y of its valid points; a prediction matches a row when |x_pred - x_gt| is
strictly below it (absent in both counts); a lane's accuracy is matching rows / rows; a
ground-truth lane is found when its best prediction reaches 0.85. A frame over 200 ms or
with more than ground truth + 2 predictions scores (0, 0, 1); frames with more than 4
ground-truth lanes forgive one FN and their worst lane. Figures are means of per-frame
ratios over all labelled frames (FP can be negative, as the official number is).

Papers also print an F1 made from the mean FP and FN, under two different formulas, each
reproduced here operation for operation: `f1_ufld` (UFLD-v2 evaluation/tusimple/lane2.py)
and `f1_clrnet` (CLRNet clrnet/utils/tusimple_metric.py).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Mapping, Sequence

import numpy as np

from ...datasets._paths import normalise_relpath
from .reader import IMAGE_HEIGHT
from ...errors import InputError
from .lane_format import check_h_samples, read_tusimple_records
from ...metrics.point_accuracy import POINT_THRESHOLD, lane_threshold, row_hits

MAX_RUN_TIME_MS = 200


def bench_frame(pred: Sequence[Sequence[float]], gt: Sequence[Sequence[float]], y_samples: Sequence[float],
                run_time: float = 0.0) -> tuple[float, float, float]:
    """(accuracy, fp, fn) of one frame, as LaneEval.bench."""
    if any(len(p) != len(y_samples) for p in pred):
        raise ValueError("a predicted lane does not have one value per h_samples row")
    if run_time > MAX_RUN_TIME_MS or len(gt) + 2 < len(pred):
        return 0.0, 0.0, 1.0
    y = np.array(y_samples, dtype=float)
    thresholds = [lane_threshold(np.array(x_gts, dtype=float), y) for x_gts in gt]
    # line_accuracy of every prediction at once: the best of hits / rows is the most hits / rows
    preds = np.array(pred, dtype=float).reshape(len(pred), len(y_samples))
    line_accs = []
    fn = 0.0
    matched = 0.0
    for x_gts, threshold in zip(gt, thresholds):
        gt_array = np.array(x_gts, dtype=float)
        max_acc = float(row_hits(preds, gt_array, threshold).max() / len(gt_array)) if len(pred) else 0.0
        if max_acc < POINT_THRESHOLD:
            fn += 1
        else:
            matched += 1
        line_accs.append(max_acc)
    fp = len(pred) - matched
    if len(gt) > 4 and fn > 0:
        fn -= 1
    total = sum(line_accs)
    if len(gt) > 4:
        total -= min(line_accs)
    return (
        total / max(min(4.0, len(gt)), 1.0),
        fp / len(pred) if len(pred) > 0 else 0.0,
        fn / max(min(len(gt), 4.0), 1.0),
    )


def f1_ufld(fp: float, fn: float) -> float:
    """F1 as UFLD-v2's evaluation/tusimple/lane2.py computes it from the mean FP and FN rates:
    precision 1 - FP, recall 1 - FN, and 0 when both are 0."""
    # lane2.py: pr = 1 - fp / num; re = 1 - fn / num; fp / num is our mean FP, the same double.
    pr = 1 - float(fp)
    re = 1 - float(fn)
    if (pr + re) == 0:
        return 0.0
    return 2 * pr * re / (pr + re)


def f1_clrnet(fp: float, fn: float) -> float:
    """F1 as CLRNet's clrnet/utils/tusimple_metric.py computes it from the mean FP and FN rates:
    tp = 1 - FP, precision tp / (tp + FP), recall tp / (tp + FN). NaN where that script
    divides by zero (it stops there with ZeroDivisionError: FP = 1 with FN = 0, or tp = 0)."""
    fp, fn = float(fp), float(fn)  # Python floats, as the script's sums: x / 0 raises, never inf
    tp = 1 - fp
    try:
        precision = tp / (tp + fp)
        recall = tp / (tp + fn)
        return 2 * precision * recall / (precision + recall)
    except ZeroDivisionError:
        return float("nan")


@dataclass(frozen=True)
class TusimpleScore:
    """Official TuSimple means over the labelled frames, and the two F1s papers print."""

    accuracy: float
    fp: float
    fn: float
    n_frames: int

    @property
    def f1_ufld(self) -> float:
        """F1 as UFLD-v2's lane2.py (precision 1 - FP, recall 1 - FN)."""
        return f1_ufld(self.fp, self.fn)

    @property
    def f1_clrnet(self) -> float:
        """F1 as CLRNet's tusimple_metric.py (tp = 1 - FP, recall tp / (tp + FN))."""
        return f1_clrnet(self.fp, self.fn)

    def as_row(self) -> dict[str, float]:
        """accuracy, fp, fn, f1_ufld, f1_clrnet: one row of official.csv."""
        return dict(accuracy=self.accuracy, fp=self.fp, fn=self.fn, f1_ufld=self.f1_ufld, f1_clrnet=self.f1_clrnet)


def mean_scores(frame_scores: Sequence[tuple[float, float, float]], n_frames: int) -> TusimpleScore:
    """Sum in the given order, divide by the number of labelled frames (as the official script)."""
    accuracy = fp = fn = 0.0
    for a, p, n in frame_scores:
        accuracy += a
        fp += p
        fn += n
    if n_frames == 0:
        return TusimpleScore(float("nan"), float("nan"), float("nan"), 0)
    return TusimpleScore(accuracy / n_frames, fp / n_frames, fn / n_frames, n_frames)


def _other_frame_hint(key: str, labelled: Mapping[str, object]) -> str:
    """For a prediction of an unlabelled frame of a labelled clip: what to do about it."""
    clip = key.rsplit("/", 1)[0]
    frame = next((name for name in labelled if name.rsplit("/", 1)[0] == clip), None)
    if frame is None:
        return ""
    return (f"; its clip is labelled on {frame.rsplit('/', 1)[1]} only. lane.py refuses predictions of other frames: "
            f"keep one line per labelled frame (the file holds every frame of a clip, as `run --maps-format lanes` "
            f"reads it? `grep '/{frame.rsplit('/', 1)[1]}\"' FILE` keeps the scored ones)")


def read_labels(labels: str | Path) -> dict[str, dict]:
    """The label file's records by frame, in file order (a frame labelled twice refused)."""
    labels = Path(labels)
    gts: dict[str, dict] = {}
    for number, record in read_tusimple_records(labels):
        key = normalise_relpath(record["raw_file"], labels, number)
        if key in gts:
            raise InputError(labels, f"{key} is labelled twice", line=number)
        check_h_samples(record["h_samples"], labels, number, IMAGE_HEIGHT)
        gts[key] = record
    return gts


def frame_scores(labels: str | Path, predictions: str | Path, gts: Mapping[str, dict],
                 scored: frozenset[str] | None = None,
                 checked_only: bool = False, keys: list[str] | None = None
                 ) -> tuple[list[int], list[tuple[float, float, float]]]:
    """Each prediction line's number and (accuracy, fp, fn), in file order: of every labelled
    frame, or of the frames in `scored` alone (a shard's share); with `checked_only`, the line
    numbers alone; each line's frame appended to `keys` when given. Every line is checked whatever
    the share: a prediction of an unlabelled or twice-predicted frame is refused."""
    labels, predictions = Path(labels), Path(predictions)
    seen: dict[str, int] = {}
    lines, scores = [], []
    for number, record in read_tusimple_records(predictions, predictions=True):
        key = normalise_relpath(record["raw_file"], predictions, number)
        if key not in gts:
            raise InputError(predictions, f"{key} is not in the labels ({labels.name})"
                                          + _other_frame_hint(key, gts), line=number)
        if key in seen:
            raise InputError(predictions, f"{key} is predicted twice (first on line {seen[key]})", line=number)
        seen[key] = number
        if scored is not None and key not in scored:
            continue
        lines.append(number)
        if keys is not None:
            keys.append(key)
        if checked_only:
            continue
        gt = gts[key]
        try:
            scores.append(bench_frame(record["lanes"], gt["lanes"], gt["h_samples"], record["run_time"]))
        except ValueError:
            raise InputError(
                predictions, f"each lane needs one value per h_samples row ({len(gt['h_samples'])})", line=number
            ) from None
    wanted = gts if scored is None else [key for key in gts if key in scored]
    missing = [key for key in wanted if key not in seen]
    if missing:
        raise InputError(
            predictions, f"no prediction for {len(missing)} of {len(wanted)} labelled frames (first: {missing[0]})"
        )
    return lines, scores
