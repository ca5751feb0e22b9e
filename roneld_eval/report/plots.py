"""Accuracy-against-threshold curves (the paper's Fig. 5) from the accuracy table.

One line per method, told apart by marker and dash as well as colour so that greyscale
prints stay readable. Legends name methods by their method name alone, and a note under each
figure states the configuration behind its numbers (map size, thicknesses, IoU threshold).
Output bytes are reproducible (no dates, fixed SVG ids).
"""

from __future__ import annotations

import re
import textwrap
from pathlib import Path
from typing import Any

import matplotlib

matplotlib.use("Agg")
# Labels are model and method names, never mathtext: "$\\input{x}$" must print as typed.
matplotlib.rcParams["text.parse_math"] = False
import matplotlib.pyplot as plt  # noqa: E402
import pandas as pd  # noqa: E402

from ..benchmarks import CategoryPanel  # noqa: E402
from ..config import EGO_LANES_ONLY  # noqa: E402
from ..methods import METHOD_TABLE  # noqa: E402
from ..errors import InputError  # noqa: E402
from .tables import Protocol, clips_text, dataset_name, display_name  # noqa: E402

STYLES: dict[str, dict[str, Any]] = {  # matplotlib line properties
    name: dict(color=facts.colour, marker=facts.marker, linestyle=facts.linestyle)
    for name, facts in METHOD_TABLE.items()
}


def _note(figure, lines: list[str], width: int) -> float:
    """Wrapped small text at the bottom of the figure; returns the height in inches it takes."""
    keep = re.compile(r"(\d) (px|clips?)\b")  # '30 px' stays on one line
    text = "\n".join(textwrap.fill(keep.sub("\\1\u00a0\\2", line), width) for line in lines if line)
    if not text:
        return 0.0
    figure.text(0.01, 0.01, text, fontsize=7.5, color="#333333", ha="left", va="bottom")
    return (text.count("\n") + 1) * 7.5 * 1.35 / 72 + 0.08


# Text extents in inches at the default 10 pt, for margins set without drawing the figure to
# measure its labels: tight_layout did that, at a quarter of a fixture run's wall time.
_CHAR_IN = 0.6 * 10 / 72  # DejaVu Sans averages under 0.6 em a character
_LINE_IN = 1.2 * 10 / 72
_TICK_IN = 8 / 72  # tick length and its label's pad
_GAP_IN = 0.06


# A legend entry's marker and the space around its name, in inches at 10 pt (matplotlib's
# handlelength 2 em, handletextpad 0.8 em, borderpad and borderaxespad 0.5 em each side).
_LEGEND_HANDLE_IN = (2.0 + 0.8 + 2 * 0.5 + 2 * 0.5) * 10 / 72


def _wrapped(name: str, inches: float, points: float = 10.0) -> str:
    """A legend name in lines at most `inches` wide at `points` (a long model name would run off the
    figure); words are kept whole where they fit a line."""
    return textwrap.fill(name, max(8, int(inches / (_CHAR_IN * points / 10))), break_on_hyphens=False)


def _panel_width(width: float, left: float, right: float, between: float, panels: int) -> float:
    """Inches of each of `panels` side by side in a figure `width` wide, within these margins."""
    return (width - left - right - between * (panels - 1)) / panels


def _place_axes(figure, left: float, bottom: float, right: float, top: float, between: float = 0.0) -> None:
    """The axes inside these margins (inches), `between` inches apart."""
    width, height = figure.get_size_inches()
    panels = max(len(figure.axes), 1)
    panel = _panel_width(width, left, right, between, panels)
    figure.subplots_adjust(left=left / width, bottom=bottom / height, right=1 - right / width, top=1 - top / height,
                           wspace=between / panel if panels > 1 else None)


def accuracy_figure(accuracy: pd.DataFrame, model: str, dataset: str, protocol: Protocol | None = None):
    """A matplotlib Figure of accuracy against IoU threshold.

    `dataset`: 'culane', 'tusimple' or any label ("the bundled CULane fixture (synthetic)");
    `protocol`: the configuration stated under the plot.
    """
    figure, axes = plt.subplots(figsize=(6.4, 4.4), dpi=150)
    left, right = _TICK_IN + 5 * _CHAR_IN + 2 * _GAP_IN + _LINE_IN, 3 * _CHAR_IN
    # The legend lies inside the axes: its names are wrapped to their width.
    name_in = _panel_width(figure.get_figwidth(), left, right, 0.0, 1) - _LEGEND_HANDLE_IN
    for method in dict.fromkeys(accuracy["method"]):
        rows = accuracy[accuracy["method"] == method]
        style = STYLES.get(method, dict(marker="x", linestyle="-."))
        axes.plot(rows["threshold"].astype(float), rows["accuracy"],
                  label=_wrapped(display_name(method, model), name_in), markersize=4, linewidth=1.6, **style)
    axes.set_title(f"Ego-lane accuracy on {dataset_name(dataset)}", fontsize=10)
    axes.set_xlabel("IoU threshold (a true positive needs IoU > threshold)")
    axes.set_ylabel("Accuracy (N_TP / N_gt)")
    axes.grid(True, alpha=0.3)
    axes.legend(loc="lower left", frameon=True)
    low = max(0.0, float(accuracy["accuracy"].min()) - 0.05)
    axes.set_ylim(low, min(1.0, float(accuracy["accuracy"].max()) + 0.05) if len(accuracy) else 1.0)
    note = []
    if protocol is not None:
        clips = "" if protocol.clips is None else f"; {clips_text(protocol.clips)}"
        note.append(f"RONELD paper's protocol: {protocol.paper()}{clips}.")
    # Room for y tick labels of up to 5 characters ("0.925") and the y label; below, the x tick
    # labels, the x label and the note; above, the title; right, half the last x tick label.
    _place_axes(figure, left=left, bottom=_note(figure, note, 100) + _TICK_IN + 2 * _LINE_IN + 2 * _GAP_IN,
                right=right, top=_LINE_IN + 3 * _GAP_IN)
    return figure


