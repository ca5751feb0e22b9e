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

from ..config import Thresholds

if TYPE_CHECKING:  # imported where used: report.tables needs this module's constants, not pandas
    import pandas as pd

RESAMPLES = 2000
SEED = 20201  # fixed: intervals are reproducible
LEVEL = 0.95
# Fewer clips than this give NaN bounds: 4 clips have only 35 distinct resamples, and one clip
# a single one, which would print as a zero-width interval around the difference.
MIN_CLIPS = 5


def clip_of(frames: pd.Series) -> pd.Series:
    """The clip (video folder) of each frame path: the unit the bootstrap resamples."""
    # Each frame has a row per side and method: name each folder once. As a numpy array: pandas'
    # string arrays are slow to walk one element at a time.
    unique = np.asarray(frames.unique(), dtype=object)
    return frames.map(dict(zip(unique, map(posixpath.dirname, unique))))


def count_clips(per_frame: pd.DataFrame) -> int:
    """How many clips the bootstrap resamples: distinct folders of the scored frames."""
    return int(clip_of(per_frame["frame"]).nunique()) if len(per_frame) else 0


def clip_counts(per_frame: pd.DataFrame, method: str, thresholds: Thresholds,
                clips: list[str]) -> tuple[np.ndarray, np.ndarray]:
    """(tp, n_gt): (C, T) true positives and (C,) ground-truth lanes per clip of one method."""
    return _clip_counts(per_frame, clip_of(per_frame["frame"]), method, thresholds, clips)


def _clip_counts(per_frame: pd.DataFrame, clip: pd.Series, method: str, thresholds: Thresholds,
                 clips: list[str]) -> tuple[np.ndarray, np.ndarray]:
    """clip_counts with each row's clip (clip_of its frame) given."""
    import pandas as pd

    chosen = (per_frame["method"] == method).to_numpy()
    rows = per_frame[chosen]
    positions = pd.Categorical(clip[chosen], categories=clips).codes.astype(np.int64)
    assert (positions >= 0).all(), "every frame's clip is among the clips"
    ious = rows["iou"].to_numpy(np.float64)
    # A bincount per threshold (not np.add.at, slow): a row-by-threshold table of pairs would take
    # some 400 bytes a frame at once, the largest allocation of a run's main process.
    tp = np.zeros((len(clips), len(thresholds)), np.int64)
    for column, value in enumerate(thresholds.values):
        tp[:, column] = np.bincount(positions[ious > value], minlength=len(clips))
    n_gt = np.bincount(positions, minlength=len(clips))
    return tp, n_gt


def paired_bootstrap(per_frame: pd.DataFrame, thresholds: Thresholds, method: str, reference: str = "roneld",
                     resamples: int = RESAMPLES, seed: int = SEED, level: float = LEVEL) -> pd.DataFrame:
    """threshold, difference (reference - method), ci_low, ci_high from a paired clip bootstrap.

    ci_low and ci_high are NaN with fewer than MIN_CLIPS clips; the difference is always given.
    """
    import pandas as pd

    clip = clip_of(per_frame["frame"])  # once for both methods
    clips = sorted(set(np.asarray(clip.unique(), dtype=object)))
    tp_ref, n_gt = _clip_counts(per_frame, clip, reference, thresholds, clips)
    tp_other, n_gt_other = _clip_counts(per_frame, clip, method, thresholds, clips)
    assert np.array_equal(n_gt, n_gt_other), "methods are scored on the same ground truth"
    delta = (tp_ref - tp_other).astype(np.float64)  # (C, T)
    total = n_gt.sum()
    difference = delta.sum(axis=0) / total if total else np.full(len(thresholds), np.nan)
    if len(clips) < MIN_CLIPS:
        nan = np.full(len(thresholds), np.nan)
        return pd.DataFrame({"threshold": list(thresholds.labels), "difference": difference, "ci_low": nan,
                             "ci_high": nan})
    rng = np.random.default_rng(seed)
    # How often each clip is drawn in each resample: equivalent to drawing indices.
    weights = rng.multinomial(len(clips), np.full(len(clips), 1 / len(clips)), size=resamples).astype(np.float64)
    drawn_gt = weights @ n_gt
    with np.errstate(invalid="ignore", divide="ignore"):
        samples = (weights @ delta) / drawn_gt[:, None]
    tail = (1 - level) / 2 * 100
    low, high = np.nanpercentile(samples, [tail, 100 - tail], axis=0) if total else (difference, difference)
    return pd.DataFrame({"threshold": list(thresholds.labels), "difference": difference,
                         "ci_low": low, "ci_high": high})
