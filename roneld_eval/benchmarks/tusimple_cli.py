"""`roneld-eval score tusimple`: the command-line face of tusimple_score.score_tusimple."""

from __future__ import annotations

from pathlib import Path

import click

from ..cluster import executed
from ..cli import OUT_FOLDER, _guard, debug_option, sharding_options, shard_written


@click.command("tusimple")
@click.option("--labels", required=True, type=click.Path(path_type=Path), help="TuSimple label file (test_label.json).")
@click.option("--pred", required=True, type=click.Path(path_type=Path),
              help="Predictions, one JSON object per line: raw_file, lanes, h_samples, optional run_time (ms).")
@click.option("--out", type=OUT_FOLDER,
              help="Folder for official.csv: accuracy, fp, fn, f1_ufld, f1_clrnet.")
@sharding_options("clips")
@click.option("--quiet", is_flag=True, help="Print nothing.")
@debug_option
def score_tusimple_command(labels, pred, out, shard, executor, scheduler, quiet, debug):
    """Official TuSimple accuracy, FP and FN, as tusimple-benchmark's evaluate/lane.py computes them, and F1
    as UFLD-v2's lane2.py (f1_ufld) and CLRNet's tusimple_metric.py (f1_clrnet) compute it."""
    from . import tusimple_score as scoring

    score = _guard(executed, debug, executor, scheduler, "score tusimple", scoring.score_tusimple, labels, pred, out,
                   shard)
    if score is None:  # a shard: its part is written
        shard_written(shard, out, quiet)
        return
    if not quiet:
        click.echo(f"{score.n_frames} frames: Accuracy {score.accuracy:.10g}  FP {score.fp:.10g}  FN {score.fn:.10g}  "
                   f"F1 {score.f1_ufld:.10g} (UFLD-v2 lane2.py)  {score.f1_clrnet:.10g} (CLRNet tusimple_metric.py)")
