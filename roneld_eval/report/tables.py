"""Result tables in the paper's layouts (Tables II-V), rendered as Markdown and LaTeX.

Display names live here and come from the method name alone: 'baseline' is the model's own
extraction ("SCNN"), 'roneld' RONELD with preceding-frame tracking ("SCNN + RONELD"),
'roneld-nopft' RONELD without it ("SCNN + RONELD w/o PFT"). So is the wording of the
configuration every label states (`Protocol`: map size, thicknesses, IoU threshold, clips).
Nothing here computes a metric; every number comes from the run's tables.
"""

from __future__ import annotations

import math
import re
from decimal import ROUND_HALF_UP, Decimal
from dataclasses import dataclass, fields
from typing import TYPE_CHECKING

from ..config import EvalConfig
from ..errors import RoneldEvalError
from ..geometry import EffectiveGeometry
from ..metrics.bootstrap import LEVEL, MIN_CLIPS, count_clips
from ..methods import ABLATION_PAIR, PAPER, facts_of
from ..wording import counted

if TYPE_CHECKING:  # only annotations use it: `score culane` renders its tables without pandas
    import pandas as pd

PAPER_THRESHOLDS = ("0.30", "0.40", "0.50")
ABLATION_THRESHOLDS = ("0.30", "0.50")


# ---- names -------------------------------------------------------------------------------

def name_parts(method: str, model: str) -> tuple[str, ...]:
    """A method's display name in the pieces a stacked table header puts on separate lines."""
    facts = facts_of(method)
    return (method,) if facts is None else (model, *facts.after_model)


def display_name(method: str, model: str) -> str:
    """How the paper names a method: 'SCNN', 'SCNN + RONELD', 'SCNN + RONELD w/o PFT'."""
    return " ".join(name_parts(method, model))


# ---- the configuration behind the numbers ---------------------------------------------------

def configured_geometry(config: EvalConfig) -> EffectiveGeometry:
    """What `config` draws on maps of its own size: the stand-in when a run recorded nothing."""
    paper, maps = config.paper, config.maps
    crop_bottom = config.dataset.image_height if maps.crop_bottom_px is None else maps.crop_bottom_px
    return EffectiveGeometry(
        image_width=config.dataset.image_width, image_height=config.dataset.image_height,
        map_width=maps.width, map_height=maps.height, crop_top_px=maps.crop_top_px, crop_bottom_px=crop_bottom,
        rescaled=False,
        gt_thickness_px=paper.thickness(paper.gt_thickness_px, maps.width, maps.height),
        pred_thickness_px=paper.thickness(paper.pred_thickness_px, maps.width, maps.height),
        official_lane_width_px=config.official.lane_width_px,
        official_iou_threshold=config.official.iou_threshold,
    )


