"""Accuracy-against-threshold curves (the paper's Fig. 5) from the accuracy table.

One line per method, told apart by marker and dash as well as colour so that greyscale
prints stay readable. Legends name methods by their method name alone, and a note under each
figure states the configuration behind its numbers (map size, thicknesses, IoU threshold).
Output bytes are reproducible (no dates, fixed SVG ids).
"""

from __future__ import annotations

import functools
import re
import textwrap
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
from ..wording import ego_lanes_only  # noqa: E402
from .tables import Protocol, clips_text, name_parts  # noqa: E402

STYLES: dict[str, dict[str, Any]] = {  # matplotlib line properties
    name: dict(color=facts.colour, marker=facts.marker, linestyle=facts.linestyle)
    for name, facts in METHOD_TABLE.items()
}


def _note(figure, lines: list[str], width: int) -> float:
    """Wrapped small text at the bottom of the figure; returns the height in inches it takes."""
    keep = re.compile(r"(\d) (px|clips?)\b")  # '30 px' stays on one line
    room = figure.get_figwidth() * 0.96  # it starts 1% in; rendered text runs a little wider than measured
    filled = []
    for line in (keep.sub("\\1\u00a0\\2", line) for line in lines if line):
        wrapped = textwrap.fill(line, width).splitlines()
        if any(_text_in(part, 7.5) > room for part in wrapped):  # wide letters (a model's name): measured
            wrapped = _lines(line, room, 7.5)
        filled += wrapped
    text = "\n".join(filled)
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
# Titles sit just above their axes, where matplotlib's automatic placement puts them whenever
# nothing (top tick labels, an offset text) is drawn above the axes, which is never the case
# here: fixed, they are the same pixels without measuring every tick label at each draw (12 ms
# of a fixture report's 300).
_TITLE_Y = 1.0


# A legend entry's marker and the space around its name, in inches at 10 pt (matplotlib's
# handlelength 2 em, handletextpad 0.8 em, borderpad and borderaxespad 0.5 em each side).
_LEGEND_HANDLE_IN = (2.0 + 0.8 + 2 * 0.5 + 2 * 0.5) * 10 / 72


def _text_in(text: str, points: float) -> float:
    """The width of one line of text in inches, from the font's own metrics (a W is twice an
    average letter, a CJK character wider still), without drawing a figure."""
    from matplotlib.font_manager import FontProperties

    return _measured(text, FontProperties(size=points))  # the rcParams' font now, at that size


@functools.lru_cache(maxsize=4096)
def _measured(text: str, font) -> float:
    # A width took about 0.5 ms, and every figure of a process measures the same names again (a
    # sweep reports each checkpoint; compare draws every run's methods). FontProperties hashes
    # and compares by every property the width depends on.
    from matplotlib.textpath import text_to_path

    width, _, _ = text_to_path.get_text_width_height_descent(text, font, ismath=False)
    return width / 72


def _lines(text: str, inches: float, points: float) -> list[str]:
    """`text` wrapped at spaces into lines at most `inches` wide at `points`, a word wider than a
    line cut."""
    inches = max(inches, 0.5)

    def longest_fitting(word: str) -> int:  # characters of the word's widest start that fits, at least one
        low, high = 1, len(word)
        while low < high:
            middle = (low + high + 1) // 2
            low, high = (middle, high) if _text_in(word[:middle], points) <= inches else (low, middle - 1)
        return low

    lines: list[str] = []
    for word in text.split(" "):  # not at no-break spaces
        if not word:
            continue
        if lines and _text_in(f"{lines[-1]} {word}", points) <= inches:
            lines[-1] += " " + word
            continue
        while word:
            cut = len(word) if _text_in(word, points) <= inches else longest_fitting(word)
            lines.append(word[:cut])
            word = word[cut:]
    return lines


def _fitted(text: str, inches: float, points: float = 10.0, most_lines: int = 2) -> str:
    """`text` in at most `most_lines` lines at most `inches` wide, what does not fit ended with an
    ellipsis (a model name of hundreds of characters pushed the axes off the figure)."""
    inches = max(inches, 0.5)  # as _lines has it
    lines = _lines(text, inches, points)
    if len(lines) > most_lines:
        last = lines[most_lines - 1]
        while len(last) > 1 and _text_in(last + "\u2026", points) > inches:
            last = last[:-1]
        lines = lines[:most_lines - 1] + [last.rstrip() + "\u2026"]
    return "\n".join(lines)


def _legend_name(method: str, model: str, inches: float, points: float = 10.0, most_lines: int = 2) -> str:
    """A method's display name fitted to a legend: where it is too long, the model's name is
    shortened and the method's own words kept ('SCNN_resnet101_cul… + RONELD w/o PFT')."""
    head, *rest = name_parts(method, model)

    def named(kept: int) -> str:
        return " ".join([head if kept == len(head) else head[:kept].rstrip() + "\u2026", *rest])

    def lines(kept: int) -> list[str]:
        return _lines(named(kept), inches, points)

    whole = lines(len(head))
    if len(whole) <= most_lines:
        return "\n".join(whole)
    low, high = 0, len(head)
    while low < high:  # the most of the model's name that fits
        middle = (low + high + 1) // 2
        low, high = (middle, high) if len(lines(middle)) <= most_lines else (low, middle - 1)
    shortened = lines(low)
    if len(shortened) <= most_lines:
        return "\n".join(shortened)
    return _fitted(named(len(head)), inches, points, most_lines)  # not even the method's words fit: the whole cut


def _panel_width(width: float, left: float, right: float, between: float, panels: int) -> float:
    """Inches of each of `panels` side by side in a figure `width` wide, within these margins."""
    return (width - left - right - between * (panels - 1)) / panels


