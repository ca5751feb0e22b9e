"""Fig. 5 of the RONELD paper for many runs: accuracy against IoU threshold, one panel per dataset.

Colour tells the model (run label) and line style and marker the method, the same in every
panel, so one legend serves all. Several runs of one model (seeds) draw their mean with a band
of ± one standard deviation. The axes say what is plotted; there is no title (a paper's caption
says what the figure is), and each panel names its dataset in a corner. Computes nothing but
means and deviations of the curves it is given; bytes are reproducible (no dates, fixed ids).
"""

from __future__ import annotations

from dataclasses import dataclass

import matplotlib

matplotlib.use("Agg")
# Labels are model and method names, never mathtext: "$\\input{x}$" must print as typed.
matplotlib.rcParams["text.parse_math"] = False
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from matplotlib.lines import Line2D  # noqa: E402

from ..methods import METHOD_TABLE  # noqa: E402

# Colour-blind-safe (Okabe-Ito), then matplotlib's tab10 for more models.
COLOURS = ("#0072B2", "#D55E00", "#009E73", "#CC79A7", "#E69F00", "#56B4E9", "#000000", "#F0E442",
           "#1f77b4", "#ff7f0e", "#2ca02c", "#d62728", "#9467bd", "#8c564b", "#e377c2", "#7f7f7f")
METHOD_STYLES = {name: dict(linestyle=facts.linestyle, marker=facts.marker) for name, facts in METHOD_TABLE.items()}
OTHER_STYLES = (dict(linestyle="-.", marker="D"), dict(linestyle=(0, (5, 1, 1, 1, 1, 1)), marker="v"),
                dict(linestyle=(0, (1, 1)), marker="P"), dict(linestyle=(0, (8, 2)), marker="X"))


@dataclass(frozen=True)
class Curve:
    """One model's one method on one dataset: accuracy per threshold of each run behind it."""

    dataset: str  # display name, e.g. "CULane"
    model: str  # the run label
    method: str
    name: str  # legend text, e.g. "SCNN + RONELD"
    thresholds: tuple[float, ...]
    runs: tuple[tuple[float, ...], ...]  # one accuracy sequence per run


def method_style(method: str, others: list[str]) -> dict:
    if method in METHOD_STYLES:
        return METHOD_STYLES[method]
    return OTHER_STYLES[others.index(method) % len(OTHER_STYLES)]


def _draw_curve(ax, curve: Curve, colour: str, width: float, others: list[str]) -> tuple[float, float]:
    """One curve, the mean over its runs with a band of one standard deviation where it has
    several; the lowest and highest value drawn."""
    values = np.array(curve.runs, np.float64)
    mean = values.mean(axis=0)
    x = np.array(curve.thresholds)
    ax.plot(x, mean, color=colour, linewidth=width, markersize=3.5, markevery=max(1, len(x) // 10),
            **method_style(curve.method, others))
    if len(values) > 1:
        sd = values.std(axis=0, ddof=1)
        ax.fill_between(x, mean - sd, mean + sd, color=colour, alpha=0.15, linewidth=0)
        return float((mean - sd).min()), float((mean + sd).max())
    return float(mean.min()), float(mean.max())


def _legend_entries(curves: list[Curve], methods: list[str], models: list[str], colour: dict, width: dict,
                    others: list[str]) -> tuple[list, list[str]]:
    """The legend: a row per model, a column per method (matplotlib fills legends column by
    column), an empty slot where a model has no curve of a method."""
    drawn = {(c.model, c.method): c for c in curves}
    counts: dict[tuple[str, str], dict[str, int]] = {}  # runs behind each curve, per panel
    for c in curves:
        counts.setdefault((c.model, c.method), {})[c.dataset] = len(c.runs)
    handles, labels = [], []
    for method in methods:
        for model in models:
            shown = drawn.get((model, method))
            if shown is None:
                handles.append(Line2D([], [], linestyle="none"))
                labels.append("")
                continue
            handles.append(Line2D([], [], color=colour[model], linewidth=width[model], markersize=3.5,
                                  **method_style(method, others)))
            labels.append(shown.name + _runs_text(counts[(model, method)]))
    return handles, labels


def curves_figure(curves: list[Curve]):
    """The figure: a panel per dataset (in order of first appearance), a shared legend below."""
    datasets = list(dict.fromkeys(c.dataset for c in curves))
    models = list(dict.fromkeys(c.model for c in curves))
    others = list(dict.fromkeys(c.method for c in curves if c.method not in METHOD_STYLES))
    colour = {model: COLOURS[k % len(COLOURS)] for k, model in enumerate(models)}
    # Earlier models draw wider lines, so a curve another model's covers exactly still shows at its edges.
    width = {model: 1.4 + 0.7 * (len(models) - 1 - k) / max(1, len(models) - 1) for k, model in enumerate(models)}
    panels = len(datasets)
    figure, axes = plt.subplots(1, panels, figsize=(3.6 * panels + 0.4, 3.5), dpi=150, squeeze=False,
                                sharey=True)
    low, high = 1.0, 0.0
    for ax, dataset in zip(axes[0], datasets):
        for curve in (c for c in curves if c.dataset == dataset):
            bottom, top = _draw_curve(ax, curve, colour[curve.model], width[curve.model], others)
            low, high = min(low, bottom), max(high, top)
        ax.text(0.97, 0.96, dataset, transform=ax.transAxes, ha="right", va="top", fontsize=9,
                bbox=dict(boxstyle="round,pad=0.25", facecolor="white", edgecolor="#999999", linewidth=0.6))
        ax.set_xlabel("IoU threshold")
        ax.grid(True, alpha=0.3)
    axes[0][0].set_ylabel("accuracy (N_TP / N_gt)")
    if high >= low:  # a curve at 1.0 stays visible above the axis' top
        axes[0][0].set_ylim(max(0.0, low - 0.05), min(1.02, high + 0.05))
    methods = list(dict.fromkeys(c.method for c in curves))
    handles, labels = _legend_entries(curves, methods, models, colour, width, others)
    legend = figure.legend(handles, labels, loc="lower center", ncol=len(methods), fontsize=7.5, frameon=False,
                           columnspacing=1.2, handlelength=2.6, numpoints=2)
    # Measured, not guessed: one panel is narrower than a legend of three methods' names.
    box = legend.get_window_extent()
    margin_in = 0.15
    if box.width / figure.dpi + 2 * margin_in > figure.get_figwidth():
        figure.set_figwidth(box.width / figure.dpi + 2 * margin_in)
    legend_in = box.height / figure.dpi + 0.08
    figure.tight_layout(rect=(0, min(0.6, legend_in / figure.get_figheight()), 1, 1))
    return figure


def _runs_text(counts: dict[str, int]) -> str:
    """'' for single runs; ' (mean ± sd, n = 3)', or with n per panel where it differs."""
    if max(counts.values()) == 1:
        return ""
    if len(set(counts.values())) == 1:
        return f" (mean ± sd, n = {next(iter(counts.values()))})"
    return " (mean ± sd, n = " + ", ".join(f"{n} {dataset}" for dataset, n in counts.items()) + ")"
