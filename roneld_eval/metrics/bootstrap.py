"""Confidence intervals of accuracy differences: a paired bootstrap over clips.

Frames of a clip are not independent (the same road, RONELD's state), so clips are the unit
resampled. Each resample draws as many clips as there are, with replacement, and recomputes
both methods' accuracy on the same draw (paired): difference = (sum TP_a - sum TP_b) / sum N_gt
over the drawn clips. The interval is the 2.5th..97.5th percentile of 2,000 resamples with a
fixed seed, so the same inputs give the same interval. With fewer than MIN_CLIPS clips the
resamples are too few to mean anything (one clip gives a zero-width "interval"), so the bounds
are NaN and only the difference is reported.
"""

from __future__ import annotations

import posixpath
from typing import TYPE_CHECKING

import numpy as np

from ..methods import PAPER
from ..thresholds import Thresholds

if TYPE_CHECKING:  # imported where used: report.tables needs this module's constants, not pandas
    import pandas as pd

RESAMPLES = 2000
SEED = 20201  # fixed: intervals are reproducible
LEVEL = 0.95
# Fewer clips than this give NaN bounds: 4 clips have only 35 distinct resamples, and one clip
# a single one, which would print as a zero-width interval around the difference.
MIN_CLIPS = 5


def clip_positions(frames: pd.Series) -> tuple[np.ndarray, list[str]]:
    """(each row's clip as an index into `clips`, `clips`: the distinct video folders of the
    frame paths, sorted): the units the bootstrap resamples."""
    folders: dict[str, int] = {}  # folder -> number, in order of first appearance

    def numbers():
        # A frame's rows follow one another (a row per side and method): its folder is found
        # once. No hash table of every frame, no string per row: a long run's largest passing
        # allocation was once here (pandas' factorize: some 260 bytes a frame).
        previous, number = None, -1
        for frame in frames.to_numpy(dtype=object):
            if frame != previous:
                previous, number = frame, folders.setdefault(posixpath.dirname(frame), len(folders))
            yield number

    found = np.fromiter(numbers(), np.int64, len(frames))
    clips = sorted(folders)
    rank = np.empty(len(clips), np.int64)
    rank[[folders[clip] for clip in clips]] = np.arange(len(clips))
    return rank[found], clips


def count_clips(per_frame: pd.DataFrame) -> int:
    """How many clips the bootstrap resamples: distinct folders of the scored frames."""
    return len(clip_positions(per_frame["frame"])[1]) if len(per_frame) else 0


def _clip_counts(per_frame: pd.DataFrame, positions: np.ndarray, method: str, thresholds: Thresholds,
                 n_clips: int) -> tuple[np.ndarray, np.ndarray]:
    """(tp, n_gt): (C, T) true positives and (C,) ground-truth lanes per clip of one method,
    from each row's clip position (clip_positions)."""
    chosen = (per_frame["method"] == method).to_numpy()
    chosen_positions = positions[chosen]
    ious = per_frame["iou"].to_numpy(np.float64)[chosen]
    # A bincount per threshold (not np.add.at, slow): a row-by-threshold table of pairs would take
    # some 400 bytes a frame at once, the largest allocation of a run's main process.
    tp = np.zeros((n_clips, len(thresholds)), np.int64)
    for column, value in enumerate(thresholds.values):
        tp[:, column] = np.bincount(chosen_positions[ious > value], minlength=n_clips)
    n_gt = np.bincount(chosen_positions, minlength=n_clips)
    return tp, n_gt


def paired_bootstrap(per_frame: pd.DataFrame, thresholds: Thresholds, method: str, reference: str = PAPER.ours,
                     resamples: int = RESAMPLES, seed: int = SEED, level: float = LEVEL) -> pd.DataFrame:
    """threshold, difference (reference - method), ci_low, ci_high from a paired clip bootstrap.

    ci_low and ci_high are NaN with fewer than MIN_CLIPS clips; the difference is always given.
    """
    import pandas as pd

    positions, clips = clip_positions(per_frame["frame"])  # once for both methods
    tp_ref, n_gt = _clip_counts(per_frame, positions, reference, thresholds, len(clips))
    tp_other, n_gt_other = _clip_counts(per_frame, positions, method, thresholds, len(clips))
    assert np.array_equal(n_gt, n_gt_other), "methods are scored on the same ground truth"
    delta = (tp_ref - tp_other).astype(np.float64)  # (C, T)
    total = n_gt.sum()
    difference = delta.sum(axis=0) / total if total else np.full(len(thresholds), np.nan)
    if len(clips) < MIN_CLIPS:
        nan = np.full(len(thresholds), np.nan)
        return pd.DataFrame({"threshold": list(thresholds.labels), "difference": difference, "ci_low": nan,
                             "ci_high": nan})
    samples = _resampled_differences(delta, n_gt, resamples, seed)
    tail = (1 - level) / 2 * 100
    low, high = np.nanpercentile(samples, [tail, 100 - tail], axis=0) if total else (difference, difference)
    return pd.DataFrame({"threshold": list(thresholds.labels), "difference": difference,
                         "ci_low": low, "ci_high": high})


# Resamples drawn at a time: a (resamples, clips) table of draws would take 16 bytes per clip
# and resample at once (13 MB for CULane's test set); drawn in blocks, the same draws follow one
# another from the generator, and the sums are of whole numbers, exact in any order.
RESAMPLE_BLOCK = 100


def _resampled_differences(delta: np.ndarray, n_gt: np.ndarray, resamples: int, seed: int) -> np.ndarray:
    """(resamples, T) accuracy differences, one row per resample of the clips with replacement."""
    rng = np.random.default_rng(seed)
    n_clips = len(n_gt)
    chance = np.full(n_clips, 1 / n_clips)
    samples = np.empty((resamples, delta.shape[1]), np.float64)
    for start in range(0, resamples, RESAMPLE_BLOCK):
        size = min(RESAMPLE_BLOCK, resamples - start)
        # How often each clip is drawn in each resample: equivalent to drawing indices.
        weights = rng.multinomial(n_clips, chance, size=size).astype(np.float64)
        drawn_gt = weights @ n_gt
        with np.errstate(invalid="ignore", divide="ignore"):
            samples[start:start + size] = (weights @ delta) / drawn_gt[:, None]
    return samples
