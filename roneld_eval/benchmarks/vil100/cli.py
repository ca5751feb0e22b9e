"""`roneld-eval score vil100`: the command-line face of benchmarks.vil100_score."""

from __future__ import annotations

from pathlib import Path

import click

from ...config import MAX_LINE_THICKNESS
from ...cluster import executed
from ...cli import (OUT_FOLDER, _announcer, _guard, _no_collections_at_exit, debug_option, sharding_options,
                    shard_written)


@click.command("vil100")
@click.option("--labels", required=True, type=click.Path(path_type=Path),
              help="Ground truth as <sequence>/<frame>.lines.txt (MMA-Net's evaluation/txt/anno_txt).")
@click.option("--pred-root", "pred_roots", required=True, multiple=True, metavar="DIR|NAME=DIR",
              help="Predicted .lines.txt files mirroring --labels (one method, named by the folder or NAME), or a "
                   "folder whose subfolders each do (one method each). Repeatable; all are scored in one pass. "
                   "A missing file means no lanes.")
@click.option("--pred-format", type=click.Choice(("lines", "png")), default="lines", show_default=True,
              help="Predictions as .lines.txt, or as MMA-Net's instance masks <sequence>/<frame>.png (each grey "
                   "value a lane), turned into lanes as its generate_iou_pred_txt.py does.")
@click.option("--list", "list_file", type=click.Path(path_type=Path),
              help="Frames to score, <sequence>/<frame> a line (MMA-Net's /JPEGImages/<sequence>/<frame>.jpg lines "
                   "too). Default: every labelled frame.")
@click.option("--image-root", type=click.Path(path_type=Path),
              help="The dataset's JPEGImages: each sequence's size is its first listed frame's.")
@click.option("--json-root", type=click.Path(path_type=Path),
              help="The dataset's Json folder: each sequence's size from its first frame's info.width/height.")
@click.option("--sizes", "sizes_file", type=click.Path(path_type=Path),
              help='JSON file of sizes: {"<sequence>": {"width": W, "height": H}, ...}.')
@click.option("--iou", metavar="T,T|START:STOP:STEP", help="IoU thresholds, scored in one pass. Default: 0.5,0.8.")
@click.option("--width", default=30, show_default=True, type=click.IntRange(min=2, max=MAX_LINE_THICKNESS),
              help="Lane width in pixels for F1 and mIoU, at every sequence's size (as MMA-Net's evaluator); the "
                   "temporal metrics draw 30 px, as RVLD's script.")
@click.option("--temporal/--no-temporal", default=True, show_default=True,
              help="Also RVLD's temporal metrics Rs, Rj, Rm (evaluate_temporal.py), each threshold as tau.")
@click.option("--strict", is_flag=True,
              help="Stop when any listed frame has no prediction or ground-truth file (default: no lanes, a warning).")
@click.option("--workers", type=click.IntRange(min=1), help="Worker processes. Default: all cores.")
@click.option("--out", type=OUT_FOLDER,
              help="Folder for official.csv (every method, sequence, scenario and threshold), temporal.csv and "
                   "summary.md.")
@sharding_options("sequences")
@click.option("--quiet", is_flag=True, help="No progress bar or table (warnings are still shown).")
@debug_option
def score_vil100_command(labels, pred_roots, pred_format, list_file, image_root, json_root, sizes_file, iou, width,
                         temporal, strict, workers, out, shard, executor, scheduler, quiet, debug):
    """Official VIL-100 F1 and mIoU per method, sequence and scenario, as MMA-Net's evaluate_iou.py
    and its CULane evaluator compute them (each sequence at its own size)."""
    from .score import RVLD_ACC_NOTE, score_vil100, summary_table

    _no_collections_at_exit()
    score = _guard(executed, debug, executor, scheduler, "score vil100", score_vil100,
                   labels, list(pred_roots), list_file=list_file, image_root=image_root,
                   json_root=json_root, sizes_file=sizes_file, iou=iou, width=width, out=out, workers=workers,
                   progress=not quiet, announce=_announcer(quiet), strict=strict, temporal=temporal,
                   pred_format=pred_format, shard=shard)
    if score is None:  # a shard: its part is written
        shard_written(shard, out, quiet)
        return
    for warning in score.warnings:
        click.echo(warning, err=True)
    if not quiet:
        click.echo(f"{score.n_frames:,} frames of {score.n_sequences} sequences, {len(score.methods)} "
                   f"method{'s' if len(score.methods) > 1 else ''}, width {width}")
        click.echo(summary_table(score))
        if any(version == "rvld" for _, version in score.acc_overall):
            click.echo(RVLD_ACC_NOTE)
