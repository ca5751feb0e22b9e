"""The comparison's tables: the accuracy, ablation, runtime, official and pair grids and their files."""

from __future__ import annotations

import math
from decimal import Decimal
from functools import partial
from typing import Callable, Sequence

import numpy as np
import pandas as pd

from ..thresholds import Thresholds, parse_thresholds
from ..errors import ConfigError
from ..metrics.bootstrap import LEVEL, MIN_CLIPS, paired_bootstrap
from ..methods import METHOD_TABLE, PAPER
from ..report.tables import display_name
from .groups import (ABLATION_METHOD, KNOWN_METHODS, PAPER_METHODS, Group, _accuracy_of, _column_of, all_found,
                     method_header, method_name, ordered_methods)
from .runs import Run
from .tables import (EMPTY, Cell, Column, Gain, Grid, Stat, Text, clips_text, grid_text, short_threshold,
                     threshold_label, wrap_words)
from .comparable import run_title


ACCURACY_ROWS = ("0.3", "0.4", "0.5")  # Tables II/III
ABLATION_ROWS = ("0.3", "0.5")  # Table IV


def table_rows(spec, grid: tuple[Decimal, ...], default: tuple[str, ...]) -> list[Decimal]:
    """The thresholds a table shows: those asked for (each in the runs' grid), else the paper's."""
    if spec is None:
        wanted = [Decimal(t) for t in default if Decimal(t) in grid]
        if wanted:
            return wanted
        return list(grid) if len(grid) <= 3 else [grid[0], grid[len(grid) // 2], grid[-1]]
    text = spec if isinstance(spec, str) else ",".join(str(t) for t in spec)
    asked = [Decimal(label) for label in parse_thresholds(text).labels]
    for threshold in asked:
        if threshold not in grid:
            raise ConfigError(f"--thresholds: {short_threshold(threshold)} is not among the runs' thresholds "
                              f"({grid_text(grid)})")
    return asked


# ---- comparison.csv and pairs --------------------------------------------------------------------

def comparison_table(runs: Sequence[Run]) -> pd.DataFrame:
    """One row per run, method and threshold: the runs' own accuracy.csv numbers, side by side."""
    frames = []
    for run in runs:
        table = run.accuracy[["method", "threshold", "n_tp", "n_gt", "accuracy"]].copy()
        table["threshold"] = table["threshold"].map(threshold_label)
        table.insert(0, "model", run.model)
        table.insert(0, "dataset", run.dataset)
        table.insert(0, "label", run.label)
        table.insert(0, "run", str(run.path))
        frames.append(table)
    return pd.concat(frames, ignore_index=True)


def _thresholds(grid: tuple[Decimal, ...]) -> Thresholds:
    return Thresholds(labels=tuple(threshold_label(t) for t in grid), values=tuple(float(t) for t in grid))


def _bootstrap(per_frame_a: pd.DataFrame, per_frame_b: pd.DataFrame, grid: tuple[Decimal, ...]) -> pd.DataFrame:
    """B - A per threshold with its paired clip-bootstrap interval (A and B: IoUs of one method)."""
    both = pd.concat([per_frame_a.assign(method="a"), per_frame_b.assign(method="b")], ignore_index=True)
    # As categories, the bootstrap finds each frame's clip once per distinct frame, not once per row.
    both["frame"] = both["frame"].astype("category")
    table = paired_bootstrap(both, _thresholds(grid), method="a", reference="b")
    table["threshold"] = np.array(grid, dtype=object)  # the Decimals themselves
    return table


def _ious_of(run: Run, method: str) -> pd.DataFrame:
    """The rows of a run's per_frame.csv that score `method`."""
    return run.per_frame[run.per_frame["method"] == method]


def pairs_table(pairs: Sequence[tuple[Run, Run]], grid: tuple[Decimal, ...]) -> pd.DataFrame:
    """a, b, method, threshold, accuracy_a, accuracy_b, difference (b - a), ci_low, ci_high, clips."""
    columns = ["a", "b", "method", "threshold", "accuracy_a", "accuracy_b", "difference", "ci_low", "ci_high",
               "clips"]
    rows = []
    for a, b in pairs:
        for method in [m for m in a.methods if m in b.methods]:
            interval = _bootstrap(_ious_of(a, method), _ious_of(b, method), grid)
            accuracy_a, accuracy_b = _accuracy_of(a, method), _accuracy_of(b, method)
            found = zip(interval["threshold"], interval["difference"], interval["ci_low"], interval["ci_high"])
            for threshold, difference, ci_low, ci_high in found:
                rows.append([str(a.path), str(b.path), method, threshold, accuracy_a[threshold],
                             accuracy_b[threshold], difference, ci_low, ci_high, a.clips])
    return pd.DataFrame(rows, columns=columns)


# ---- the tables ------------------------------------------------------------------------------

def protocol_text(runs: Sequence[Run]) -> str:
    """The paper's protocol as the runs measured it (from their config.toml)."""
    settings = dict(runs[0].protocol)
    if len({run.protocol for run in runs}) > 1:
        return "The runs differ in the paper's protocol (see the note)."
    rule = settings.get("paper.thickness_rule")
    reference = {"width": "an 800-px-wide map, scaled with each model's map width",
                 "height": "a 288-row map, scaled with each model's map height"}.get(str(rule), f"rule {rule}")
    rounding = ("; predictions truncated to pixels" if settings.get("paper.prediction_rounding") == "truncate"
                else "")
    return (f"The RONELD paper's protocol: ego lanes drawn {settings.get('paper.gt_thickness_px')} px (ground truth) "
            f"and {settings.get('paper.pred_thickness_px')} px (predictions) wide on {reference}{rounding}; a true "
            f"positive needs IoU > the row's threshold.")


def _seeds_note(groups: Sequence[Group]) -> str:
    if all(g.n == 1 for g in groups):
        return ""
    return ("Where n is given, the model's runs (seeds or checkpoints) are averaged: mean ± sample standard "
            "deviation over the n runs.")


def _accuracy_columns(group: Group) -> list[tuple[str, str]]:
    """(kind, method) for the columns of one model: the paper's pair with its increase, then the rest."""
    methods = group.methods
    columns = []
    if all(m in methods for m in PAPER_METHODS):
        columns += [("value", PAPER.reference), ("value", PAPER.ours), ("gain", PAPER.reference)]
    else:
        columns += [("value", m) for m in PAPER_METHODS if m in methods]
    if ABLATION_METHOD in methods and PAPER.ours not in methods:
        columns.append(("value", ABLATION_METHOD))  # else Table IV shows it
    columns += [("value", m) for m in ordered_methods(methods) if m not in KNOWN_METHODS]
    return columns


def _gain(group: Group, method: str, threshold: Decimal, interval: pd.DataFrame | None) -> Gain:
    """RONELD's increase over `method`: a run's own numbers, or over seeds a pooled paired bootstrap."""
    increases = []
    for run in group.runs:
        stated = _column_of(run, method, "roneld_gain").get(threshold, math.nan)
        if math.isnan(stated):
            stated = _accuracy_of(run, PAPER.ours)[threshold] - _accuracy_of(run, method)[threshold]
        increases.append(stated)
    base = group.accuracy(method, threshold).mean
    clips = group.runs[0].clips
    if group.n == 1:
        run = group.runs[0]
        if "roneld_gain_ci_low" not in run.accuracy.columns:
            return Gain(Stat(tuple(increases)), base)
        low = _column_of(run, method, "roneld_gain_ci_low").get(threshold, math.nan)
        high = _column_of(run, method, "roneld_gain_ci_high").get(threshold, math.nan)
        return Gain(Stat(tuple(increases)), base, low, high, clips)
    assert interval is not None  # _group_interval gives one for a group of several runs
    row = interval[interval["threshold"] == threshold].iloc[0]
    return Gain(Stat(tuple(increases)), base, float(row.ci_low), float(row.ci_high), clips)


def _group_interval(group: Group, method: str) -> pd.DataFrame | None:
    """Seeds share their frames: resample clips once for all of them (the mean increase's interval)."""
    if group.n == 1:
        return None
    pick = lambda m: pd.concat([r.per_frame[r.per_frame["method"] == m] for r in group.runs],  # noqa: E731
                               ignore_index=True)
    return _bootstrap(pick(method), pick(PAPER.ours), group.runs[0].thresholds)


def accuracy_grid(groups: Sequence[Group], rows: Sequence[Decimal]) -> Grid:
    """Table II/III of one dataset: per model its baseline, + RONELD and the increase (bold: relative)."""
    columns: list[Column] = []
    makers: list[Callable[[Decimal], Cell]] = []
    for group in groups:
        for kind, method in _accuracy_columns(group):
            if kind == "gain":
                columns.append(Column("Acc. Inc." + ("" if group.n == 1 else f" (n = {group.n})"), ("Acc. Inc.",),
                                      group.title()))
                makers.append(partial(_gain, group, method, interval=_group_interval(group, method)))
            else:
                columns.append(Column(method_name(method, group.label) + ("" if group.n == 1 else
                                                                           f" (n = {group.n})"),
                                      method_header(method, group.label), group.title()))
                makers.append(partial(group.accuracy, method))
    table_rows = tuple((Text(short_threshold(t)),) + tuple(make(t) for make in makers) for t in rows)
    return Grid((Column("IoU threshold", ("IoU", "threshold")),), tuple(columns), table_rows)


def _interval_note(groups: Sequence[Group]) -> str:
    clips = groups[0].runs[0].clips
    return (f"Acc. Inc.: RONELD's increase over the model's own extraction (baseline), in bold relative to it; "
            f"with its {LEVEL:.0%} interval from a paired bootstrap over the {clips_text(clips)} (n/a with fewer "
            f"than {MIN_CLIPS}).")


def accuracy_files(groups: Sequence[Group], rows, notes) -> dict[str, str]:
    markdown, latex = ["# Ego-lane accuracy (N_TP / N_gt): Tables II and III\n"], []
    for dataset in dict.fromkeys(g.dataset for g in groups):
        members = [g for g in groups if g.dataset == dataset]
        grid = accuracy_grid(members, rows)
        name = members[0].dataset_name
        protocol = protocol_text([run for group in members for run in group.runs])
        text = " ".join(filter(None, [f"Ego-lane accuracy on {name}.", protocol, _interval_note(members),
                                      _seeds_note(members)]))
        markdown += [f"## {name}\n", text + "\n", grid.to_markdown()] + [f"\n{note}\n" for note in notes]
        latex.append(grid.to_latex(text, f"tab:compare-accuracy-{dataset}", list(notes)))
    return {"table_accuracy.md": "\n".join(markdown), "table_accuracy.tex": "\n".join(latex)}


def ablation_files(groups: Sequence[Group], rows, protocol: str, notes) -> dict[str, str]:
    """Table IV: RONELD without and with PFT, per dataset and model; nothing when no run has both."""
    holding = [g for g in groups if PAPER.ours in g.methods and ABLATION_METHOD in g.methods]
    if not holding:
        return {}
    columns, makers = [], []
    for group in holding:
        name = f"{group.dataset_name}, {display_name(PAPER.ours, group.label)}"
        title = name if group.n == 1 else f"{name}, n = {group.n}"
        for method, short in ((ABLATION_METHOD, "w/o PFT"), (PAPER.ours, "w/ PFT")):
            columns.append(Column(f"{name} {short}" + ("" if group.n == 1 else f" (n = {group.n})"), (short,), title))
            makers.append(lambda t, g=group, m=method: g.accuracy(m, t))
    table_rows = tuple((Text(short_threshold(t)),) + tuple(make(t) for make in makers) for t in rows)
    grid = Grid((Column("IoU threshold", ("IoU", "threshold")),), tuple(columns), table_rows)
    text = " ".join(filter(None, [
        f"Accuracy of RONELD without (w/o) and with (w/) preceding frame tracking (PFT): the methods "
        f"'{PAPER.without_tracking}' and '{PAPER.ours}'.", protocol, _seeds_note(holding)]))
    markdown = "# RONELD with and without PFT: Table IV\n\n" + text + "\n\n" + grid.to_markdown() + "".join(
        f"\n{note}\n" for note in notes)
    return {"table_ablation.md": markdown, "table_ablation.tex": grid.to_latex(text, "tab:compare-pft", list(notes))}



def _runtime_of(run: Run) -> dict[str, float]:
    return dict(zip(run.runtime["method"], run.runtime["mean_ms"].astype(float)))


def runtime_grid(groups: Sequence[Group]) -> Grid:
    """Table V: mean ms per frame of extraction per dataset and model (RONELD first), and a mean row."""
    methods = _runtime_methods(groups)
    columns = tuple(_runtime_column(m) for m in methods)
    rows = []
    means: dict[str, list[float]] = {m: [] for m in methods}
    for group in groups:
        cells = [_runtime_cell(group, method, means[method]) for method in methods]
        title = group.label if group.n == 1 else f"{group.label} (n = {group.n})"
        rows.append((Text(group.dataset_name), Text(title), *cells))
    mean_cells = [Stat((math.fsum(means[m]) / len(means[m]),)) if means[m] else EMPTY for m in methods]
    rows.append((Text("Mean"), Text(""), *mean_cells))
    return Grid((Column("Dataset", ("Dataset",)), Column("Model", ("Model",))), columns, tuple(rows),
                rules_after=(len(rows) - 2,))


def _runtime_methods(groups: Sequence[Group]) -> list[str]:
    """The methods timed, RONELD first: Table V is RONELD's runtime, the others beside it."""
    methods = ordered_methods(m for g in groups for r in g.runs for m in r.runtime["method"] if m != "map loading")
    first = (PAPER.ours, ABLATION_METHOD)
    return [m for m in first if m in methods] + [m for m in methods if m not in first]


def _runtime_column(method: str) -> Column:
    if method in METHOD_TABLE:
        return Column(METHOD_TABLE[method].words + " (ms)", METHOD_TABLE[method].word_parts)
    return Column(method + " (ms)", wrap_words(method))


def _runtime_cell(group: Group, method: str, means: list[float]) -> Cell:
    """The group's runtime of one method (its runs' mean), EMPTY where a run lacks it; the mean
    is also added to `means`, what the Mean row averages."""
    values = all_found([_runtime_of(run).get(method) for run in group.runs])
    if values is None:
        return EMPTY
    cell = Stat(tuple(values))
    means.append(cell.mean)
    return cell


def _untimed_note(groups: Sequence[Group]) -> str:
    """Why a run's runtime is n/a: it was written with `run --no-timings`."""
    untimed = [run.label for group in groups for run in group.runs
               if len(run.runtime) and run.runtime["mean_ms"].isna().all()]
    if not untimed:
        return ""
    return (f"n/a for {', '.join(dict.fromkeys(untimed))}: written with `run --no-timings`, which records no "
            "timings.")


def runtime_files(groups: Sequence[Group], notes) -> dict[str, str]:
    grid = runtime_grid(groups)
    text = " ".join(filter(None, [
        "Runtime: mean milliseconds per frame of lane extraction alone (after numba warm-up, one-time imports "
        "left out; map loading apart), as each run measured it on its own machine; the Mean row averages the "
        "rows above.",
        _untimed_note(groups), _seeds_note(groups)]))
    markdown = "# Runtime per frame: Table V\n\n" + text + "\n\n" + grid.to_markdown() + "".join(
        f"\n{note}\n" for note in notes)
    return {"table_runtime.md": markdown, "table_runtime.tex": grid.to_latex(text, "tab:compare-runtime", list(notes))}


def official_files(groups: Sequence[Group], notes) -> dict[str, str]:
    markdown, latex = ["# Official scores\n"], []
    seeds = _seeds_note(groups)
    for dataset in dict.fromkeys(g.dataset for g in groups):
        members = [g for g in groups if g.dataset == dataset]
        name = members[0].dataset_name
        grid, text = members[0].runs[0].benchmark.official_comparison(members)
        text = " ".join(filter(None, [text, seeds]))
        markdown += [f"## {name}\n", text + "\n", grid.to_markdown()] + [f"\n{note}\n" for note in notes]
        latex.append(grid.to_latex(text, f"tab:compare-official-{dataset}", list(notes)))
    return {"table_official.md": "\n".join(markdown), "table_official.tex": "\n".join(latex)}


def pair_files(everyone: Sequence[Run], pairs: Sequence[tuple[Run, Run]], table: pd.DataFrame,
                rows: Sequence[Decimal], protocol: str, notes) -> dict[str, str]:
    grid_rows = []
    for a, b in pairs:
        title = f"{run_title(b, everyone)} − {run_title(a, everyone)}"
        for method in [m for m in a.methods if m in b.methods]:
            cells = []
            for threshold in rows:
                hit = table[(table["a"] == str(a.path)) & (table["b"] == str(b.path)) & (table["method"] == method)
                            & (table["threshold"] == threshold)].iloc[0]
                cells.append(Gain(Stat((float(hit.difference),)), float(hit.accuracy_a), float(hit.ci_low),
                                  float(hit.ci_high), int(hit.clips)))
            words = METHOD_TABLE[method].words if method in METHOD_TABLE else method
            grid_rows.append((Text(title), Text(words), *cells))
    columns = tuple(Column(f"IoU > {short_threshold(t)}", (f"IoU > {short_threshold(t)}",)) for t in rows)
    grid = Grid((Column("Runs", ("Runs",)), Column("Method", ("Method",))), columns, tuple(grid_rows))
    text = " ".join(filter(None, [
        f"Differences in accuracy between runs on the same frames (B − A, each method against itself), in bold "
        f"relative to A; with the {LEVEL:.0%} interval from a paired bootstrap over clips (n/a with fewer than "
        f"{MIN_CLIPS}).", protocol]))
    markdown = "# Paired differences between runs\n\n" + text + "\n\n" + grid.to_markdown() + "".join(
        f"\n{note}\n" for note in notes)
    return {"table_pairs.md": markdown, "table_pairs.tex": grid.to_latex(text, "tab:compare-pairs", list(notes))}
