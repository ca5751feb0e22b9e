"""`roneld-eval score culane`: the command-line face of culane_score.score_culane."""

from __future__ import annotations

from pathlib import Path

import click

from ...config import MAX_LINE_THICKNESS
from ...cluster import executed
from ...cli import (OUT_FOLDER, _announcer, _guard, _no_collections_at_exit, debug_option, sharding_options,
                    shard_written)


@click.command("culane")
@click.option("--data-root", required=True, type=click.Path(path_type=Path),
              help="CULane root with the ground-truth .lines.txt files and list/test.txt.")
@click.option("--pred-root", "pred_roots", multiple=True, metavar="DIR|NAME=DIR|PATTERN",
              help="Predicted .lines.txt files mirrored under DIR (one method, named by the folder or NAME), or "
                   "a folder whose subfolders each mirror the list (one method each, as run --save-lanes writes "
                   "OUT/lanes/), or a quoted glob ('ckpt/epoch_*/lines': a checkpoint sweep, one checkpoint per "
                   "folder, named by what tells its path apart: epoch_12). Repeatable; all are scored in one pass. "
                   "A missing file means no lanes.")
@click.option("--pred-roots-from", "roots_file", type=click.Path(path_type=Path),
              help="A file listing checkpoints' prediction roots, DIR or NAME=DIR a line (relative to the file; "
                   "named as a glob's folders), added to --pred-root. With several checkpoints (from a glob or this "
                   "file), sweep.csv and sweep.png give each one's F1 over all frames and name the best (sweep.json: "
                   "on what; `roneld-eval compare` reads sweeps).")
@click.option("--list", "list_file", type=click.Path(path_type=Path),
              help="List file (default <data-root>/list/test.txt).")
@click.option("--iou", metavar="T|START:STOP:STEP",
              help="IoU threshold, or a grid scored in one pass (e.g. 0.50:0.95:0.05 for mF1). Default: 0.5.")
@click.option("--preset", type=click.Choice(["clrnet"]),  # culane_score.SCORE_PRESETS (a test keeps them equal)
              help="A paper family's grid: clrnet is --iou 0.50:0.95:0.05 with F1@50, F1@75 and mF1.")
@click.option("--width", default=30, show_default=True, type=click.IntRange(min=2, max=MAX_LINE_THICKNESS),
              help="Lane width in pixels at 1640x590.")
@click.option("--strict", is_flag=True, help="Stop when any listed frame has no prediction file (default: no lanes).")
@click.option("--workers", type=click.IntRange(min=1), help="Worker processes. Default: all cores.")
@click.option("--out", type=OUT_FOLDER,
              help="Folder for official.csv (every method, category and threshold), summary.csv and summary.md.")
@sharding_options("clips")
@click.option("--quiet", is_flag=True, help="No progress bar or table (warnings are still shown).")
@debug_option
def score_culane_command(data_root, pred_roots, roots_file, list_file, iou, preset, width, strict, workers, out,
                         shard, executor, scheduler, quiet, debug):
    """Official CULane precision, recall and F1 per method and category, as SCNN's lane_evaluation
    computes them; with a grid, F1@50, F1@75 and mF1 as CLRNet reports them."""
    from . import score as scoring  # not api: scoring needs none of the evaluation's imports

    _no_collections_at_exit()
    roots = list(pred_roots)
    if roots_file is not None:
        from ...sweeps import roots_from_file

        roots += _guard(roots_from_file, debug, roots_file)
    if not roots:
        raise click.UsageError("give --pred-root or --pred-roots-from")
    score = _guard(executed, debug, executor, scheduler, "score culane", scoring.score_culane,
                   data_root, roots, list_file=list_file, iou=iou, width=width,
                   out=out, workers=workers, progress=not quiet, announce=_announcer(quiet), preset=preset,
                   strict=strict, shard=shard)
    if score is None:  # a shard: its part is written
        shard_written(shard, out, quiet)
        return
    for warning in score.warnings:  # never silently, --quiet or not
        click.echo(warning, err=True)
    if not quiet:
        _print_culane_score(score, width)
        if score.sweep and len(score.trees) > 1:
            from .score import culane_sweep

            _, best = culane_sweep(score)
            column = score.summary_rows.columns[-1]
            if best is not None:
                click.echo(f"best by {column} over all frames: {best}" + (f" (sweep.csv, sweep.png in {out})"
                                                                         if out is not None else ""))
                from ...sweeps import ego_lanes_note

                note = ego_lanes_note(score.methods)
                if note:
                    click.echo(f"note: {note}, so the best by it does not tell which extracts lanes better (a run's "
                               "official.csv compares them on the ego lanes too)")


def _print_culane_score(score, width: int) -> None:
    from .score import first_threshold_table, grid_text, summary_table

    grid = grid_text(score.thresholds)
    click.echo(f"{score.n_frames:,} frames, {len(score.trees)} method{'s' if len(score.trees) > 1 else ''}, "
               f"{f'IoU > {grid}' if len(score.thresholds) == 1 else f'IoU thresholds {grid}'}, width {width}")
    if len(score.thresholds) > 1:
        click.echo("F1 in percent; mF1 = mean F1 over the thresholds")
        click.echo(summary_table(score).to_markdown())
    else:
        click.echo(first_threshold_table(score).to_markdown())
