"""Cells and tables of `compare`, rendered as Markdown and as LaTeX that fits a two-column paper.

A cell is one run's number, or the mean and standard deviation of several runs' numbers
(seeds, checkpoints): `0.703 ± 0.004` in Markdown, the sd on a line of its own in LaTeX. A
table has stub columns (thresholds, categories) repeated in every block; its other columns are
packed into blocks no wider than one page, so a table of many models stacks its blocks instead
of running off the page. Nothing here reads files or computes a metric.
"""

from __future__ import annotations

from decimal import Decimal

import math
import re
from dataclasses import dataclass
from typing import Sequence

from ..metrics.bootstrap import MIN_CLIPS
from ..report.tables import clips_text, fixed, latex_text

# Widths in TeX points of a \footnotesize booktabs table in a two-column article: \columnwidth
# is 229.5 pt and \textwidth 469 pt (IEEEtran: 252 and 516). Blocks are packed to less, because
# the width of a cell is estimated from its characters.
NARROW_PT = 225.0
WIDE_PT = 440.0
COLUMN_GAP_PT = 8.0  # 2 x \tabcolsep (4 pt)
DASH = "–"  # a cell a run does not have


def _char_pt(char: str) -> float:
    """Width of a character in \\footnotesize Computer Modern, rounded up (measured with pdflatex)."""
    if char.isdigit():
        return 4.3
    if char in " .,:;()[]|'!/":
        return 2.6
    if char in "%mwMW":
        return 7.4
    if char in "+=±–":
        return 6.6
    if char.isupper():
        return 6.1
    return 4.2


def text_pt(text: str, bold: bool = False) -> float:
    return sum(_char_pt(c) for c in text) * (1.2 if bold else 1.0)


def number(value: float, decimals: int, signed: bool = False) -> str:
    """As the run's own tables print it (report.tables.fixed), so both show the same digits."""
    if value is None:
        return "n/a"
    return fixed(value, decimals, signed)


LATEX_SYMBOLS = {"±": "$\\pm$", "−": "$-$", "–": "--", "—": "---", "×": "$\\times$"}


def latex(text: str) -> str:
    """Plain text as LaTeX for pdflatex: specials escaped, a few symbols spelt out, and any
    character outside Latin-1 (which pdflatex's default input cannot typeset) as '?'."""
    text = "".join(c if c in LATEX_SYMBOLS or ord(c) < 256 else "?" for c in text)
    text = latex_text(text).replace("--", "-{}-")  # '--allow-mixed' as typed, not an en dash
    for symbol, spelt in LATEX_SYMBOLS.items():
        text = text.replace(symbol, spelt)
    return text


def latex_number(text: str) -> str:
    """A cell as LaTeX, with a typeset minus for negative numbers."""
    return re.sub(r"(?<![\w.])-(?=\d)", "$-$", latex(text))


# ---- cells -----------------------------------------------------------------------------------

@dataclass(frozen=True)
class Text:
    """A plain label."""

    text: str

    def markdown(self) -> str:
        return markdown_text(self.text)

    def latex_lines(self) -> list[str]:
        return [latex_number(self.text)]

    def widths(self) -> list[float]:
        return [text_pt(self.text)]


@dataclass(frozen=True)
class Stat:
    """One number, or the mean and sample standard deviation over several runs' numbers."""

    values: tuple[float, ...]
    decimals: int = 3
    scale: float = 1.0  # 100 for percentages

    @property
    def n(self) -> int:
        return len(self.values)

    @property
    def mean(self) -> float:
        finite = [v for v in self.values if not math.isnan(v)]
        return math.fsum(finite) / len(finite) if len(finite) == len(self.values) and finite else math.nan

    @property
    def sd(self) -> float:
        if self.n < 2 or math.isnan(self.mean):
            return math.nan
        mean = self.mean
        return math.sqrt(math.fsum((v - mean) ** 2 for v in self.values) / (self.n - 1))

    def mean_text(self, signed: bool = False) -> str:
        return number(self.mean * self.scale, self.decimals, signed)

    def sd_text(self) -> str:
        return "" if self.n < 2 or math.isnan(self.sd) else "± " + number(self.sd * self.scale, self.decimals)

    def markdown(self) -> str:
        return " ".join(filter(None, [self.mean_text(), self.sd_text()]))

    def latex_lines(self) -> list[str]:
        return [latex_number(t) for t in (self.mean_text(), self.sd_text()) if t]

    def widths(self) -> list[float]:
        return [text_pt(t) for t in (self.mean_text(), self.sd_text()) if t]


