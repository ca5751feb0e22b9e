"""`roneld-eval compare`: runs side by side, as the RONELD paper's Tables II-V and Fig. 5.

`compare(runs, out)` reads finished run folders (see comparison/runs.py), refuses what is not
comparable (one dataset on different frames or ground truth, different threshold grids,
different paper-protocol settings unless `allow_mixed`), and writes comparison.csv, the
tables (accuracy, ablation, runtime, official, pairs) and curves.png/.svg/.pdf. Runs with the
same label on one dataset (seeds, checkpoints) are shown as mean ± sample standard deviation.
Every number comes from the runs' own tables; the only new computation is the paired
bootstrap over clips (roneld_eval/metrics/bootstrap.py) for seeds and for `pairs`.
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass
from decimal import Decimal
from functools import partial
from pathlib import Path
from typing import Callable, Iterable, Mapping, Sequence

import numpy as np
import pandas as pd

from ..version import __version__
from ..thresholds import Thresholds, parse_thresholds
from ..errors import ConfigError, InputError
from ..metrics.bootstrap import LEVEL, MIN_CLIPS, paired_bootstrap
from ..benchmarks import benchmark_for
from ..methods import METHOD_TABLE
from ..report.tables import dataset_name, display_name
from ..wording import counted
from .groups import (ABLATION_METHOD, KNOWN_METHODS, PAPER_METHODS, Group, _accuracy_of, _column_of, _groups,
                     all_found, method_header, method_name, ordered_methods)
from .runs import Run, frames_of, read_run
from .tables import EMPTY, Cell, Column, Gain, Grid, Stat, Text, clips_text, wrap_words

ACCURACY_ROWS = ("0.3", "0.4", "0.5")  # Tables II/III
ABLATION_ROWS = ("0.3", "0.5")  # Table IV

__all__ = ["compare", "Comparison", "read_run", "Run"]


@dataclass(frozen=True, eq=False)
class Comparison:
    """What `compare` found and wrote."""

    runs: tuple[Run, ...]
    comparison: pd.DataFrame  # comparison.csv: run, label, dataset, model, method, threshold, n_tp, n_gt, accuracy
    pairs: pd.DataFrame  # pairs.csv (no rows without `pairs`)
    notes: tuple[str, ...]  # footnotes every table carries (mixed protocols)
    files: tuple[Path, ...]  # what was written


def compare(runs: Sequence[str | Path], out: str | Path = "comparison",
            labels: Mapping[str | Path, str] | None = None, thresholds: str | Sequence[float] | None = None,
            pairs: Iterable[str | tuple[str, str]] = (), allow_mixed: bool = False) -> Comparison:
    """Read finished run folders, check they are comparable, and write the comparison into `out`.

    `labels` maps a run folder to the name its model gets in tables (default: the run's
    config.toml `model`); `thresholds` picks the table rows (default 0.3/0.4/0.5, Table IV
    0.3/0.5); `pairs` names runs "A,B" whose difference B - A gets a paired bootstrap interval.
    """
    from ..output import OutputFolder
    from ..output import Staging
    from ..signals import terminate_as_interrupt

    if isinstance(runs, (str, Path)):
        runs = [runs]
    if not runs:
        raise ConfigError("give at least one run folder (written by `roneld-eval run`)")
    _check_outside_runs(Path(out), runs)
    # OUT is taken before any run is read: a folder that cannot be used is refused at once, and
    # SIGTERM or SIGHUP anywhere end the command as Ctrl-C does, with nothing half-written.
    with terminate_as_interrupt(), OutputFolder(out, "compare") as folder:
        chosen = _labels(runs, labels or {})
        loaded = tuple(read_run(path, chosen.get(k)) for k, path in enumerate(runs))
        notes = tuple(check_comparable(loaded, allow_mixed))
        grid = loaded[0].thresholds
        accuracy_rows = _table_rows(thresholds, grid, ACCURACY_ROWS)
        ablation_rows = _table_rows(thresholds, grid, ABLATION_ROWS)
        groups = _groups(loaded)
        pair_runs = [_pair(loaded, pair) for pair in pairs]

        comparison = comparison_table(loaded)
        pair_table = pairs_table(pair_runs, grid)
        files: dict[str, str] = {"comparison.csv": comparison.to_csv(index=False, float_format="%.10g",
                                                                      lineterminator="\n")}
        protocol = _protocol_text(loaded)
        files.update(_accuracy_files(groups, accuracy_rows, notes))
        files.update(_ablation_files(groups, ablation_rows, protocol, notes))
        files.update(_runtime_files(groups, notes))
        files.update(_official_files(groups, notes))
        if pair_runs:
            files["pairs.csv"] = pair_table.assign(threshold=pair_table["threshold"].map(_label)).to_csv(
                index=False, float_format="%.10g", lineterminator="\n")
            files.update(_pair_files(loaded, pair_runs, pair_table, accuracy_rows, protocol, notes))
        files["summary.json"] = json.dumps(_summary(loaded, groups, accuracy_rows, ablation_rows, pair_runs, notes,
                                                    allow_mixed), indent=2) + "\n"
        from .figure import curves_figure, save

        staging = Staging(folder)
        for name, text in files.items():
            staging.write_text(name, text)
        save(curves_figure(_curves(groups)), [staging.file(f"curves.{suffix}") for suffix in ("png", "svg", "pdf")])
        written = folder.commit()
    return Comparison(loaded, comparison, pair_table, notes, tuple(written))


# ---- which runs, under which names -----------------------------------------------------------

def _check_outside_runs(out: Path, runs: Sequence[str | Path]) -> None:
    """Refuse an OUT inside a compared run's folder: the run would then hold files it did not
    write, and a later run into that folder would refuse it."""
    try:
        parents = out.resolve().parents
    except (OSError, RuntimeError):
        return
    for run in runs:
        if any(_same_folder(parent, run) for parent in parents):
            raise InputError(out, f"lies inside the run folder {run}: write the comparison outside it")


def _same_folder(a: str | Path, b: str | Path) -> bool:
    if str(a) == str(b):
        return True
    try:
        return Path(a).resolve() == Path(b).resolve()
    except (OSError, RuntimeError):  # RuntimeError: a symlink loop (Python < 3.13)
        return False


def _labels(runs: Sequence[str | Path], labels: Mapping[str | Path, str]) -> dict[int, str]:
    """Run index -> label, for every run a `labels` key names."""
    chosen: dict[int, str] = {}
    for key, label in labels.items():
        if not isinstance(label, str) or not label.strip():
            raise ConfigError(f"--label {key}=: a label must not be empty")
        if not label.isprintable():
            raise ConfigError(f"--label {key}={label!a}: a label must not hold control characters")
        matches = [k for k, path in enumerate(runs) if _same_folder(path, key)]
        if not matches:
            raise ConfigError(f"--label {key}={label}: {key} is not one of the run folders compared")
        for k in matches:
            chosen[k] = label.strip()
    return chosen


def parse_label_options(options: Sequence[str], runs: Sequence[str | Path]) -> dict[str, str]:
    """`RUN=LABEL` texts (the CLI's --label) -> {run: label}; RUN may itself hold '='."""
    out: dict[str, str] = {}
    for option in options:
        cuts = [k for k, char in enumerate(option) if char == "="]
        for cut in cuts:  # the first '=' after which the left part names a run folder
            if any(_same_folder(run, option[:cut]) for run in runs):
                out[option[:cut]] = option[cut + 1:]
                break
        else:
            if not cuts:
                raise ConfigError(f"--label {option}: write RUN=LABEL, e.g. --label runs/enet=ENet-SAD")
            raise ConfigError(f"--label {option}: {option[:cuts[0]]} is not one of the run folders compared")
    return out


def run_title(run: Run, runs: Sequence[Run]) -> str:
    """The label, with the folder's name when another run of that dataset shares the label."""
    twins = [r for r in runs if r.label == run.label and r.dataset == run.dataset]
    return run.label if len(twins) == 1 else f"{run.label} ({run.path.name or run.path})"


def _pair(runs: Sequence[Run], pair: str | tuple[str, str]) -> tuple[Run, Run]:
    names = [p.strip() for p in pair.split(",")] if isinstance(pair, str) else [str(p).strip() for p in pair]
    if len(names) != 2 or not all(names):
        raise ConfigError(f"--pair {pair}: name two runs, A,B (a run folder, or a label only one run has)")
    found = []
    for name in names:
        by_path = [r for r in runs if _same_folder(r.path, name)]
        by_label = [r for r in runs if r.label == name]
        match = by_path or by_label
        if not match:
            raise ConfigError(f"--pair {pair}: {name} is neither a run folder compared nor a run's label")
        if len(match) > 1:
            raise ConfigError(f"--pair {pair}: {name} names {len(match)} runs; name one by its folder")
        found.append(match[0])
    a, b = found
    if a is b:
        raise ConfigError(f"--pair {pair}: names one run twice")
    if a.dataset != b.dataset or a.frames_key != b.frames_key or a.truth_key != b.truth_key:
        raise ConfigError(f"--pair {pair}: {a.name()} and {b.name()} were not scored on the same frames and "
                          f"ground truth, so no paired difference exists")
    if not [m for m in a.methods if m in b.methods]:
        raise ConfigError(f"--pair {pair}: the two runs have no method in common")
    return a, b


# ---- comparability ---------------------------------------------------------------------------

def check_comparable(runs: Sequence[Run], allow_mixed: bool = False) -> list[str]:
    """Raise ConfigError for runs that cannot share a table; return the footnotes of allowed mixes."""
    for k, run in enumerate(runs):
        for other in runs[:k]:
            if _same_folder(run.path, other.path):
                raise ConfigError(f"{run.name()} is given twice")
    first: dict[str, Run] = {}
    for run in runs:
        base = first.setdefault(run.dataset, run)
        if run is base:
            continue
        where = f"cannot compare {base.name()} with {run.name()}: both are {dataset_name(run.dataset)} runs"
        if run.frames_key != base.frames_key:
            a, b = frames_of(base), frames_of(run)
            differ = sorted(a ^ b)
            detail = (f"of the {counted(len(a | b), 'frame')} with a ground-truth ego lane in either, "
                      f"{len(differ)} {'is' if len(differ) == 1 else 'are'} in one run only, e.g. {differ[0]}"
                      if differ else
                      f"{base.counts['labelled_frames']} and {run.counts['labelled_frames']} frames scored")
            raise ConfigError(f"{where} but scored different frames ({detail}); compare runs of one dataset "
                              f"on the same frames")
        if run.clip_sizes != base.clip_sizes:
            clip = sorted(set(base.clip_sizes) ^ set(run.clip_sizes))[0][0]
            sizes = " and ".join(next((f"{w}x{h}" for name, w, h in one.clip_sizes if name == clip), "none")
                                 for one in (base, run))
            raise ConfigError(f"{where} on the same frames but at different frame sizes (clip {clip}: {sizes}); "
                              "evaluate both with one dataset's sizes")
        if run.truth_key != base.truth_key:
            raise ConfigError(f"{where} on the same frames but against different ground truth (ego lanes "
                              f"{base.counts['ego_lanes']} and {run.counts['ego_lanes']}, all lanes "
                              f"{base.counts['gt_lanes']} and {run.counts['gt_lanes']}); evaluate both on one "
                              f"dataset root")
    for run in runs[1:]:
        if run.thresholds != runs[0].thresholds:
            raise ConfigError(f"cannot compare {runs[0].name()} with {run.name()}: different IoU threshold grids "
                              f"({_grid_text(runs[0].thresholds)} and {_grid_text(run.thresholds)}); rerun one "
                              f"with the other's --thresholds")
    notes = []
    for index, (setting, value) in enumerate(runs[0].protocol):
        values: dict[object, list[Run]] = {}
        for run in runs:
            values.setdefault(run.protocol[index][1], []).append(run)
        if len(values) == 1:
            continue
        (a_value, a_runs), (b_value, b_runs) = list(values.items())[:2]
        if not allow_mixed:
            raise ConfigError(f"cannot compare {a_runs[0].name()} with {b_runs[0].name()}: different paper-protocol "
                              f"settings ({setting} = {a_value!r} and {b_value!r}); rerun one of them, or pass "
                              f"--allow-mixed to compare them anyway (the tables then say so)")
        shown = "; ".join(f"{value!r} for " + ", ".join(f"{r.label} on {dataset_name(r.dataset)}" for r in members)
                          for value, members in values.items())
        notes.append(f"Compared with --allow-mixed: the runs differ in {setting}: {shown}.")
    groups: dict[tuple[str, str], Run] = {}
    for run in runs:
        other = groups.setdefault((run.dataset, run.label), run)
        if other.methods != run.methods:
            raise ConfigError(f"cannot average {other.name()} and {run.name()}: both are {run.label!r} on "
                              f"{dataset_name(run.dataset)} but ran different methods ({','.join(other.methods)} "
                              f"and {','.join(run.methods)}); give one of them another --label")
    return notes


def _grid_text(grid: tuple[Decimal, ...]) -> str:
    if len(grid) == 1:
        return f"{grid[0]}"
    steps = {grid[k + 1] - grid[k] for k in range(len(grid) - 1)}
    step = f" step {steps.pop()}" if len(steps) == 1 else ""
    return f"{grid[0]}..{grid[-1]}{step}, {len(grid)} thresholds"


def _label(threshold: Decimal) -> str:
    """0.3 -> '0.30' (as accuracy.csv writes thresholds: at least two decimals)."""
    exponent = threshold.normalize().as_tuple().exponent
    assert isinstance(exponent, int), threshold  # thresholds are finite
    places = max(2, -exponent)
    return f"{threshold:.{places}f}"


def _short(threshold: Decimal) -> str:
    """0.30 -> '0.3', as the paper prints thresholds."""
    text = f"{threshold.normalize():f}"
    return text if "." in text else text + ".0"


def _table_rows(spec, grid: tuple[Decimal, ...], default: tuple[str, ...]) -> list[Decimal]:
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
            raise ConfigError(f"--thresholds: {_short(threshold)} is not among the runs' thresholds "
                              f"({_grid_text(grid)})")
    return asked


# ---- comparison.csv and pairs --------------------------------------------------------------------

def comparison_table(runs: Sequence[Run]) -> pd.DataFrame:
    """One row per run, method and threshold: the runs' own accuracy.csv numbers, side by side."""
    frames = []
    for run in runs:
        table = run.accuracy[["method", "threshold", "n_tp", "n_gt", "accuracy"]].copy()
        table["threshold"] = table["threshold"].map(_label)
        table.insert(0, "model", run.model)
        table.insert(0, "dataset", run.dataset)
        table.insert(0, "label", run.label)
        table.insert(0, "run", str(run.path))
        frames.append(table)
    return pd.concat(frames, ignore_index=True)


def _thresholds(grid: tuple[Decimal, ...]) -> Thresholds:
    return Thresholds(labels=tuple(_label(t) for t in grid), values=tuple(float(t) for t in grid))


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

def _protocol_text(runs: Sequence[Run]) -> str:
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
        columns += [("value", "baseline"), ("value", "roneld"), ("gain", "baseline")]
    else:
        columns += [("value", m) for m in PAPER_METHODS if m in methods]
    if ABLATION_METHOD in methods and "roneld" not in methods:
        columns.append(("value", ABLATION_METHOD))  # else Table IV shows it
    columns += [("value", m) for m in ordered_methods(methods) if m not in KNOWN_METHODS]
    return columns


def _gain(group: Group, method: str, threshold: Decimal, interval: pd.DataFrame | None) -> Gain:
    """RONELD's increase over `method`: a run's own numbers, or over seeds a pooled paired bootstrap."""
    increases = []
    for run in group.runs:
        stated = _column_of(run, method, "roneld_gain").get(threshold, math.nan)
        if math.isnan(stated):
            stated = _accuracy_of(run, "roneld")[threshold] - _accuracy_of(run, method)[threshold]
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
    return _bootstrap(pick(method), pick("roneld"), group.runs[0].thresholds)


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
    table_rows = tuple((Text(_short(t)),) + tuple(make(t) for make in makers) for t in rows)
    return Grid((Column("IoU threshold", ("IoU", "threshold")),), tuple(columns), table_rows)


def _interval_note(groups: Sequence[Group]) -> str:
    clips = groups[0].runs[0].clips
    return (f"Acc. Inc.: RONELD's increase over the model's own extraction (baseline), in bold relative to it; "
            f"with its {LEVEL:.0%} interval from a paired bootstrap over the {clips_text(clips)} (n/a with fewer "
            f"than {MIN_CLIPS}).")


def _accuracy_files(groups: Sequence[Group], rows, notes) -> dict[str, str]:
    markdown, latex = ["# Ego-lane accuracy (N_TP / N_gt): Tables II and III\n"], []
    for dataset in dict.fromkeys(g.dataset for g in groups):
        members = [g for g in groups if g.dataset == dataset]
        grid = accuracy_grid(members, rows)
        name = dataset_name(dataset)
        protocol = _protocol_text([run for group in members for run in group.runs])
        text = " ".join(filter(None, [f"Ego-lane accuracy on {name}.", protocol, _interval_note(members),
                                      _seeds_note(members)]))
        markdown += [f"## {name}\n", text + "\n", grid.to_markdown()] + [f"\n{note}\n" for note in notes]
        latex.append(grid.to_latex(text, f"tab:compare-accuracy-{dataset}", list(notes)))
    return {"table_accuracy.md": "\n".join(markdown), "table_accuracy.tex": "\n".join(latex)}


def _ablation_files(groups: Sequence[Group], rows, protocol: str, notes) -> dict[str, str]:
    """Table IV: RONELD without and with PFT, per dataset and model; nothing when no run has both."""
    holding = [g for g in groups if "roneld" in g.methods and ABLATION_METHOD in g.methods]
    if not holding:
        return {}
    columns, makers = [], []
    for group in holding:
        name = f"{dataset_name(group.dataset)}, {display_name('roneld', group.label)}"
        title = name if group.n == 1 else f"{name}, n = {group.n}"
        for method, short in ((ABLATION_METHOD, "w/o PFT"), ("roneld", "w/ PFT")):
            columns.append(Column(f"{name} {short}" + ("" if group.n == 1 else f" (n = {group.n})"), (short,), title))
            makers.append(lambda t, g=group, m=method: g.accuracy(m, t))
    table_rows = tuple((Text(_short(t)),) + tuple(make(t) for make in makers) for t in rows)
    grid = Grid((Column("IoU threshold", ("IoU", "threshold")),), tuple(columns), table_rows)
    text = " ".join(filter(None, [
        "Accuracy of RONELD without (w/o) and with (w/) preceding frame tracking (PFT): the methods 'roneld-nopft' "
        "and 'roneld'.", protocol, _seeds_note(holding)]))
    markdown = "# RONELD with and without PFT: Table IV\n\n" + text + "\n\n" + grid.to_markdown() + "".join(
        f"\n{note}\n" for note in notes)
    return {"table_ablation.md": markdown, "table_ablation.tex": grid.to_latex(text, "tab:compare-pft", list(notes))}



def _runtime_of(run: Run) -> dict[str, float]:
    return dict(zip(run.runtime["method"], run.runtime["mean_ms"].astype(float)))


def runtime_grid(groups: Sequence[Group]) -> Grid:
    """Table V: mean ms per frame of extraction per dataset and model (RONELD first), and a mean row."""
    methods = ordered_methods(m for g in groups for r in g.runs for m in r.runtime["method"] if m != "map loading")
    first = ("roneld", ABLATION_METHOD)  # Table V is RONELD's runtime; the others beside it
    methods = [m for m in first if m in methods] + [m for m in methods if m not in first]
    columns = tuple(Column((METHOD_TABLE[m].words if m in METHOD_TABLE else m) + " (ms)",
                           METHOD_TABLE[m].word_parts if m in METHOD_TABLE else wrap_words(m)) for m in methods)
    rows = []
    means: dict[str, list[float]] = {m: [] for m in methods}
    for group in groups:
        cells: list[Cell] = []
        for method in methods:
            values = all_found([_runtime_of(run).get(method) for run in group.runs])
            if values is None:
                cells.append(EMPTY)
                continue
            cell = Stat(tuple(values))
            means[method].append(cell.mean)
            cells.append(cell)
        title = group.label if group.n == 1 else f"{group.label} (n = {group.n})"
        rows.append((Text(dataset_name(group.dataset)), Text(title), *cells))
    mean_cells = [Stat((math.fsum(means[m]) / len(means[m]),)) if means[m] else EMPTY for m in methods]
    rows.append((Text("Mean"), Text(""), *mean_cells))
    return Grid((Column("Dataset", ("Dataset",)), Column("Model", ("Model",))), columns, tuple(rows),
                rules_after=(len(rows) - 2,))


def _runtime_files(groups: Sequence[Group], notes) -> dict[str, str]:
    grid = runtime_grid(groups)
    text = " ".join(filter(None, [
        "Runtime: mean milliseconds per frame of lane extraction alone (after numba warm-up; map loading apart), "
        "as each run measured it on its own machine; the Mean row averages the rows above.",
        _seeds_note(groups)]))
    markdown = "# Runtime per frame: Table V\n\n" + text + "\n\n" + grid.to_markdown() + "".join(
        f"\n{note}\n" for note in notes)
    return {"table_runtime.md": markdown, "table_runtime.tex": grid.to_latex(text, "tab:compare-runtime", list(notes))}


def _official_files(groups: Sequence[Group], notes) -> dict[str, str]:
    markdown, latex = ["# Official scores\n"], []
    seeds = _seeds_note(groups)
    for dataset in dict.fromkeys(g.dataset for g in groups):
        members = [g for g in groups if g.dataset == dataset]
        name = dataset_name(dataset)
        grid, text = benchmark_for(dataset).official_comparison(members)
        text = " ".join(filter(None, [text, seeds]))
        markdown += [f"## {name}\n", text + "\n", grid.to_markdown()] + [f"\n{note}\n" for note in notes]
        latex.append(grid.to_latex(text, f"tab:compare-official-{dataset}", list(notes)))
    return {"table_official.md": "\n".join(markdown), "table_official.tex": "\n".join(latex)}


def _pair_files(everyone: Sequence[Run], pairs: Sequence[tuple[Run, Run]], table: pd.DataFrame,
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
    columns = tuple(Column(f"IoU > {_short(t)}", (f"IoU > {_short(t)}",)) for t in rows)
    grid = Grid((Column("Runs", ("Runs",)), Column("Method", ("Method",))), columns, tuple(grid_rows))
    text = " ".join(filter(None, [
        f"Differences in accuracy between runs on the same frames (B − A, each method against itself), in bold "
        f"relative to A; with the {LEVEL:.0%} interval from a paired bootstrap over clips (n/a with fewer than "
        f"{MIN_CLIPS}).", protocol]))
    markdown = "# Paired differences between runs\n\n" + text + "\n\n" + grid.to_markdown() + "".join(
        f"\n{note}\n" for note in notes)
    return {"table_pairs.md": markdown, "table_pairs.tex": grid.to_latex(text, "tab:compare-pairs", list(notes))}


# ---- the figure and the record -----------------------------------------------------------------

def _curves(groups: Sequence[Group]):
    from .figure import Curve

    curves = []
    for group in groups:
        for method in ordered_methods(group.methods):
            per_run = []
            for run in group.runs:
                values = _accuracy_of(run, method)
                per_run.append(tuple(values[t] for t in run.thresholds))
            curves.append(Curve(dataset_name(group.dataset), group.label, method, method_name(method, group.label),
                                tuple(float(t) for t in group.runs[0].thresholds), tuple(per_run)))
    return curves


def _summary(runs, groups, accuracy_rows, ablation_rows, pairs, notes, allow_mixed) -> dict:
    return {
        "tool": "roneld-eval compare",
        "version": __version__,
        "runs": [{"run": str(r.path), "label": r.label, "model": r.model, "dataset": r.dataset,
                  "methods": list(r.methods), "clips": r.clips, "scored_frames": r.counts["labelled_frames"],
                  "ego_lanes": r.counts["ego_lanes"]} for r in runs],
        "groups": [{"dataset": g.dataset, "label": g.label, "runs": [str(r.path) for r in g.runs]} for g in groups],
        "thresholds": [_label(t) for t in runs[0].thresholds],
        "table_thresholds": [_label(t) for t in accuracy_rows],
        "ablation_thresholds": [_label(t) for t in ablation_rows],
        "pairs": [[str(a.path), str(b.path)] for a, b in pairs],
        "allow_mixed": allow_mixed,
        "notes": list(notes),
    }

