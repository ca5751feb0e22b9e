"""The run's tables from its per-frame rows: accuracy gains with paired-bootstrap intervals (each
pair once), runtime, and the versions that shape the numbers."""

from __future__ import annotations

import platform
from typing import TYPE_CHECKING, Mapping, Sequence

import numpy as np

from ..methods import GAIN_REFERENCES, RONELD
from ..metrics.bootstrap import paired_bootstrap
from ..version import __version__

if TYPE_CHECKING:  # annotations only: a run forks its workers before pandas is imported
    import pandas as pd


class PairedGains:
    """Accuracy gains with their 95% paired-bootstrap intervals over clips, each pair bootstrapped
    once however many tables show it (accuracy.csv's RONELD gain and gains.csv share some)."""

    def __init__(self, per_frame: pd.DataFrame, thresholds):
        self.per_frame, self.thresholds = per_frame, thresholds
        self._done: dict[tuple[str, str], pd.DataFrame] = {}

    def of(self, method: str, over: str) -> pd.DataFrame:
        """threshold, difference (`method` - `over` accuracy), ci_low, ci_high."""
        key = (method, over)
        if key not in self._done:
            self._done[key] = paired_bootstrap(self.per_frame, self.thresholds, over, reference=method)
        return self._done[key]


def with_intervals(accuracy: pd.DataFrame, gains: PairedGains) -> pd.DataFrame:
    """Add RONELD's gain over each other method with its 95% paired-bootstrap interval over clips."""
    accuracy = accuracy.copy()
    for column in ("roneld_gain", "roneld_gain_ci_low", "roneld_gain_ci_high"):
        accuracy[column] = np.nan
    methods = set(accuracy["method"])
    if RONELD.name not in methods or gains.per_frame.empty:
        return accuracy
    for method in sorted(methods - {RONELD.name}):
        gain = gains.of(RONELD.name, over=method)
        rows = (accuracy["method"] == method).to_numpy()
        accuracy.loc[rows, "roneld_gain"] = gain["difference"].to_numpy()
        accuracy.loc[rows, "roneld_gain_ci_low"] = gain["ci_low"].to_numpy()
        accuracy.loc[rows, "roneld_gain_ci_high"] = gain["ci_high"].to_numpy()
    return accuracy


def pairwise_gains(gains: PairedGains, methods: Sequence[str]) -> pd.DataFrame:
    """method, reference, threshold, gain (method - reference accuracy), ci_low, ci_high: every
    method against each of GAIN_REFERENCES the run has."""
    tables = []
    for reference in GAIN_REFERENCES:
        if reference not in methods or gains.per_frame.empty:
            continue
        for method in methods:
            if method == reference:
                continue
            table = gains.of(method, over=reference).rename(columns={"difference": "gain"})
            table.insert(0, "reference", reference)
            table.insert(0, "method", method)
            tables.append(table)
    import pandas as pd

    columns = ["method", "reference", "threshold", "gain", "ci_low", "ci_high"]
    return pd.concat(tables, ignore_index=True)[columns] if tables else pd.DataFrame(columns=columns)



def _runtime_table(extract_ms: Mapping[str, Sequence[float]], load_ms: Sequence[float]) -> pd.DataFrame:
    import pandas as pd

    rows = []
    for name, times in list(extract_ms.items()) + [("map loading", load_ms)]:
        values = np.asarray(times, np.float64)
        if values.size == 0:
            continue
        rows.append(dict(
            method=name, frames=int(values.size), mean_ms=float(values.mean()),
            median_ms=float(np.median(values)), p95_ms=float(np.percentile(values, 95)),
        ))
    return pd.DataFrame(rows, columns=["method", "frames", "mean_ms", "median_ms", "p95_ms"])



def versions() -> dict:
    """Versions of the tool, Python and the libraries that shape the numbers."""
    import importlib.metadata as metadata

    out: dict[str, str | None] = {"roneld-eval": __version__, "python": platform.python_version(),
                                  "platform": platform.platform()}
    packages = ("numpy", "numba", "llvmlite", "scipy", "opencv-python-headless", "pandas", "matplotlib", "click",
                "tqdm")
    for package in packages:
        try:
            out[package] = metadata.version(package)
        except metadata.PackageNotFoundError:
            out[package] = None
    return out
