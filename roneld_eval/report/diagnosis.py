"""What `--diagnose` and `--score-sweep` write beside a score's tables: errors.csv/.md/.png (lane
error types and their dF1, metrics.lane_errors), frames.csv.gz (every frame's counts, for pandas
slices), and sweep_scores.csv/.png (precision, recall and F1 at each score threshold).

A `matching` column is written where a benchmark scores two ways (OpenLane: lanes matched within
their category, or whatever it is); the Cat type only where lanes match within their category."""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from functools import cached_property
from typing import TYPE_CHECKING, Any, Callable, Iterator, Mapping, Sequence

import numpy as np

from ..metrics.lane_errors import (CAT, ERROR_COLUMNS, ERROR_TYPES, FrameDiagnoses, Measure, ScoreSweep,
                                   error_records, sweep_records)
from ..metrics.lane_iou_f1 import f_measure
from ..output import csv_gz
from ..scoring import PlainTable

if TYPE_CHECKING:
    from ..output import Staging

ERROR_CSV_COLUMNS = ("method", "matching", "category", "threshold", "side", "type", "count", "dF1")
SWEEP_CSV_COLUMNS = ("method", "matching", "category", "threshold", "score_threshold", "tp", "fp", "fn", "precision",
                     "recall", "f1", "best")
FRAME_CSV_COLUMNS = ("frame", "sequence", "category", "method", "matching", "threshold", "tp", "fp", "fn")


@dataclass(frozen=True)
class Diagnosed:
    """A score's per-frame counts and what they are of: each entry of their method axis as
    (method, matching; "" where a benchmark matches one way), category groups (name, frame mask;
    'all' last), the IoU threshold labels, and each frame's (sequence, category)."""

    diagnoses: FrameDiagnoses
    entries: tuple[tuple[str, str], ...]
    groups: tuple[tuple[str, np.ndarray], ...]
    labels: tuple[str, ...]
    loc_iou: float
    frame_facts: Callable[[str], tuple[str, str]]
    title: str  # "CULane, the lane IoU F1 of SCNN's evaluator (30 px at 1640x590)"
    sweep: ScoreSweep | None = None
    errors: bool = True  # --diagnose (else only the sweep was asked for)
    with_categories: bool = False  # lanes match within their category: the Cat type is shown
    measure: Measure = f_measure  # the benchmark's precision, recall and F1 of (tp, fp, fn)
    frame_lanes: Callable[[str], Any] | None = None  # a frame's gallery.GalleryFrame (its lanes read again)
    image_root: str | None = None  # where the frames' images are, as the score was told
    # method -> the name tables and figures give it (a run's: "SCNN + RONELD"); the CSV files keep the method's
    display: Mapping[str, str] = field(default_factory=dict)

    @property
    def types(self) -> tuple[int, ...]:
        """The error types shown (indices into ERROR_TYPES)."""
        return tuple(k for k in range(len(ERROR_TYPES)) if k != CAT or self.with_categories)

    @property
    def fixes(self) -> tuple[tuple[str, str], ...]:
        """The types with a dF1 of their own (a Loc pair counts on both sides: its fp row)."""
        return tuple(ERROR_TYPES[k] for k in self.types if ERROR_TYPES[k] != ("fn", "Loc"))

    @property
    def matched_two_ways(self) -> bool:
        return any(matching for _, matching in self.entries)

    @cached_property
    def error_rows(self) -> list[tuple]:
        """error_records' rows (summed once: the files and the console both read them)."""
        return error_records(self.diagnoses, self.entries, self.groups, self.labels, self.types, self.measure)

    @cached_property
    def sweep_rows(self) -> list[tuple]:
        assert self.sweep is not None
        return sweep_records(self.diagnoses, self.entries, self.groups, self.labels, self.sweep, self.measure)

    def name(self, method: str, matching: str) -> str:
        shown = self.display.get(method, method)
        return f"{shown} ({matching})" if matching else shown


def _table(columns: Sequence[str], rows: Sequence[tuple], keep_matching: bool) -> PlainTable:
    """A table without its matching column (the second) where a benchmark matches one way."""
    if keep_matching:
        return PlainTable(tuple(columns), tuple(rows))
    return PlainTable(tuple(columns[:1]) + tuple(columns[2:]), tuple(row[:1] + row[2:] for row in rows))


def write_diagnosis(staging: Staging, diagnosed: Diagnosed | None, shown: Sequence[str]) -> None:
    """The files of `diagnosed` (none without it), their tables at the thresholds `shown` in errors.md."""
    if diagnosed is None:
        return
    if diagnosed.errors:
        rows = diagnosed.error_rows
        staging.write_text("errors.csv", _table(ERROR_CSV_COLUMNS, rows, diagnosed.matched_two_ways).to_csv())
        staging.write_text("errors.md", errors_markdown(diagnosed, rows, shown))
        errors_figure(diagnosed, rows, shown[0], staging.file("errors.png"))
        staging.write_bytes("frames.csv.gz", frames_csv_gz(diagnosed))
        from .gallery import write_gallery

        write_gallery(staging, diagnosed, shown[0])
    if diagnosed.sweep is not None:
        swept = diagnosed.sweep_rows
        staging.write_text("sweep_scores.csv", _table(SWEEP_CSV_COLUMNS, swept, diagnosed.matched_two_ways).to_csv())
        sweep_figure(diagnosed, swept, shown[0], staging.file("sweep_scores.png"))


