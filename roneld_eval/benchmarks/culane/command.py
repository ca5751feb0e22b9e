"""`roneld-eval score culane`, declared (roneld_eval.score_commands builds the command)."""

from __future__ import annotations

from typing import Any, Mapping

from ...score_commands import Echo, echo_diagnosis, Option, ScoreCommand, closing_options, diagnosis, pred_roots, width


def _with_listed_roots(values: dict[str, Any]) -> dict[str, Any]:
    """--pred-roots-from's roots added to --pred-root's; one of them must give some."""
    import click

    roots = list(values["pred_roots"])
    if values["roots_file"] is not None:
        from ...sweeps import roots_from_file

        roots += roots_from_file(values["roots_file"])
    if not roots:
        raise click.UsageError("give --pred-root or --pred-roots-from")
    return {**values, "pred_roots": roots}


def _report(score, values: Mapping[str, Any], echo: Echo) -> None:
    from .score import culane_sweep, first_threshold_table, grid_text, summary_table

    grid = grid_text(score.thresholds)
    echo(f"{score.n_frames:,} frames, {len(score.trees)} method{'s' if len(score.trees) > 1 else ''}, "
         f"{f'IoU > {grid}' if len(score.thresholds) == 1 else f'IoU thresholds {grid}'}, width {values['width']}")
    if len(score.thresholds) > 1:
        echo("F1 in percent; mF1 = mean F1 over the thresholds")
        echo(summary_table(score).to_markdown())
    else:
        echo(first_threshold_table(score).to_markdown())
    echo_diagnosis(score, values, echo, score.highlighted[0])
    if score.sweep and len(score.trees) > 1:
        _, best = culane_sweep(score)
        column = score.summary_rows.columns[-1]
        if best is not None:
            folder = values["out"]
            echo(f"best by {column} over all frames: {best}" + (f" (sweep.csv, sweep.png in {folder})"
                                                                if folder is not None else ""))
            from ...sweeps import ego_lanes_note

            note = ego_lanes_note(score.methods)
            if note:
                echo(f"note: {note}, so the best by it does not tell which extracts lanes better (a run's "
                     "official.csv compares them on the ego lanes too)")


COMMAND = ScoreCommand(
    "culane",
    """Official CULane precision, recall and F1 per method and category, as SCNN's lane_evaluation
    computes them; with a grid, F1@50, F1@75 and mF1 as CLRNet reports them.""",
    options=(
        Option("--data-root", "CULane root with the ground-truth .lines.txt files and list/test.txt.", kind="path",
               required=True),
        pred_roots("Predicted .lines.txt files mirrored under DIR (one method, named by the folder or NAME), or "
                   "a folder whose subfolders each mirror the list (one method each, as run --save-lanes writes "
                   "OUT/lanes/), or a quoted glob ('ckpt/epoch_*/lines': a checkpoint sweep, one checkpoint per "
                   "folder, named by what tells its path apart: epoch_12). Repeatable; all are scored in one pass. "
                   "A missing file means no lanes.", required=False, metavar="DIR|NAME=DIR|PATTERN"),
        Option("--pred-roots-from",
               "A file listing checkpoints' prediction roots, DIR or NAME=DIR a line (relative to the file; "
               "named as a glob's folders), added to --pred-root. With several checkpoints (from a glob or this "
               "file), sweep.csv and sweep.png give each one's F1 over all frames and name the best (sweep.json: "
               "on what; `roneld-eval compare` reads sweeps).", name="roots_file", kind="path"),
        Option("--list", "List file (default <data-root>/list/test.txt).", name="list_file", kind="path"),
        Option("--iou", "IoU threshold, or a grid scored in one pass (e.g. 0.50:0.95:0.05 for mF1). Default: 0.5.",
               metavar="T|START:STOP:STEP"),
        Option("--preset", "A paper family's grid: clrnet is --iou 0.50:0.95:0.05 with F1@50, F1@75 and mF1.",
               kind="choice", choices=("clrnet",)),  # culane_score.SCORE_PRESETS (a test keeps them equal)
        width("Lane width in pixels at 1640x590."),
        *diagnosis("a lane is kept when its score in <stem>.scores.txt is at least the threshold; 1.0 without "
                   "the file"),
        *closing_options("Stop when any listed frame has no prediction file (default: no lanes).",
                         "Folder for official.csv (every method, category and threshold), summary.csv and "
                         "summary.md.", "clips"),
    ),
    positional=("data_root", "pred_roots"),
    prepare=_with_listed_roots,
    driver_only=("roots_file",),
    report=_report,
)
