"""`roneld-eval score curvelanes`: the command-line face of benchmarks.curvelanes_score."""

from __future__ import annotations

from pathlib import Path

import click

from ...cluster import executed
from ...cli import (OUT_FOLDER, _announcer, _guard, _no_collections_at_exit, debug_option, sharding_options,
                    shard_written)


def _thresholds(context, parameter, value):
    from .score import VEGA_THRESHOLDS

    if value is None:
        return VEGA_THRESHOLDS
    if value.strip().lower() == "none":
        return ()
    try:
        return tuple(float(part) for part in value.split(","))
    except ValueError:
        raise click.BadParameter(f"{value!r} is not numbers separated by commas") from None


@click.command("curvelanes")
@click.option("--labels", required=True, type=click.Path(path_type=Path),
              help="Ground truth as <name>.lines.json (CurveLanes' labels folder).")
@click.option("--pred-root", "pred_roots", required=True, multiple=True, metavar="DIR|NAME=DIR",
              help="Predicted <name>.lines.json files mirroring --labels (one method), or a folder of such "
                   "folders (one method each). Repeatable. A missing file means no lanes.")
@click.option("--image-root", required=True, type=click.Path(path_type=Path),
              help="The images (<name>.jpg): each image is scored at its own size, read from its header.")
@click.option("--list", "list_file", type=click.Path(path_type=Path),
              help="Images to score, <name>.jpg a line. Default: every label file.")
@click.option("--score-threshold", default=0.0, show_default=True, type=float,
              help="A lane given with a score is kept when its score is above this (lanes without one always are).")
@click.option("--best-of", callback=_thresholds, metavar="T,T,...",
              help="Also give the best F1 over these score thresholds, labelled as chosen on the test set. "
                   "Default: vega's list (auto_lane.yml, 0f1d0d0: 0.56, 0.60, 0.63, ..., 0.93); none: only the "
                   "fixed --score-threshold.")
@click.option("--strict", is_flag=True, help="Stop when any listed image has no prediction file (default: no lanes).")
@click.option("--workers", type=click.IntRange(min=1), help="Worker processes. Default: all cores.")
@click.option("--out", type=OUT_FOLDER, help="Folder for official.csv.")
@sharding_options("images")
@click.option("--quiet", is_flag=True, help="No progress bar or table (warnings are still shown).")
@debug_option
def score_curvelanes_command(labels, pred_roots, image_root, list_file, score_threshold, best_of, strict, workers,
                             out, shard, executor, scheduler, quiet, debug):
    """CurveLanes precision, recall and F1 per method, as CondLaneNet's lane_metric.py computes them
    (the same as vega's LaneMetricCore; CurveLanes has no official tool)."""
    from .score import score_curvelanes

    _no_collections_at_exit()
    score = _guard(executed, debug, executor, scheduler, "score curvelanes", score_curvelanes,
                   labels, list(pred_roots), image_root, list_file=list_file,
                   score_threshold=score_threshold, best_of=best_of, out=out, workers=workers, progress=not quiet,
                   announce=_announcer(quiet), strict=strict, shard=shard)
    if score is None:  # a shard: its part is written
        shard_written(shard, out, quiet)
        return
    for warning in score.warnings:
        click.echo(warning, err=True)
    if not quiet:
        click.echo(f"{score.n_frames:,} images, {len(score.methods)} method{'s' if len(score.methods) > 1 else ''}")
        click.echo("| method | score threshold | chosen | precision (%) | recall (%) | F1 (%) |")
        click.echo("|---|---|---|---|---|---|")
        for row in score.rows.rows:
            click.echo(f"| {row[0]} | {row[1]:g} | {row[2]} | {100 * row[6]:.2f} | {100 * row[7]:.2f} | "
                       f"{100 * row[8]:.2f} |")