@dataclass(frozen=True)
class Gain:
    """RONELD's accuracy increase over a method: per run, with its relative size and interval."""

    increase: Stat  # per-run increases (RONELD minus the method)
    base: float  # the method's mean accuracy: the relative increase is increase.mean / base
    low: float = math.nan  # 95% interval of the (mean) increase: paired bootstrap over clips
    high: float = math.nan
    clips: int | None = None  # clips behind the interval; None: no interval asked for

    def relative_text(self) -> str:
        if not self.base or math.isnan(self.base) or math.isnan(self.increase.mean):
            return "(n/a)"
        return f"({fixed(self.increase.mean / self.base * 100, 1)}%)"

    def interval_text(self) -> str:
        if self.clips is None:
            return ""
        if not math.isnan(self.low) and not math.isnan(self.high):
            return f"[{number(self.low, 3)}, {number(self.high, 3)}]"
        if self.clips < MIN_CLIPS:
            return f"[n/a ({clips_text(self.clips)})]"
        return "[n/a]"

    def markdown(self) -> str:
        parts = [self.increase.mean_text(signed=True), self.increase.sd_text(), self.interval_text(),
                 f"**{self.relative_text()}**"]
        return " ".join(p for p in parts if p)

    def latex_lines(self) -> list[str]:
        lines = [latex_number(self.increase.mean_text(signed=True))]
        if self.increase.n > 1:
            lines.append(latex_number(self.increase.sd_text()))
        lines.append(f"\\textbf{{{latex_number(self.relative_text())}}}")
        if self.interval_text():
            lines.append(latex_number(self.interval_text()))
        return lines

    def widths(self) -> list[float]:
        texts = [self.increase.mean_text(signed=True), self.increase.sd_text(), self.interval_text()]
        return [text_pt(t) for t in texts if t] + [text_pt(self.relative_text(), bold=True)]


EMPTY = Text(DASH)
Cell = Text | Stat | Gain  # what a Grid row holds, one per column


def markdown_text(text: str) -> str:
    """Text safe inside a Markdown table cell."""
    return text.replace("\\", "\\\\").replace("|", "\\|").replace("\n", " ").replace("\r", " ")


# ---- tables ----------------------------------------------------------------------------------

@dataclass(frozen=True)
class Column:
    """A column: its Markdown header, its LaTeX header lines, and the group spanning above it."""

    markdown: str
    lines: tuple[str, ...]
    group: str = ""  # consecutive columns of one group share a spanning header (LaTeX)

    def widths(self) -> list[float]:
        return [text_pt(line) for line in self.lines]


