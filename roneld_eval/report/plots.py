"""Accuracy-against-threshold curves (the paper's Fig. 5) from the accuracy table.

One line per method, told apart by marker and dash as well as colour so that greyscale
prints stay readable. Output bytes are reproducible (no dates, fixed SVG ids).
"""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import pandas as pd  # noqa: E402

from .tables import display_name  # noqa: E402

STYLES = {
    "baseline": dict(color="#d62728", marker="o", linestyle="--"),
    "roneld": dict(color="#2ca02c", marker="s", linestyle="-"),
    "roneld-nopft": dict(color="#1f77b4", marker="^", linestyle=":"),
}


def accuracy_figure(accuracy: pd.DataFrame, model: str, dataset: str, pft: bool = True):
    """A matplotlib Figure of accuracy against IoU threshold."""
    figure, axes = plt.subplots(figsize=(6.4, 4.0), dpi=150)
    for method in dict.fromkeys(accuracy["method"]):
        rows = accuracy[accuracy["method"] == method]
        style = STYLES.get(method, dict(marker="x", linestyle="-."))
        axes.plot(rows["threshold"].astype(float), rows["accuracy"], label=display_name(method, model, pft),
                  markersize=4, linewidth=1.6, **style)
    name = {"culane": "CULane", "tusimple": "TuSimple"}.get(dataset, dataset)
    axes.set_title(f"Active-lane accuracy on {name}")
    axes.set_xlabel("IoU threshold")
    axes.set_ylabel("Accuracy (N_TP / N_gt)")
    axes.grid(True, alpha=0.3)
    axes.legend(loc="lower left", frameon=True)
    low = max(0.0, float(accuracy["accuracy"].min()) - 0.05)
    axes.set_ylim(low, min(1.0, float(accuracy["accuracy"].max()) + 0.05) if len(accuracy) else 1.0)
    figure.tight_layout()
    return figure


def save_figure(figure, png: Path, svg: Path | None = None) -> None:
    """PNG (and SVG) without timestamps, so the same numbers give the same bytes."""
    with matplotlib.rc_context({"svg.hashsalt": "roneld-eval"}):
        figure.savefig(png, metadata={"Software": None})
        if svg is not None:
            figure.savefig(svg, metadata={"Date": None, "Creator": None})
    plt.close(figure)


HATCHES = {"baseline": "//", "roneld": "", "roneld-nopft": ".."}


def category_figure(categories: pd.DataFrame, official: pd.DataFrame | None, model: str, threshold_label: str,
                    pft: bool = True):
    """Grouped bars per CULane category: the paper's accuracy (left) and the official F1 (right)."""
    import numpy as np

    names = [c for c in dict.fromkeys(categories["category"])]
    methods = list(dict.fromkeys(categories["method"]))
    panels = [("accuracy", categories, f"Active-lane accuracy (IoU > {threshold_label})")]
    if official is not None and "f1" in official.columns:
        panels.append(("f1", official[official["category"].isin(names)], "Official CULane F1 (all lanes)"))
    figure, axes = plt.subplots(1, len(panels), figsize=(6.2 * len(panels), 4.2), dpi=150, squeeze=False)
    width = 0.8 / max(len(methods), 1)
    positions = np.arange(len(names))
    for ax, (column, table, title) in zip(axes[0], panels):
        for k, method in enumerate(methods):
            rows = table[table["method"] == method].set_index("category").reindex(names)
            style = STYLES.get(method, {})
            ax.bar(positions + (k - (len(methods) - 1) / 2) * width, rows[column].fillna(0), width,
                   label=display_name(method, model, pft), color=style.get("color", "#777777"),
                   hatch=HATCHES.get(method, "xx"), edgecolor="black", linewidth=0.6)
        ax.set_xticks(positions, names, rotation=30, ha="right")
        ax.set_ylim(0, 1.05)
        ax.set_title(title, fontsize=10)
        ax.grid(True, axis="y", alpha=0.3)
    handles, labels = axes[0][0].get_legend_handles_labels()
    figure.legend(handles, labels, loc="upper center", ncol=len(methods), fontsize=9, frameon=False)
    figure.tight_layout(rect=(0, 0, 1, 0.92))
    return figure
