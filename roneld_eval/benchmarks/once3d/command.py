"""`roneld-eval score once3d`, declared (roneld_eval.score_commands builds the command)."""

from __future__ import annotations

from typing import Any, Mapping

from ...score_commands import Echo, Option, ScoreCommand, closing_options, pred_roots


def _report(score, values: Mapping[str, Any], echo: Echo) -> None:
    from .score import summary_table

    echo(f"{score.n_frames:,} frame{'s' if score.n_frames != 1 else ''}; {score.describe()}")
    for method in score.methods:
        if len(score.methods) > 1:
            echo(f"{method}:")
        echo(summary_table(score, method))


COMMAND = ScoreCommand(
    "once3d",
    """Official ONCE-3DLanes F1, precision, recall and distance error at each score threshold 0.10-0.95,
    as its evaluator (once_3dlanes_benchmark evaluation/eval_utils.py) computes them.""",
    options=(
        Option("--labels", "Labels as <segment>/cam01/<frame>.json ({\"lanes\": [[[x, y, z], ...], ...]}, camera "
                           "coordinates in metres).", kind="path", required=True),
        pred_roots("Prediction files mirroring --labels ({\"lanes\": [{\"points\": [[x, y, z], ...], \"score\": s}, "
                   "...]}), or a folder of such folders (one method each). Repeatable. A missing file means no "
                   "lanes."),
        Option("--iou-gate", "A labelled opt-in, not the official evaluator: a matched pair also needs this top-view "
                             "IoU (the paper's gate; the evaluator reads iou_thresh 0.3 and never uses it).",
               kind="float", metavar="IOU"),
        *closing_options("Stop when any labelled frame has no prediction file (default: no lanes).",
                         "Folder for official.csv and summary.md.", "segments"),
    ),
    positional=("labels", "pred_roots"),
    report=_report,
)
