"""`roneld-eval score tusimple`: the command-line face of tusimple_score.score_tusimple."""

from __future__ import annotations

from pathlib import Path

import click

from ...cluster import executed
from ...cli import OUT_FOLDER, _guard, debug_option, sharding_options, shard_written


@click.command("tusimple")
@click.option("--labels", required=True, type=click.Path(path_type=Path), help="TuSimple label file (test_label.json).")
@click.option("--pred", "preds", required=True, multiple=True, metavar="FILE|NAME=FILE",
              help="Predictions, one JSON object per line: raw_file, lanes, h_samples, optional run_time (ms). One "
                   "method, named by the file's stem or NAME. Repeatable: every method against one reading of the "
                   "labels.")
@click.option("--out", type=OUT_FOLDER,
              help="Folder for official.csv: method, accuracy, fp, fn, f1_ufld, f1_clrnet (a row per method).")
@sharding_options("clips")
@click.option("--quiet", is_flag=True, help="Print nothing.")
@debug_option
def score_tusimple_command(labels, preds, out, shard, executor, scheduler, quiet, debug):
    """Official TuSimple accuracy, FP and FN, as tusimple-benchmark's evaluate/lane.py computes them, and F1
    as UFLD-v2's lane2.py (f1_ufld) and CLRNet's tusimple_metric.py (f1_clrnet) compute it."""
    from . import score as scoring

    pred = preds[0] if len(preds) == 1 else list(preds)  # one file: its score, as the library gives it
    score = _guard(executed, debug, executor, scheduler, "score tusimple", scoring.score_tusimple, labels, pred, out,
                   shard)
    if score is None:  # a shard: its part is written
        shard_written(shard, out, quiet)
        return
    if quiet:
        return
    for method, one in (score.items() if isinstance(score, dict) else [("", score)]):
        click.echo(f"{f'{method}: ' if method else ''}{one.n_frames} frames: Accuracy {one.accuracy:.10g}  "
                   f"FP {one.fp:.10g}  FN {one.fn:.10g}  F1 {one.f1_ufld:.10g} (UFLD-v2 lane2.py)  "
                   f"{one.f1_clrnet:.10g} (CLRNet tusimple_metric.py)")
