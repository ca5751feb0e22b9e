"""Result tables in the paper's layouts (Tables II-V), rendered as Markdown and LaTeX.

Display names live here: 'baseline' is the model's own extraction ("SCNN"), 'roneld' is
"SCNN + RONELD". Nothing here computes a metric; every number comes from the run's tables.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import pandas as pd

PAPER_THRESHOLDS = ("0.30", "0.40", "0.50")
ABLATION_THRESHOLDS = ("0.30", "0.50")


@dataclass(frozen=True)
class Increase:
    """An accuracy increase and its size relative to the method RONELD improves on."""

    absolute: float
    relative: float  # NaN when the base accuracy is 0
    low: float = math.nan  # 95% interval of the absolute increase (paired bootstrap over clips)
    high: float = math.nan


@dataclass(frozen=True)
class Table:
    """Headers (repeats allowed, as in the paper) and rows of str, float or Increase cells."""

    headers: tuple[str, ...]
    rows: tuple[tuple, ...]

    def to_markdown(self) -> str:
        lines = ["| " + " | ".join(self.headers) + " |", "|" + "|".join("---" for _ in self.headers) + "|"]
        for row in self.rows:
            lines.append("| " + " | ".join(_cell(value, latex=False) for value in row) + " |")
        return "\n".join(lines) + "\n"

    def to_latex(self, caption: str, label: str) -> str:
        lines = [
            "\\begin{table}[t]",
            "  \\centering",
            f"  \\caption{{{_latex_escape(caption)}}}",
            f"  \\label{{{label}}}",
            "  \\begin{tabular}{c|" + "c" * (len(self.headers) - 1) + "}",
            "    \\hline",
            "    " + " & ".join(_latex_escape(h) for h in self.headers) + " \\\\",
            "    \\hline",
        ]
        for row in self.rows:
            lines.append("    " + " & ".join(_cell(value, latex=True) for value in row) + " \\\\")
        lines += ["    \\hline", "  \\end{tabular}", "\\end{table}"]
        return "\n".join(lines) + "\n"


def _cell(value, latex: bool) -> str:
    if isinstance(value, Increase):
        percent = "n/a" if math.isnan(value.relative) else f"{value.relative * 100:.1f}%"
        interval = "" if math.isnan(value.low) else f" [{value.low:.3f}, {value.high:.3f}]"
        if latex:
            return f"{value.absolute:+.3f}{interval} \\textbf{{({percent.replace('%', chr(92) + '%')})}}"
        return f"{value.absolute:+.3f}{interval} **({percent})**"
    if isinstance(value, float):
        return "n/a" if math.isnan(value) else f"{value:.3f}"
    return _latex_escape(str(value)) if latex else str(value)


def _latex_escape(text: str) -> str:
    return text.replace("\\", "\\textbackslash{}").replace("%", "\\%").replace("&", "\\&").replace("_", "\\_")


def display_name(method: str, model: str, pft: bool = True) -> str:
    """How the paper names a method: 'SCNN', 'SCNN + RONELD', 'SCNN + RONELD w/o PFT'."""
    if method == "baseline":
        return model
    if method == "roneld":
        return f"{model} + RONELD" if pft else f"{model} + RONELD w/o PFT"
    if method == "roneld-nopft":
        return f"{model} + RONELD w/o PFT"
    return method


def table_thresholds(labels: list[str], wanted=PAPER_THRESHOLDS) -> list[str]:
    """The paper's rows when the sweep has them, else its first, middle and last thresholds."""
    wanted_values = {round(float(w), 6) for w in wanted}
    present = [label for label in labels if round(float(label), 6) in wanted_values]
    if present:
        return present
    if len(labels) <= 3:
        return list(labels)
    return [labels[0], labels[len(labels) // 2], labels[-1]]


def short_threshold(label: str) -> str:
    """'0.30' -> '0.3', as the paper prints thresholds."""
    text = label.rstrip("0")
    return text + "0" if text.endswith(".") else text


def comparison_table(accuracy: pd.DataFrame, model: str, pft: bool = True) -> Table:
    """Tables II/III: at 0.3/0.4/0.5, each method, RONELD beside it, and the increase."""
    labels = list(dict.fromkeys(accuracy["threshold"]))
    methods = list(dict.fromkeys(accuracy["method"]))
    value = {(r.method, r.threshold): float(r.accuracy) for r in accuracy.itertuples()}
    interval = {}
    if "roneld_gain_ci_low" in accuracy.columns:
        interval = {(r.method, r.threshold): (float(r.roneld_gain_ci_low), float(r.roneld_gain_ci_high))
                    for r in accuracy.itertuples()}
    others = [m for m in methods if m != "roneld"]
    headers = ["IoU threshold"]
    if "roneld" in methods and others:
        for method in others:
            headers += [display_name(method, model, pft), display_name("roneld", model, pft), "Acc. Inc."]
    else:
        headers += [display_name(m, model, pft) for m in methods]
    rows = []
    for label in table_thresholds(labels):
        row: list = [short_threshold(label)]
        if "roneld" in methods and others:
            ours = value[("roneld", label)]
            for method in others:
                base = value[(method, label)]
                relative = (ours - base) / base if base else math.nan
                low, high = interval.get((method, label), (math.nan, math.nan))
                row += [base, ours, Increase(ours - base, relative, low, high)]
        else:
            row += [value[(m, label)] for m in methods]
        rows.append(tuple(row))
    return Table(tuple(headers), tuple(rows))


def ablation_table(accuracy: pd.DataFrame, dataset: str) -> Table | None:
    """Table IV: RONELD with and without PFT at 0.3 and 0.5 (None without both runs)."""
    if not {"roneld", "roneld-nopft"} <= set(accuracy["method"]):
        return None
    labels = list(dict.fromkeys(accuracy["threshold"]))
    value = {(r.method, r.threshold): float(r.accuracy) for r in accuracy.itertuples()}
    name = {"culane": "CULane", "tusimple": "TuSimple"}.get(dataset, dataset)
    rows = tuple(
        (short_threshold(label), value[("roneld-nopft", label)], value[("roneld", label)])
        for label in table_thresholds(labels, ABLATION_THRESHOLDS)
    )
    return Table(("IoU threshold", f"{name} w/o PFT", f"{name} w/ PFT"), rows)


def runtime_table(runtime: pd.DataFrame, model: str, pft: bool = True) -> Table:
    """Table V: milliseconds per frame of extraction alone, map loading apart."""
    rows = []
    for row in runtime.itertuples(index=False):
        name = "Map loading" if row.method == "map loading" else display_name(row.method, model, pft)
        rows.append((name, str(row.frames), float(row.mean_ms), float(row.median_ms), float(row.p95_ms)))
    return Table(("Method", "Frames", "Mean (ms)", "Median (ms)", "p95 (ms)"), tuple(rows))