@dataclass(frozen=True)
class Protocol:
    """The configuration that produced a run's numbers, in the words every label uses."""

    geometry: EffectiveGeometry
    clips: int | None = None  # clips scored: the unit of the bootstrap
    recorded: bool = True  # False: `geometry` is the configuration's; the maps' size was not recorded

    @classmethod
    def of_run(cls, result) -> "Protocol":
        """From a RunResult: its recorded geometry, else the configuration's."""
        clips = count_clips(result.per_frame)
        if result.geometry is not None:
            return cls(result.geometry, clips)
        return cls(configured_geometry(result.config), clips, recorded=False)

    @classmethod
    def from_summary(cls, summary: dict) -> "Protocol | None":
        """From a run folder's summary.json ("geometry", else "config"); None when neither reads."""
        clips = summary.get("counts", {}).get("clips")
        data = summary.get("geometry")
        names = [f.name for f in fields(EffectiveGeometry) if f.name != "frame_sizes"]
        if isinstance(data, dict) and all(name in data for name in names):
            try:
                sizes = tuple((int(width), int(height)) for width, height in data.get("frame_sizes", ()))
                return cls(EffectiveGeometry(**{name: data[name] for name in names}, frame_sizes=sizes), clips)
            except (TypeError, ValueError):
                pass
        try:
            return cls(configured_geometry(EvalConfig.from_dict(summary["config"])), clips, recorded=False)
        except (RoneldEvalError, KeyError, TypeError, AttributeError, ValueError):
            return None  # an older or foreign summary: say nothing rather than guess

    def map_size(self) -> str:
        g = self.geometry
        text = f"{g.map_width}x{g.map_height} maps"
        if (g.crop_top_px, g.crop_bottom_px) != (0, g.image_height):
            text += f" (image rows {g.crop_top_px}..{g.crop_bottom_px - 1} of {g.image_width}x{g.image_height})"
        if g.rescaled:
            text += ", rescaled from the preset's size"
        if not self.recorded:
            text += " (the configured size; the run did not record the maps' size)"
        return text

    def paper(self) -> str:
        """The RONELD paper's protocol as this run drew it (section IV-B)."""
        g = self.geometry
        return (f"ego lanes drawn on the {self.map_size()}, ground truth {g.gt_thickness_px} px "
                f"and predictions {g.pred_thickness_px} px wide")

    def paper_short(self) -> str:
        """The paper's protocol in a few words, for pictures."""
        g = self.geometry
        return (f"ground truth {g.gt_thickness_px} px, predictions {g.pred_thickness_px} px "
                f"on {g.map_width}x{g.map_height} maps")

    def interval(self) -> str:
        """How the intervals of Acc. Inc. were made, and when they are absent."""
        over = "clips" if self.clips is None else clips_text(self.clips)
        return (f"{LEVEL:.0%} interval from a paired bootstrap over the {over} "
                f"(n/a with fewer than {MIN_CLIPS})")


def clips_text(clips: int) -> str:
    return counted(clips, "clip")


# ---- tables --------------------------------------------------------------------------------

@dataclass(frozen=True)
class Increase:
    """An accuracy increase and its size relative to the method RONELD improves on."""

    absolute: float
    relative: float  # NaN when the base accuracy is 0
    low: float = math.nan  # 95% interval of the absolute increase (paired bootstrap over clips)
    high: float = math.nan
    clips: int | None = None  # clips behind the interval; shown when there is none ("n/a (4 clips)")

    def interval_text(self) -> str:
        """'[0.050, 0.100]', '[n/a (4 clips)]', '[n/a]', or '' when no interval was asked for."""
        if not math.isnan(self.low) and not math.isnan(self.high):
            return f"[{fixed(self.low)}, {fixed(self.high)}]"
        if self.clips is not None and self.clips < MIN_CLIPS:
            return f"[n/a ({clips_text(self.clips)})]"
        return "" if self.clips is None else "[n/a]"