Summed = dict[tuple[str, str, str, str], dict[tuple[str, str], tuple[int, float]]]


def _summed(rows: Sequence[tuple]) -> Summed:
    """{(method, matching, category, threshold): {(side, type): (count, dF1)}} of error_records' rows."""
    out: Summed = {}
    for method, matching, category, label, side, kind, count, delta in rows:
        out.setdefault((method, matching, category, label), {})[(side, kind)] = (count, delta)
    return out


def console_lines(diagnosed: Diagnosed, label: str, written: bool = True) -> list[str]:
    """What the console says of a diagnosis at one threshold over all frames, a line an entry:
    its error counts and the type whose fix gains most; the best F1 of the score sweep (naming the
    files that hold the rest when they are `written`)."""
    lines = []
    if diagnosed.errors:
        summed = _summed(diagnosed.error_rows)
        lines += [_error_line(diagnosed, method, matching, summed[(method, matching, "all", label)], label)
                  + (" (errors.md)" if written else "") for method, matching in diagnosed.entries]
    if diagnosed.sweep is not None:
        lines += [f"{diagnosed.name(row[0], row[1])}: best F1 {100 * row[10]:.2f} at score threshold {row[4]} "
                  f"({diagnosed.sweep.rule}; chosen on the test set{'; sweep_scores.csv' if written else ''})"
                  for row in diagnosed.sweep_rows if row[2] == "all" and row[3] == label and row[11]]
    return lines


def _error_line(diagnosed: Diagnosed, method: str, matching: str, types: dict[tuple[str, str], tuple[int, float]],
                label: str) -> str:
    shown = [ERROR_TYPES[k] for k in diagnosed.types]
    counts = ", ".join(f"{kind} {types[(side, kind)][0]}" for side, kind in shown if side == "fp")
    missed = ", ".join(f"{kind} {types[(side, kind)][0]}" for side, kind in shown if side == "fn")
    gains = [(types[key][1], key[1]) for key in diagnosed.fixes if not math.isnan(types[key][1])]
    top = max(gains) if gains else None
    best = f"; fixing {top[1]} gains most ({_points(top[0])} F1)" if top and top[0] > 0 else ""
    return f"{diagnosed.name(method, matching)} at IoU > {label}, all frames: FP {counts}; FN {missed}{best}"


def _points(value: float) -> str:
    return "" if math.isnan(value) else f"{100 * value:+.2f}"


def error_lines(diagnosed: Diagnosed, rows: Sequence[tuple], label: str) -> list[str]:
    """The markdown table of every entry and category at one threshold: counts, F1, each error
    type's count and its dF1 (F1 points gained by fixing every error of that type)."""
    shown = [ERROR_TYPES[k] for k in diagnosed.types]
    header = ["method", "category", "TP", "FP", "FN", "F1 (%)"]
    header += [f"{side.upper()} {kind}" for side, kind in shown]
    header += [f"dF1 {kind}" for _, kind in diagnosed.fixes]
    lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    for (method, matching, category, at), types in _summed(rows).items():
        if at != label:
            continue
        fp = sum(types[key][0] for key in shown if key[0] == "fp")
        fn = sum(types[key][0] for key in shown if key[0] == "fn")
        tp = _true_positives(diagnosed, (method, matching), category, label)
        f1 = diagnosed.measure(tp, fp, fn)[2]
        cells = [diagnosed.name(method, matching), category, str(tp), str(fp), str(fn),
                 "" if math.isnan(f1) else f"{100 * f1:.2f}"]
        cells += [str(types[key][0]) for key in shown]
        cells += [_points(types[key][1]) for key in diagnosed.fixes]
        lines.append("| " + " | ".join(cells) + " |")
    return lines


def _true_positives(diagnosed: Diagnosed, entry: tuple[str, str], category: str, label: str) -> int:
    m = diagnosed.entries.index(entry)
    inside = dict(diagnosed.groups)[category]
    return int(diagnosed.diagnoses.tp[m, inside, diagnosed.labels.index(label)].sum())


