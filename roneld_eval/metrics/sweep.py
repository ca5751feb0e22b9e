"""Accuracy over a sweep of IoU thresholds from stored per-lane IoUs (geometry never again).

accuracy(t) = N_TP(t) / N_gt with a true positive when IoU > t (strictly); sums first,
the division last, so per-clip counts combine exactly.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from ..thresholds import Thresholds

if TYPE_CHECKING:  # annotations only: a run forks its workers before pandas is imported
    import pandas as pd


def sweep_counts(ious: np.ndarray, thresholds: Thresholds) -> np.ndarray:
    """Number of IoUs strictly above each threshold."""
    ious = np.asarray(ious, np.float64)
    # A threshold at a time: a (thresholds, IoUs) table of comparisons would take 21 bytes per
    # IoU at once, a long run's main process growing with its frames.
    return np.array([np.count_nonzero(ious > limit) for limit in thresholds.values], np.int64)


def sweep_accuracy(per_frame: pd.DataFrame, thresholds: Thresholds, methods=None) -> pd.DataFrame:
    """method, threshold, n_tp, n_gt, accuracy for every method and threshold."""
    import pandas as pd

    if methods is None:
        methods = list(dict.fromkeys(per_frame["method"]))
    rows = []
    for method in methods:
        ious = per_frame.loc[per_frame["method"] == method, "iou"].to_numpy(np.float64)
        counts = sweep_counts(ious, thresholds)
        for label, n_tp in zip(thresholds.labels, counts.tolist()):
            n_gt = len(ious)
            rows.append(dict(method=method, threshold=label, n_tp=n_tp, n_gt=n_gt,
                             accuracy=n_tp / n_gt if n_gt else float("nan")))
    return pd.DataFrame(rows, columns=["method", "threshold", "n_tp", "n_gt", "accuracy"])


def category_accuracy(per_frame: pd.DataFrame, categories, threshold: float, methods=None) -> pd.DataFrame:
    """category, method, n_tp, n_gt, accuracy at one threshold, per category list and 'all'."""
    import pandas as pd

    if methods is None:
        methods = list(dict.fromkeys(per_frame["method"]))
    groups = [(name, per_frame["frame"].isin(members)) for name, members in categories.items()]
    groups.append(("all", pd.Series(True, index=per_frame.index)))
    rows = []
    for name, inside in groups:
        for method in methods:
            ious = per_frame.loc[inside & (per_frame["method"] == method), "iou"].to_numpy(np.float64)
            n_tp = int(np.count_nonzero(ious > threshold))
            rows.append(dict(category=name, method=method, n_tp=n_tp, n_gt=len(ious),
                             accuracy=n_tp / len(ious) if len(ious) else float("nan")))
    return pd.DataFrame(rows, columns=["category", "method", "n_tp", "n_gt", "accuracy"])