@dataclass(frozen=True)
class Grid:
    """Stub columns (repeated in every block) and data columns; rows hold a cell per column."""

    stub: tuple[Column, ...]
    columns: tuple[Column, ...]
    rows: tuple[tuple, ...]
    rules_after: tuple[int, ...] = ()  # row indices followed by a \midrule (e.g. before a mean row)

    # Markdown: one table, whatever its width; spanning groups become part of the headers.
    def to_markdown(self) -> str:
        headers = [c.markdown for c in self.stub + self.columns]
        lines = ["| " + " | ".join(markdown_text(h) for h in headers) + " |",
                 "|" + "|".join("---" for _ in headers) + "|"]
        for row in self.rows:
            lines.append("| " + " | ".join(cell.markdown() for cell in row) + " |")
        return "\n".join(lines) + "\n"

    def _column_pt(self, index: int) -> float:
        column = (self.stub + self.columns)[index]
        widths = column.widths() + [w for row in self.rows for w in row[index].widths()]
        return max(widths, default=0.0) + COLUMN_GAP_PT

    def natural_pt(self) -> float:
        """Estimated width of the whole table; @{} drops the outer column gaps. A group's name
        spans its columns and widens them when it is the wider (a two-model ablation table ran
        57 pt past a column when only the cells were counted)."""
        stub_pt = sum(self._column_pt(i) for i in range(len(self.stub)))
        return stub_pt + sum(width for _, width in self._groups()) - COLUMN_GAP_PT

    def _groups(self) -> list[tuple[list[int], float]]:
        """Data columns in runs sharing a group name, each with its width in points."""
        groups: list[list[int]] = []
        for k, column in enumerate(self.columns):
            if groups and column.group and self.columns[groups[-1][-1]].group == column.group:
                groups[-1].append(k)
            else:
                groups.append([k])
        return [(group, max(sum(self._column_pt(len(self.stub) + k) for k in group),
                            text_pt(self.columns[group[0]].group) + COLUMN_GAP_PT)) for group in groups]

    def blocks(self, budget_pt: float) -> list[list[int]]:
        """Data columns packed into blocks that fit `budget_pt` beside the stub, groups kept whole."""
        stub_pt = sum(self._column_pt(i) for i in range(len(self.stub)))
        blocks: list[list[int]] = []
        used = stub_pt
        for group, group_pt in self._groups():
            if blocks and used + group_pt > budget_pt:
                blocks.append([])
                used = stub_pt
            if not blocks:
                blocks.append([])
            blocks[-1].extend(group)
            used += group_pt
        return blocks or [[]]

    def to_latex(self, caption: str, label: str, notes: Sequence[str] = ()) -> str:
        """A booktabs `table` when it fits one column, else a `table*` of stacked blocks.

        Needs only \\usepackage{booktabs}; unscaled, it fits a two-column article.
        """
        wide = self.natural_pt() > NARROW_PT
        environment = "table*" if wide else "table"
        blocks = self.blocks(WIDE_PT) if wide else [list(range(len(self.columns)))]
        where = ("a table* spanning both columns of a two-column paper" if wide else "a table one column wide")
        lines = [f"% Written by roneld-eval compare: {where}.",
                 "% Needs \\usepackage{booktabs}; nothing else. Unscaled, it fits a two-column article "
                 "(wide tables stack blocks of columns).",
                 f"\\begin{{{environment}}}[t]", "  \\centering", "  \\footnotesize",
                 "  \\setlength{\\tabcolsep}{4pt}", f"  \\caption{{{latex(caption)}}}",
                 f"  \\label{{{label}}}"]
        for number_, block in enumerate(blocks):
            lines.append("  \\smallskip" if number_ == 0 else "  \\par\\medskip")
            lines += self._latex_block(block)
        if notes:
            lines.append("  \\par\\smallskip")
            lines.append("  {\\scriptsize\\sloppy\\raggedright")
            lines += [f"  {latex(note)}\\par" for note in notes]
            lines.append("  }")
        lines.append(f"\\end{{{environment}}}")
        return "\n".join(lines) + "\n"

    def _latex_block(self, block: list[int]) -> list[str]:
        indices = list(range(len(self.stub))) + [len(self.stub) + k for k in block]
        columns = [(self.stub + self.columns)[i] for i in indices]
        spec = "l" * len(self.stub) + "c" * len(block)
        lines = [f"  \\begin{{tabular}}{{@{{}}{spec}@{{}}}}", "    \\toprule"]
        lines += self._latex_groups(block)
        depth = max(len(c.lines) for c in columns)
        for level in range(depth):
            cells = []
            for column in columns:
                index = level - (depth - len(column.lines))  # stacked headers sit on the bottom line
                cells.append(latex(column.lines[index]) if index >= 0 else "")
            lines.append("    " + " & ".join(cells) + " \\\\")
        lines.append("    \\midrule")
        lines += self._latex_rows(indices)
        lines += ["    \\bottomrule", "  \\end{tabular}"]
        return lines

    def _latex_groups(self, block: list[int]) -> list[str]:
        """The group headers over runs of neighbouring columns of one group, and their rules
        (none where no column of the block has a group)."""
        groups = [(k, self.columns[k].group) for k in block]
        if not any(group for _, group in groups):
            return []
        cells, rules = [""] * len(self.stub), []
        position = len(self.stub)
        k = 0
        while k < len(groups):
            name = groups[k][1]
            span = 1
            while k + span < len(groups) and name and groups[k + span][1] == name:
                span += 1
            if name:
                cells.append(f"\\multicolumn{{{span}}}{{c}}{{{latex(name)}}}")
                rules.append(f"\\cmidrule(lr){{{position + 1}-{position + span}}}")
            else:
                cells += [""] * span
            position += span
            k += span
        return ["    " + " & ".join(cells) + " \\\\", "    " + " ".join(rules)]

    def _latex_rows(self, indices: list[int]) -> list[str]:
        lines = []
        for number_, row in enumerate(self.rows):
            cells = [row[i].latex_lines() for i in indices]
            if number_ and any(len(cell) > 1 for cell in cells) and (number_ - 1) not in self.rules_after:
                lines.append("    \\addlinespace[3pt]")
            for level in range(max(len(cell) for cell in cells)):
                lines.append("    " + " & ".join(cell[level] if level < len(cell) else "" for cell in cells) + " \\\\")
            if number_ in self.rules_after:
                lines.append("    \\midrule")
        return lines


def wrap_words(text: str, width: int = 14) -> tuple[str, ...]:
    """A header broken into lines of about `width` characters at spaces (LaTeX stacks them)."""
    lines: list[str] = []
    for word in text.split():
        if lines and len(lines[-1]) + 1 + len(word) <= width:
            lines[-1] += " " + word
        else:
            lines.append(word)
    return tuple(lines) or ("",)


# ---- thresholds as the tables name them ----------------------------------------------------------

def grid_text(grid: tuple[Decimal, ...]) -> str:
    if len(grid) == 1:
        return f"{grid[0]}"
    steps = {grid[k + 1] - grid[k] for k in range(len(grid) - 1)}
    step = f" step {steps.pop()}" if len(steps) == 1 else ""
    return f"{grid[0]}..{grid[-1]}{step}, {len(grid)} thresholds"


def threshold_label(threshold: Decimal) -> str:
    """0.3 -> '0.30' (as accuracy.csv writes thresholds: at least two decimals)."""
    exponent = threshold.normalize().as_tuple().exponent
    assert isinstance(exponent, int), threshold  # thresholds are finite
    places = max(2, -exponent)
    return f"{threshold:.{places}f}"


def short_threshold(threshold: Decimal) -> str:
    """0.30 -> '0.3', as the paper prints thresholds."""
    text = f"{threshold.normalize():f}"
    return text if "." in text else text + ".0"