@dataclass(frozen=True)
class Table:
    """Headers (repeats allowed, as in the paper) and rows of str, float or Increase cells.

    `header_lines` gives each header as the lines LaTeX stacks (default: one line each), and
    `group` an optional header row above them: (text, first column, end column) spans.
    """

    headers: tuple[str, ...]
    rows: tuple[tuple, ...]
    header_lines: tuple[tuple[str, ...], ...] = ()
    group: tuple[tuple[str, int, int], ...] = ()

    def to_markdown(self) -> str:
        lines = ["| " + " | ".join(self.headers) + " |", "|" + "|".join("---" for _ in self.headers) + "|"]
        for row in self.rows:
            lines.append("| " + " | ".join(_cell(value, latex=False) for value in row) + " |")
        return "\n".join(lines) + "\n"

    def to_latex(self, caption: str, label: str, wide: bool = False) -> str:
        """A booktabs table; `wide`: `table*` (both columns of a two-column paper).

        Fits without scaling: footnote-size type, stacked headers, an increase on lines of its
        own (absolute, relative, interval), and a wide table spread over the line with 4 pt gaps
        at the least. The head comment says what it needs.
        """
        environment = "table*" if wide else "table"
        where = ("a table* spanning both columns of a two-column paper (an ordinary table in one column)"
                 if wide else "a table one column wide")
        comment = (f"Written by roneld-eval: {where}.\n"
                   "Needs \\usepackage{booktabs} (\\toprule, \\midrule, \\cmidrule, \\bottomrule); nothing else.\n"
                   "Unscaled, it fits a two-column article and a one-column article with default margins.")
        columns = len(self.headers)
        stacked = self.header_lines or tuple((h,) for h in self.headers)
        depth = max(len(lines) for lines in stacked)
        lines = [f"% {line}" if line else "%" for line in comment.splitlines()]
        lines += [
            f"\\begin{{{environment}}}[t]",
            "  \\centering",
            "  \\footnotesize",
            f"  \\setlength{{\\tabcolsep}}{{{'2pt' if wide else '4pt'}}}",
            f"  \\caption{{{latex_text(caption)}}}",
            f"  \\label{{{label}}}",
            "  \\smallskip",
            (f"  \\begin{{tabular*}}{{\\linewidth}}{{@{{\\extracolsep{{\\fill}}}}l{'c' * (columns - 1)}@{{}}}}" if wide
             else f"  \\begin{{tabular}}{{@{{}}l{'c' * (columns - 1)}@{{}}}}"),
            "    \\toprule",
        ]
        lines += self._latex_group_lines(columns)
        for level in range(depth):
            cells = []
            for header in stacked:
                index = level - (depth - len(header))  # stacked headers sit on the bottom line
                cells.append(latex_text(header[index]) if index >= 0 else "")
            lines.append("    " + " & ".join(cells) + " \\\\")
        lines.append("    \\midrule")
        lines += self._latex_body_lines()
        lines += ["    \\bottomrule", f"  \\end{{{'tabular*' if wide else 'tabular'}}}", f"\\end{{{environment}}}"]
        return "\n".join(lines) + "\n"


    def _latex_group_lines(self, columns: int) -> list[str]:
        """The group header over its columns and its rules, where the table has one."""
        if not self.group:
            return []
        cells, rules, at = [], [], 0
        for text, first, end in self.group:
            cells += [""] * (first - at) + [f"\\multicolumn{{{end - first}}}{{c}}{{{latex_text(text)}}}"]
            rules.append(f"\\cmidrule(lr){{{first + 1}-{end}}}")
            at = end
        cells += [""] * (columns - at)
        return ["    " + " & ".join(cells) + " \\\\", "    " + " ".join(rules)]

    def _latex_body_lines(self) -> list[str]:
        """The rows, a cell of several lines (an increase: absolute, relative, interval) stacked,
        with a little space before a row of such cells."""
        lines = []
        for number, row in enumerate(self.rows):
            cell_lines = [_latex_lines(value) for value in row]
            if number and any(len(cell) > 1 for cell in cell_lines):
                lines.append("    \\addlinespace[3pt]")
            for level in range(max(len(cell) for cell in cell_lines)):
                line = " & ".join(cell[level] if level < len(cell) else "" for cell in cell_lines)
                lines.append("    " + line + " \\\\")
        return lines


def fixed(value: float, decimals: int = 3, signed: bool = False) -> str:
    """A number with `decimals` places, halves rounded up from its 12 significant digits, so that
    the same number prints the same however it was computed: 0.7125 - 0.425 and 23/80 differ in
    their last binary digit, and f"{x:.3f}" prints them as 0.288 and 0.287; 0.7125 - 0.675 is
    0.03749999999999998, which is 3/80 = 0.0375 (0.038) before float rounding."""
    if math.isnan(value):
        return "n/a"
    digits = Decimal(format(float(value), ".12g"))
    text = f"{digits.quantize(Decimal(1).scaleb(-decimals), ROUND_HALF_UP):f}"
    if Decimal(text) == 0:
        text = f"{Decimal(0).scaleb(-decimals):f}"  # never "-0.000"
    return "+" + text if signed and not text.startswith("-") else text


def _percent(value: Increase) -> str:
    return "n/a" if math.isnan(value.relative) else f"{fixed(value.relative * 100, 1)}%"


def _latex_lines(value) -> list[str]:
    """A cell as LaTeX, one entry per table line: an increase takes up to three."""
    if isinstance(value, Increase):
        lines = [_latex_number(fixed(value.absolute, signed=True)), f"\\textbf{{({latex_text(_percent(value))})}}"]
        interval = value.interval_text()
        return lines + ([_latex_number(latex_text(interval))] if interval else [])
    return [_cell(value, latex=True)]


