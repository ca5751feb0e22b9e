"""`roneld-eval score openlane`: the command-line face of benchmarks.openlane_score."""

from __future__ import annotations

from pathlib import Path

import click

from ...config import MAX_LINE_THICKNESS
from ...cluster import executed
from ...cli import (OUT_FOLDER, _announcer, _guard, _no_collections_at_exit, debug_option, sharding_options,
                    shard_written)


@click.command("openlane")
@click.option("--labels", required=True, type=click.Path(path_type=Path),
              help="Ground truth as <segment>/<frame>.json (OpenLane's lane2d annotations).")
@click.option("--pred-root", "pred_roots", required=True, multiple=True, metavar="DIR|NAME=DIR",
              help="Predicted <segment>/<frame>.json files mirroring --labels (one method), or a folder of such "
                   "folders (one method each). Repeatable. A missing file means no lanes.")
@click.option("--list", "list_file", type=click.Path(path_type=Path),
              help="Images to score, <segment>/<frame>.jpg a line (its test_list.txt). Default: every annotation.")
@click.option("--iou", metavar="T,T|START:STOP:STEP", help="IoU thresholds, scored in one pass. Default: 0.3.")
@click.option("--width", default=30, show_default=True, type=click.IntRange(min=2, max=MAX_LINE_THICKNESS),
              help="Lane width in pixels.")
@click.option("--any-category", "any_only", is_flag=True,
              help="Only the matching that ignores categories (the evaluator's -k); default: both.")
@click.option("--strict", is_flag=True, help="Stop when any listed image has no prediction file (default: no lanes).")
@click.option("--workers", type=click.IntRange(min=1), help="Worker processes. Default: all cores.")
@click.option("--out", type=OUT_FOLDER, help="Folder for official.csv and summary.md.")
@sharding_options("segments")
@click.option("--quiet", is_flag=True, help="No progress bar or table (warnings are still shown).")
@debug_option
def score_openlane_command(labels, pred_roots, list_file, iou, width, any_only, strict, workers, out, shard, executor,
                           scheduler, quiet, debug):
    """Official OpenLane 2D precision, recall and F1 per method, with lanes matched within their
    category (the evaluator's default) and whatever their category (its -k)."""
    from .score import MODES, score_openlane, summary_table

    _no_collections_at_exit()
    modes = MODES[1:] if any_only else MODES
    score = _guard(executed, debug, executor, scheduler, "score openlane", score_openlane,
                   labels, list(pred_roots), list_file=list_file, iou=iou, width=width,
                   modes=modes, out=out, workers=workers, progress=not quiet, announce=_announcer(quiet),
                   strict=strict, shard=shard)
    if score is None:  # a shard: its part is written
        shard_written(shard, out, quiet)
        return
    for warning in score.warnings:
        click.echo(warning, err=True)
    if not quiet:
        click.echo(f"{score.n_frames:,} images, {len(score.methods)} method{'s' if len(score.methods) > 1 else ''}, "
                   f"width {width}")
        click.echo(summary_table(score))
