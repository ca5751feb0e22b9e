"""`roneld-eval compare`: runs side by side, as the RONELD paper's Tables II-V and Fig. 5.

`compare(runs, out)` reads finished run folders (see comparison/runs.py), refuses what is not
comparable (one dataset on different frames or ground truth, different threshold grids,
different paper-protocol settings unless `allow_mixed`), and writes comparison.csv, the
tables (accuracy, ablation, runtime, official, pairs) and curves.png/.svg/.pdf. Runs with the
same label on one dataset (seeds, checkpoints) are shown as mean ± sample standard deviation.
Every number comes from the runs' own tables; the only new computation is the paired
bootstrap over clips (roneld_eval/metrics/bootstrap.py) for seeds and for `pairs`.

This module is the orchestration; runs.py reads a run, comparable.py names the runs and checks
they compare, groups.py groups them by model, grids.py builds each table, tables.py renders a
table, figure.py draws the curves, sweeps.py compares checkpoint sweeps.
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path
from typing import Iterable, Mapping, Sequence

import pandas as pd

from ..version import __version__
from ..errors import ConfigError
from .groups import Group, _accuracy_of, _groups, method_name, ordered_methods
from .runs import Run, read_run
from .tables import threshold_label
from .comparable import check_comparable, check_outside_runs, parse_label_options, run_labels, run_pair
from .grids import (ABLATION_ROWS, ACCURACY_ROWS, ablation_files, accuracy_files, comparison_table, official_files,
                    pair_files, pairs_table, protocol_text, runtime_files, table_rows)

__all__ = ["compare", "Comparison", "parse_label_options", "read_run", "Run"]


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
    from ..output import Staging, csv_float
    from ..signals import terminate_as_interrupt

    if isinstance(runs, (str, Path)):
        runs = [runs]
    if not runs:
        raise ConfigError("give at least one run folder (written by `roneld-eval run`)")
    check_outside_runs(Path(out), runs)
    # OUT is taken before any run is read: a folder that cannot be used is refused at once, and
    # SIGTERM or SIGHUP anywhere end the command as Ctrl-C does, with nothing half-written.
    with terminate_as_interrupt(), OutputFolder(out, "compare") as folder:
        chosen = run_labels(runs, labels or {})
        loaded = tuple(read_run(path, chosen.get(k)) for k, path in enumerate(runs))
        notes = tuple(check_comparable(loaded, allow_mixed))
        grid = loaded[0].thresholds
        accuracy_rows = table_rows(thresholds, grid, ACCURACY_ROWS)
        ablation_rows = table_rows(thresholds, grid, ABLATION_ROWS)
        groups = _groups(loaded)
        pair_runs = [run_pair(loaded, pair) for pair in pairs]

        comparison = comparison_table(loaded)
        pair_table = pairs_table(pair_runs, grid)
        files: dict[str, str] = {"comparison.csv": comparison.to_csv(index=False, float_format=csv_float,
                                                                      lineterminator="\n")}
        protocol = protocol_text(loaded)
        files.update(accuracy_files(groups, accuracy_rows, notes))
        files.update(ablation_files(groups, ablation_rows, protocol, notes))
        files.update(runtime_files(groups, notes))
        files.update(official_files(groups, notes))
        if pair_runs:
            files["pairs.csv"] = pair_table.assign(threshold=pair_table["threshold"].map(threshold_label)).to_csv(
                index=False, float_format=csv_float, lineterminator="\n")
            files.update(pair_files(loaded, pair_runs, pair_table, accuracy_rows, protocol, notes))
        files["summary.json"] = json.dumps(_summary(loaded, groups, accuracy_rows, ablation_rows, pair_runs, notes,
                                                    allow_mixed), indent=2) + "\n"
        from ..report.figure_files import save_figure
        from .figure import curves_figure

        staging = Staging(folder)
        for name, text in files.items():
            staging.write_text(name, text)
        save_figure(curves_figure(_curves(groups)),
                    [staging.file(f"curves.{suffix}") for suffix in ("png", "svg", "pdf")])
        written = folder.commit()
    return Comparison(loaded, comparison, pair_table, notes, tuple(written))


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
            curves.append(Curve(group.dataset_name, group.label, method, method_name(method, group.label),
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
        "thresholds": [threshold_label(t) for t in runs[0].thresholds],
        "table_thresholds": [threshold_label(t) for t in accuracy_rows],
        "ablation_thresholds": [threshold_label(t) for t in ablation_rows],
        "pairs": [[str(a.path), str(b.path)] for a, b in pairs],
        "allow_mixed": allow_mixed,
        "notes": list(notes),
    }