def errors_markdown(diagnosed: Diagnosed, rows: Sequence[tuple], shown: Sequence[str]) -> str:
    cat = ("**Cat** when it would match a lane of another category (IoU above the threshold; lanes match only "
           "lanes of their category here), checked first; else " if diagnosed.with_categories else "")
    lines = [f"# Why F1 is not higher: {diagnosed.title}", "",
             f"Each false positive takes its highest-IoU ground-truth lane: {cat}**Loc** when that IoU is at least "
             f"{diagnosed.loc_iou:g} (--loc-iou) and the lane is not a true positive (of several on one lane, the "
             "highest IoU; the others **Dupe**), **Dupe** when the lane is already a true positive, **Bkg** when no "
             "IoU reaches it. A missed lane is **Loc** when a Loc prediction is on it, else **Miss**. Each side adds "
             "up to the official FP and FN. dF1 is F1 with every error of that type fixed, minus F1 as it is, in "
             f"points (TIDE's dAP for lanes): a Loc pair made a true positive, a Dupe{', Cat' if cat else ''} or "
             "Bkg prediction removed, a Miss removed. Every threshold is in errors.csv, every frame in frames.csv.gz.",
             ""]
    for label in shown:
        lines += [f"## IoU > {label}", "", *error_lines(diagnosed, rows, label), ""]
    return "\n".join(lines)


def frames_csv_gz(diagnosed: Diagnosed) -> bytes:
    """frames.csv.gz: a row per frame, entry and threshold (FRAME_CSV_COLUMNS, then the error
    types shown), gzip without a time stamp so that the same score writes the same bytes."""
    d = diagnosed.diagnoses
    types = list(diagnosed.types)

    def rows() -> Iterator[tuple]:
        for k, frame in enumerate(d.frames):
            sequence, category = diagnosed.frame_facts(frame)
            n_gt = int(d.n_gt[k])
            for m, (method, matching) in enumerate(diagnosed.entries):
                n_pred = int(d.n_pred[m, k])
                for t, label in enumerate(diagnosed.labels):
                    tp = int(d.tp[m, k, t])
                    yield (frame, sequence, category, method, matching, label, tp, n_pred - tp, n_gt - tp,
                           *d.errors[m, k, t, types].tolist())

    return csv_gz(FRAME_CSV_COLUMNS + tuple(ERROR_COLUMNS[k] for k in types), rows())


def errors_figure(diagnosed: Diagnosed, rows: Sequence[tuple], label: str, path) -> None:
    """errors.png: each entry's dF1 per error type over all frames at one threshold."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from .figure_files import write_png

    summed = _summed(rows)
    fixes = diagnosed.fixes
    figure, axes = plt.subplots(figsize=(7, 1.4 + 0.45 * len(fixes) * max(1, len(diagnosed.entries)) ** 0.5), dpi=100)
    width = 0.8 / max(1, len(diagnosed.entries))
    for m, (method, matching) in enumerate(diagnosed.entries):
        types = summed[(method, matching, "all", label)]
        values = [0.0 if math.isnan(types[key][1]) else 100 * types[key][1] for key in fixes]
        axes.barh([k + m * width for k in range(len(fixes))], values, height=width,
                  label=diagnosed.name(method, matching))
    axes.set_yticks([k + 0.4 - width / 2 for k in range(len(fixes))],
                    [f"{kind} ({side.upper()})" for side, kind in fixes])
    axes.invert_yaxis()
    axes.set_xlabel("F1 gained by fixing every error of the type (points)")
    axes.set_title(f"{diagnosed.title}: all frames, IoU > {label}", fontsize=9)
    axes.grid(alpha=0.3, axis="x")
    axes.legend(fontsize=8, loc="upper left", bbox_to_anchor=(1.01, 1.0))  # beside the bars, never over one
    figure.tight_layout()
    write_png(figure, path)
    plt.close(figure)


def sweep_figure(diagnosed: Diagnosed, rows: Sequence[tuple], label: str, path) -> None:
    """sweep_scores.png: precision against recall over the score thresholds (all frames, one IoU
    threshold), the best F1 marked as chosen on these frames."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from .figure_files import write_png

    assert diagnosed.sweep is not None
    figure, axes = plt.subplots(figsize=(5.5, 4.5), dpi=100)
    for method, matching in diagnosed.entries:
        curve = [row for row in rows if row[:2] == (method, matching) and row[2] == "all" and row[3] == label]
        name = diagnosed.name(method, matching)
        axes.plot([100 * row[9] for row in curve], [100 * row[8] for row in curve], marker="o", markersize=3,
                  label=name)
        for row in curve:
            if row[11]:
                axes.plot([100 * row[9]], [100 * row[8]], marker="*", markersize=13, color="black", linestyle="none",
                          label=f"{name}: best F1 {100 * row[10]:.2f} at {row[4]} (chosen on the test set)")
    axes.set_xlabel("recall (%)")
    axes.set_ylabel("precision (%)")
    axes.set_title(f"{diagnosed.title}: all frames, IoU > {label}\nkept when {diagnosed.sweep.rule}", fontsize=9)
    axes.grid(alpha=0.3)
    axes.legend(fontsize=8, loc="lower left")
    figure.tight_layout()
    write_png(figure, path)
    plt.close(figure)