def _cell(value, latex: bool) -> str:
    if isinstance(value, Increase):  # Markdown; LaTeX stacks it (_latex_lines)
        interval = value.interval_text()
        return f"{fixed(value.absolute, signed=True)}{' ' + interval if interval else ''} **({_percent(value)})**"
    if isinstance(value, float):
        text = fixed(value)
        return _latex_number(text) if latex else text
    return latex_text(str(value)) if latex else str(value)


def _latex_number(text: str) -> str:
    """A typeset minus for negative numbers."""
    return re.sub(r"(?<![\w.])-(?=\d)", "$-$", text)


_CONTROLS = {code: " " if chr(code) in "\t\n\r" else "?" for code in [*range(32), *range(127, 160)]}


def latex_text(text: str) -> str:
    """Plain text as LaTeX: specials escaped, '>' and '<' in math, '800x288' with a times sign,
    quoted words in TeX's opening and closing quotes (apostrophes stay), control characters
    (which TeX reads as commands or rejects) as spaces or '?'."""
    text = text.translate(_CONTROLS)
    text = (text.replace("\\", "\x00").replace("{", "\\{").replace("}", "\\}").replace("\x00", "\\textbackslash{}")
            .replace("%", "\\%").replace("&", "\\&").replace("_", "\\_").replace("#", "\\#")
            .replace("$", "\\$").replace("~", "\\textasciitilde{}").replace("^", "\\textasciicircum{}"))
    text = text.replace(" >", "~>").replace(">", "$>$").replace("<", "$<$")  # 'IoU > 0.5' on one line
    text = re.sub(r"(\d) (px|clips?|frames?)\b", r"\1~\2", text)  # '30 px' on one line
    text = re.sub(r"(?<!\w)'([^'\n]+?)'(?!\w)", r"`\1'", text)  # 'roneld' quoted as TeX quotes, not two closing ones
    return re.sub(r"(\d)x(\d)", r"\1$\\times$\2", text)


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


def _accuracies(accuracy: pd.DataFrame) -> dict[tuple[str, str], float]:
    """Accuracy by (method, threshold label), from an accuracy table."""
    rows = zip(accuracy["method"], accuracy["threshold"], accuracy["accuracy"])
    return {(method, label): float(value) for method, label, value in rows}


def comparison_table(accuracy: pd.DataFrame, model: str, clips: int | None = None) -> Table:
    """Tables II/III: at 0.3/0.4/0.5, each method, RONELD beside it, and the increase.

    `clips`: how many clips the intervals were drawn over; with too few for one (NaN bounds)
    the increase says "n/a (k clips)" instead.
    """
    labels = list(dict.fromkeys(accuracy["threshold"]))
    methods = list(dict.fromkeys(accuracy["method"]))
    value = _accuracies(accuracy)
    interval = _gain_intervals(accuracy)
    others = [m for m in methods if m != PAPER.ours]
    paired = PAPER.ours in methods and bool(others)
    shown = [m for other in others for m in (other, PAPER.ours)] if paired else methods
    headers, header_lines = _comparison_headers(shown, model, paired)
    rows = []
    for label in table_thresholds(labels):
        row: list = [short_threshold(label)]
        if paired:
            ours = value[(PAPER.ours, label)]
            for method in others:
                base = value[(method, label)]
                relative = (ours - base) / base if base else math.nan
                low, high = interval.get((method, label), (math.nan, math.nan))
                row += [base, ours, Increase(ours - base, relative, low, high, clips if interval else None)]
        else:
            row += [value[(m, label)] for m in methods]
        rows.append(tuple(row))
    return Table(tuple(headers), tuple(rows), tuple(header_lines))


def _gain_intervals(accuracy: pd.DataFrame) -> dict[tuple[str, str], tuple[float, float]]:
    """(method, threshold) -> the interval of RONELD's gain over it, where accuracy.csv has them."""
    if "roneld_gain_ci_low" not in accuracy.columns:
        return {}
    bounds = zip(accuracy["method"], accuracy["threshold"], accuracy["roneld_gain_ci_low"],
                 accuracy["roneld_gain_ci_high"])
    return {(method, label): (float(low), float(high)) for method, label, low, high in bounds}