def _place_axes(figure, left: float, bottom: float, right: float, top: float, between: float = 0.0) -> None:
    """The axes inside these margins (inches), `between` inches apart; the figure grows taller
    where the margins leave the axes less than 1.5 inches."""
    if figure.get_figheight() < bottom + top + 1.5:
        figure.set_figheight(bottom + top + 1.5)
    width, height = figure.get_size_inches()
    panels = max(len(figure.axes), 1)
    panel = _panel_width(width, left, right, between, panels)
    figure.subplots_adjust(left=left / width, bottom=bottom / height, right=1 - right / width, top=1 - top / height,
                           wspace=between / panel if panels > 1 else None)


def accuracy_figure(accuracy: pd.DataFrame, model: str, dataset: str, protocol: Protocol | None = None):
    """A matplotlib Figure of accuracy against IoU threshold.

    `dataset`: how the title names the data ("CULane", "the bundled CULane fixture (synthetic)");
    `protocol`: the configuration stated under the plot.
    """
    figure, axes = plt.subplots(figsize=(6.4, 4.4), dpi=150)
    left, right = _TICK_IN + 5 * _CHAR_IN + 2 * _GAP_IN + _LINE_IN, 3 * _CHAR_IN
    axes_in = _panel_width(figure.get_figwidth(), left, right, 0.0, 1)
    handles, names = [], []
    for method in dict.fromkeys(accuracy["method"]):
        rows = accuracy[accuracy["method"] == method]
        style = STYLES.get(method, dict(marker="x", linestyle="-."))
        handles += axes.plot(rows["threshold"].astype(float), rows["accuracy"], markersize=4, linewidth=1.6, **style)
        # The legend lies inside the axes: its names fitted to their width, two lines at most.
        names.append(_legend_name(method, model, axes_in - _LEGEND_HANDLE_IN))
    # Centred over the axes, so as wide as the axes and twice the right margin; on the fixture it names the model.
    title = _fitted(f"Ego-lane accuracy on {dataset}", axes_in + 2 * right - 2 * _GAP_IN)
    axes.set_title(title, fontsize=10, y=_TITLE_Y)
    axes.set_xlabel("IoU threshold (a true positive needs IoU > threshold)")
    axes.set_ylabel("Accuracy (N_TP / N_gt)")
    axes.grid(True, alpha=0.3)
    axes.legend(handles, names, loc="lower left", frameon=True)  # given: a name may begin with "_"
    low = max(0.0, float(accuracy["accuracy"].min()) - 0.05)
    axes.set_ylim(low, min(1.0, float(accuracy["accuracy"].max()) + 0.05) if len(accuracy) else 1.0)
    note = []
    if protocol is not None:
        clips = "" if protocol.clips is None else f"; {clips_text(protocol.clips)}"
        note.append(f"RONELD paper's protocol: {protocol.paper()}{clips}.")
    # Room for y tick labels of up to 5 characters ("0.925") and the y label; below, the x tick
    # labels, the x label and the note; above, the title; right, half the last x tick label.
    _place_axes(figure, left=left, bottom=_note(figure, note, 100) + _TICK_IN + 2 * _LINE_IN + 2 * _GAP_IN,
                right=right, top=(title.count("\n") + 1) * _LINE_IN + 3 * _GAP_IN)
    return figure


HATCHES = {name: facts.hatch for name, facts in METHOD_TABLE.items()}


def _category_note(panel: CategoryPanel | None, model: str, methods: list[str],
                   protocol: Protocol | None) -> list[str]:
    """What stands under the bars: the protocols of both panels, and what an all-lanes score
    makes of the methods that output the ego lanes only."""
    note = []
    if protocol is not None:
        note.append(f"Accuracy: {protocol.paper()}.")
        if panel is not None and panel.settings is not None:
            note.append(f"{panel.score_name}: {panel.settings}.")
    # Shortened as in the legend, the method's words kept: RONELD with and without PFT stay apart.
    ego_only = [_legend_name(method, model, 4.0, 7.5, most_lines=1) for method in methods if method in EGO_LANES_ONLY]
    if panel is not None and ego_only:
        note.append(f"{ego_lanes_only(ego_only)}: {panel.ego_lanes_note}.")
    return note


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
    # One legend above the panels, a column per method: each name fitted to its column (9 pt).
    column_in = (figure.get_figwidth() - 2 * _GAP_IN) / max(len(methods), 1) - _LEGEND_HANDLE_IN * 0.9
    shown = {method: _legend_name(method, model, column_in, 9.0, most_lines=3) for method in methods}
    handles = []
    width = 0.8 / max(len(methods), 1)
    positions = np.arange(len(names))
    for ax, (column, table, title) in zip(axes[0], panels):
        for k, method in enumerate(methods):
            rows = table[table["method"] == method].set_index("category").reindex(names)
            style = STYLES.get(method, {})
            bars = ax.bar(positions + (k - (len(methods) - 1) / 2) * width, rows[column].fillna(0), width,
                          color=style.get("color", "#777777"), hatch=HATCHES.get(method, "xx"), edgecolor="black",
                          linewidth=0.6)
            if ax is axes[0][0]:
                handles.append(bars)
        ax.set_xticks(positions, names, rotation=30, ha="right")
        ax.set_ylim(0, 1.05)
        ax.set_title(title, fontsize=10, y=_TITLE_Y)
        ax.grid(True, axis="y", alpha=0.3)
    # The names given, not collected: matplotlib leaves out a name that begins with "_"
    figure.legend(handles, list(shown.values()), loc="upper center", ncol=len(methods), fontsize=9, frameon=False)
    note = _category_note(panel, model, methods, protocol)
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