def save_figure(figure, png: Path, svg: Path | None = None) -> None:
    """PNG (and SVG) without timestamps, so the same numbers give the same bytes."""
    try:
        with matplotlib.rc_context({"svg.hashsalt": "roneld-eval"}):
            for path, metadata in ((png, {"Software": None}), (svg, {"Date": None, "Creator": None})):
                if path is None:
                    continue
                try:
                    figure.savefig(path, metadata=metadata)
                except OSError as error:  # disk full, quota: name the picture, not matplotlib's internals
                    raise InputError.unwritable(path, error) from None
    finally:
        plt.close(figure)


HATCHES = {name: facts.hatch for name, facts in METHOD_TABLE.items()}


def category_figure(categories: pd.DataFrame, panel: CategoryPanel | None, model: str, threshold_label: str,
                    protocol: Protocol | None = None):
    """Grouped bars per category: the paper's accuracy (left) and, where the benchmark gives one
    (`Benchmark.category_panel`), its official score by category (right).

    `threshold_label`: the IoU threshold of both panels (the official one); `protocol`: the
    configuration stated under the bars.
    """
    import numpy as np

    names = [c for c in dict.fromkeys(categories["category"])]
    methods = list(dict.fromkeys(categories["method"]))
    panels = [("accuracy", categories, f"Ego-lane accuracy, paper's protocol (IoU > {threshold_label})")]
    if panel is not None:
        panels.append(("score", panel.table[panel.table["category"].isin(names)],
                       f"{panel.title} (IoU > {threshold_label})"))
    figure, axes = plt.subplots(1, len(panels), figsize=(6.2 * len(panels), 4.6), dpi=150, squeeze=False)
    # One legend above the panels, a column per method: each name wrapped to its column (9 pt).
    column_in = (figure.get_figwidth() - 2 * _GAP_IN) / max(len(methods), 1) - _LEGEND_HANDLE_IN * 0.9
    shown = {method: _wrapped(display_name(method, model), column_in, 9.0) for method in methods}
    width = 0.8 / max(len(methods), 1)
    positions = np.arange(len(names))
    for ax, (column, table, title) in zip(axes[0], panels):
        for k, method in enumerate(methods):
            rows = table[table["method"] == method].set_index("category").reindex(names)
            style = STYLES.get(method, {})
            ax.bar(positions + (k - (len(methods) - 1) / 2) * width, rows[column].fillna(0), width,
                   label=shown[method], color=style.get("color", "#777777"),
                   hatch=HATCHES.get(method, "xx"), edgecolor="black", linewidth=0.6)
        ax.set_xticks(positions, names, rotation=30, ha="right")
        ax.set_ylim(0, 1.05)
        ax.set_title(title, fontsize=10)
        ax.grid(True, axis="y", alpha=0.3)
    handles, labels = axes[0][0].get_legend_handles_labels()
    figure.legend(handles, labels, loc="upper center", ncol=len(methods), fontsize=9, frameon=False)
    note = []
    if protocol is not None:
        note.append(f"Accuracy: {protocol.paper()}.")
        if panel is not None and panel.settings is not None:
            note.append(f"{panel.score_name}: {panel.settings}.")
    ego_only = [display_name(method, model) for method in methods if method in EGO_LANES_ONLY]
    if panel is not None and ego_only:
        note.append(f"{' and '.join(ego_only)} output{'s' if len(ego_only) == 1 else ''} the two ego lanes only: "
                    f"{panel.ego_lanes_note}.")
    lines = max((name.count("\n") + 1 for name in shown.values()), default=1)
    legend_in = 0.4 + (lines - 1) * 9 * 1.25 / 72  # the legend's rows, each 9 pt and its spacing
    # Category names are tick labels turned 30 degrees, ending at their tick: the longest sets
    # the room below the axes, and how far any reaches left of the axes (a tick lies (k + 1/2) / n
    # of the panel's width in) the room beside them and between the panels.
    longest = max((len(str(name)) for name in names), default=0) * _CHAR_IN
    y_labels = _TICK_IN + 4 * _CHAR_IN + 2 * _GAP_IN  # "1.0" and its tick, the least room beside a panel
    beside = y_labels
    for _ in range(2):  # the panels' width depends on the room beside them
        panel_in = _panel_width(figure.get_figwidth(), beside, _GAP_IN * 3, beside + _GAP_IN, len(panels))
        reach = max((len(str(name)) * _CHAR_IN * 0.87 - (k + 0.5) / len(names) * panel_in
                     for k, name in enumerate(names)), default=0.0)
        beside = max(y_labels, reach + _GAP_IN)
    _place_axes(figure, left=beside, bottom=_note(figure, note, 100 * len(panels)) + _TICK_IN + longest * 0.5
                + _LINE_IN * 0.87 + 2 * _GAP_IN, right=_GAP_IN * 3, top=legend_in + _LINE_IN + 2 * _GAP_IN,
                between=beside + _GAP_IN)
    return figure