def _comparison_headers(shown: list[str], model: str, paired: bool) -> tuple[list[str], list[tuple[str, ...]]]:
    """Each column's header, and its lines stacked: the threshold, the methods, and the increase
    after each RONELD column of a paired table."""
    headers = ["IoU threshold"]
    header_lines: list[tuple[str, ...]] = [("IoU", "threshold")]
    for method in shown:
        headers.append(display_name(method, model))
        header_lines.append(name_parts(method, model))
        if paired and method == PAPER.ours:
            headers.append("Acc. Inc.")
            header_lines.append(("Acc. Inc.",))
    return headers, header_lines


def ablation_table(accuracy: pd.DataFrame, dataset: str, model: str | None = None) -> Table | None:
    """Table IV: RONELD without ('roneld-nopft') and with ('roneld') PFT at 0.3 and 0.5.

    None without both methods. Column labels come from the method names, never from a flag.
    """
    methods = ABLATION_PAIR
    if not set(methods) <= set(accuracy["method"]):
        return None
    labels = list(dict.fromkeys(accuracy["threshold"]))
    value = _accuracies(accuracy)
    name = dataset  # as tables and titles name it: its benchmark's display name
    rows = tuple(
        (short_threshold(label), *(value[(m, label)] for m in methods))
        for label in table_thresholds(labels, ABLATION_THRESHOLDS)
    )
    group_name = name if model is None else f"{name}, {display_name(PAPER.ours, model)}"
    labels = [_pft_label(m) for m in methods]
    return Table(("IoU threshold", *(f"{name} {label}" for label in labels)), rows,
                 (("IoU", "threshold"), *((label,) for label in labels)), ((group_name, 1, 3),))


def _pft_label(method: str) -> str:
    facts = facts_of(method)
    assert facts is not None and facts.pft_label is not None
    return facts.pft_label


def runtime_table(runtime: pd.DataFrame, model: str) -> Table:
    """Table V: milliseconds per frame of extraction alone, map loading apart."""
    rows = []
    for row in runtime.to_dict("records"):
        name = "Map loading" if row["method"] == "map loading" else display_name(row["method"], model)
        rows.append((name, str(row["frames"]), float(row["mean_ms"]), float(row["median_ms"]), float(row["p95_ms"])))
    return Table(("Method", "Frames", "Mean (ms)", "Median (ms)", "p95 (ms)"), tuple(rows))


# The categories that stand for the whole set in a benchmark's official table: its total, and
# the ego lanes a run adds (where preceding-frame tracking acts).
WHOLE_SET = ("all", "ego")


def official_headline(official: pd.DataFrame, benchmark, model: str) -> Table | None:
    """The official scores papers quote, one short table: the rows over the whole set (where
    the table has categories) and the rates and scores the benchmark declares, its counts left
    to official.csv. None where nothing is left to show."""
    if official is None or official.empty or "method" not in official.columns:
        return None
    rows = official[official["category"].isin(WHOLE_SET)] if "category" in official.columns else official
    keys = [column for column in benchmark.official_key if column in rows.columns]
    numbers = _headline_columns(benchmark, rows, keys)
    if rows.empty or not numbers:
        return None
    body = tuple((display_name(record["method"], model), *(str(record[key]) for key in keys[1:]),
                  *(_headline_number(record[column]) for column in numbers))
                 for record in rows.to_dict("records"))
    return Table(("method", *keys[1:], *numbers), body)


def _headline_columns(benchmark, rows: pd.DataFrame, keys: list[str]) -> list[str]:
    """The benchmark's rate and score columns (its declared numbers) the table has, keys aside."""
    kinds = {**benchmark.official_columns, **benchmark.official_optional}
    return [column for column, kind in kinds.items()
            if column in rows.columns and column not in keys and kind.endswith("number")]


def _headline_number(value) -> str:
    try:
        number = float(value)
    except (TypeError, ValueError):
        return "n/a"
    return "n/a" if math.isnan(number) else f"{number:.4f}"
