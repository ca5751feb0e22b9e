"""VIL-100's official F1 and mIoU, as MMA-Net scores them (yujun0-0/MMA-Net 8f95908, evaluation/):
its modified CULane evaluator run once per sequence at the sequence's size, lanes 30 px wide
whatever the size, and evaluate_iou.py gathering the sequences.

A frame is matched as CULane's evaluator matches it (metrics.lane_iou_f1, the same C++ code):
a matched pair is a TP when its IoU > the threshold, FP = predictions - TP, FN = ground truth - TP.
MMA-Net adds a frame mIoU (culane/src/counter.cpp:75-134): the IoU summed over every pair the
Hungarian matching assigns, below the threshold too, divided by the number of predicted lanes; 1
when both sides are empty, 0 when one is. It does not depend on the threshold. A sequence's mIoU is
the mean over its listed frames (evaluate.cpp:185), printed with 6 significant digits; the overall
mIoU is the unweighted mean of those printed values over the sequences, and the overall F1 comes
from TP, FP and FN summed over the sequences (evaluate_iou.py:78-91).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Sequence

import numpy as np

from ...metrics.lane_iou_f1 import FrameMatches, f_measure


def frame_miou(result: FrameMatches) -> float:
    """MMA-Net's per-frame mIoU of a matched frame (counter.cpp:77-89, 112-133)."""
    if result.n_gt == 0:
        return 1.0 if result.n_pred == 0 else 0.0
    if result.n_pred == 0:
        return 0.0
    total = 0.0
    for value in result.matched_iou.tolist():  # in ground-truth order, one addition at a time, as the C++ loop
        if value != -np.inf:
            total += value
    return total / result.n_pred


def printed(value: float) -> str:
    """A double as the evaluator's iostream prints it (6 significant digits)."""
    return "%g" % value


@dataclass(frozen=True)
class SequenceScore:
    """One sequence of one method at one threshold: counts, and its mIoU exact and as printed."""

    sequence: str
    tp: int
    fp: int
    fn: int
    miou: float

    @property
    def miou_printed(self) -> float:
        return float(printed(self.miou))


def sequence_score(sequence: str, results: Sequence[FrameMatches], mious: Sequence[float],
                   threshold: float) -> SequenceScore:
    tp = sum(result.true_positives(threshold) for result in results)
    n_gt = sum(result.n_gt for result in results)
    n_pred = sum(result.n_pred for result in results)
    total = 0.0
    for value in mious:  # frame order, as evaluate.cpp sums tuple_lists
        total += value
    return SequenceScore(sequence, tp, n_pred - tp, n_gt - tp, total / len(mious) if mious else float("nan"))


@dataclass(frozen=True)
class PooledScore:
    """Sequences gathered as evaluate_iou.py gathers them: counts summed, printed mIoUs averaged."""

    tp: int
    fp: int
    fn: int
    miou: float
    sequences: int

    @property
    def ratios(self) -> tuple[float, float, float]:
        return f_measure(self.tp, self.fp, self.fn)


def pooled(scores: Sequence[SequenceScore]) -> PooledScore:
    """evaluate_iou.py sums the printed mIoUs in os.listdir's order (unspecified); here they are
    summed in list order, so the last bit of a long float may differ from its print."""
    total = 0.0
    for score in scores:
        total += score.miou_printed
    return PooledScore(sum(s.tp for s in scores), sum(s.fp for s in scores), sum(s.fn for s in scores),
                       total / len(scores) if scores else float("nan"), len(scores))
