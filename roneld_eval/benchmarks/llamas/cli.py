"""`roneld-eval score llamas`: the command-line face of benchmarks.llamas_score."""

from __future__ import annotations

from pathlib import Path

import click

from ...config import MAX_LINE_THICKNESS
from ...cluster import executed
from ...cli import (OUT_FOLDER, _announcer, _guard, _no_collections_at_exit, debug_option, sharding_options,
                    shard_written)


@click.command("llamas")
@click.option("--labels", required=True, type=click.Path(path_type=Path),
              help="One split's labels: <recording>/<frame>.json below it (LLAMAS's labels/valid), every one scored.")
@click.option("--pred-root", "pred_roots", multiple=True, metavar="DIR|NAME=DIR",
              help="Predicted <recording>/<frame>.lines.txt (CULane format) for every label (one method), or a "
                   "folder of such folders (one method each), scored for F1. Repeatable. A missing file means "
                   "no lanes.")
@click.option("--maps", "map_roots", multiple=True, metavar="DIR|NAME=DIR",
              help="Probability maps <recording>/<frame>.json_<c>.png (c = 1..4: l1, l0, r0, r1; grey 0..255) "
                   "for every label, or a folder of such folders, scored for AP as evaluate_segmentation.py "
                   "--multi_class does. Repeatable; a method given both gets both.")
@click.option("--iou", metavar="T,T|START:STOP:STEP",
              help="IoU thresholds, scored in one pass. Default: 0.50:0.95:0.05 (F1@0.5, F1@0.75 and mF1).")
@click.option("--width", default=30, show_default=True, type=click.IntRange(min=2, max=MAX_LINE_THICKNESS),
              help="Lane width in pixels (evaluate.py's --width).")
@click.option("--strict", is_flag=True, help="Stop when any label has no prediction file (default: no lanes).")
@click.option("--workers", type=click.IntRange(min=1), help="Worker processes. Default: all cores.")
@click.option("--out", type=OUT_FOLDER, help="Folder for official.csv, summary.csv and summary.md.")
@sharding_options("recordings")
@click.option("--quiet", is_flag=True, help="No progress bar or table (warnings are still shown).")
@debug_option
def score_llamas_command(labels, pred_roots, map_roots, iou, width, strict, workers, out, shard, executor, scheduler,
                         quiet, debug):
    """Official LLAMAS precision, recall and F1 per method, as unsupervised_llamas'
    culane_metric/evaluate.py computes them, with the F1@0.75 and mF1 papers print; and the AP
    of probability maps per class, as its evaluation/evaluate_segmentation.py computes it."""
    from .score import score_llamas, summary_table

    _no_collections_at_exit()
    score = _guard(executed, debug, executor, scheduler, "score llamas", score_llamas,
                   labels, list(pred_roots), iou=iou, width=width, out=out, workers=workers,
                   progress=not quiet, announce=_announcer(quiet), strict=strict, maps=list(map_roots), shard=shard)
    if score is None:  # a shard: its part is written
        shard_written(shard, out, quiet)
        return
    for warning in score.warnings:
        click.echo(warning, err=True)
    if not quiet:
        click.echo(f"{score.n_frames:,} labels, {len(score.methods)} method{'s' if len(score.methods) > 1 else ''}"
                   + (f", width {width}" if score.mf1s else ""))
        click.echo(summary_table(score).to_markdown(), nl=False)
