"""What a `score culane --shard I/N` part holds (part.npz): each frame's lane counts, the IoU of
each ground-truth lane with the prediction matched to it, and its categories, checked before
`merge` combines them."""

from __future__ import annotations

from typing import Iterable

import numpy as np

from ...errors import InputError
from ...shards import ARRAYS_NAME, MANIFEST_NAME, Part


def check_part_arrays(part: Part, n_methods: int, n_categories: int, more: Iterable[str] = ()) -> dict[str, np.ndarray]:
    """A part's arrays, every shape, type and value range checked (`more`: the names of arrays
    its settings add, which their reader checks)."""
    arrays = part.arrays
    where = part.path / ARRAYS_NAME
    wanted = {"frames", "n_gt", "n_pred", "matched_iou", *(f"category_{k}" for k in range(n_categories)), *more}
    if set(arrays) != wanted:
        raise InputError(where, f"holds {sorted(arrays)}, not {sorted(wanted)}")
    frames = arrays["frames"]
    if frames.ndim != 1 or frames.dtype.kind != "U":
        raise InputError(where, "its frames are not a list of names")
    n = len(frames)
    _check_counts(arrays["n_gt"], arrays["n_pred"], n, n_methods, where)
    _check_matches(arrays["matched_iou"], arrays["n_gt"], arrays["n_pred"], n, n_methods, where)
    for k in range(n_categories):
        if arrays[f"category_{k}"].dtype != np.bool_ or arrays[f"category_{k}"].shape != (n,):
            raise InputError(where, f"its category {k} is not one flag a frame")
    if part.manifest.get("scored_frames") != n:
        raise InputError(part.path / MANIFEST_NAME, "its frame count differs from its part.npz's")
    return arrays


def _check_counts(n_gt: np.ndarray, n_pred: np.ndarray, n: int, n_methods: int, where) -> None:
    if n_gt.dtype != np.int64 or n_gt.shape != (n,) or (n_gt < 0).any():
        raise InputError(where, "its lane counts are not one count a frame")
    if n_pred.dtype != np.int64 or n_pred.shape != (n_methods, n) or (n_pred < 0).any():
        raise InputError(where, "its predicted lane counts are not one count a frame and method")
    if (n_gt >= 1 << 20).any() or (n_pred >= 1 << 20).any():
        raise InputError(where, "a frame with more than a million lanes")


def _check_matches(matched: np.ndarray, n_gt: np.ndarray, n_pred: np.ndarray, n: int, n_methods: int,
                   where) -> None:
    """One IoU a labelled lane and method, in [0, 1] (NaN, or -inf for none matched), and no
    frame with more matched lanes than predicted ones."""
    if matched.dtype != np.float64 or matched.shape != (n_methods, int(n_gt.sum())):
        raise InputError(where, "its matched IoUs are not one a labelled lane and method")
    with np.errstate(invalid="ignore"):
        if not (np.isnan(matched) | (matched == -np.inf) | ((matched >= 0) & (matched <= 1))).all():
            raise InputError(where, "a matched IoU outside [0, 1]")
    # a ground-truth lane is matched to at most one predicted lane of its frame
    frame_of = np.repeat(np.arange(n), n_gt)
    for m in range(n_methods):
        matched_lanes = np.bincount(frame_of[matched[m] > -np.inf], minlength=n) if n else np.zeros(0, np.int64)
        if (matched_lanes > n_pred[m]).any():
            raise InputError(where, "a frame with more matched lanes than predicted ones")
