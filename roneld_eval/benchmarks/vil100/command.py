"""`roneld-eval score vil100`, declared (roneld_eval.score_commands builds the command)."""

from __future__ import annotations

from typing import Any, Mapping

from ...score_commands import Echo, echo_diagnosis, Option, ScoreCommand, closing_options, diagnosis, pred_roots, width


def _report(score, values: Mapping[str, Any], echo: Echo) -> None:
    from .score import RVLD_ACC_NOTE, summary_table

    echo(f"{score.n_frames:,} frames of {score.n_sequences} sequences, {len(score.methods)} "
         f"method{'s' if len(score.methods) > 1 else ''}, width {values['width']}")
    echo(summary_table(score))
    if any(version == "rvld" for _, version in score.acc_overall):
        echo(RVLD_ACC_NOTE)
    echo_diagnosis(score, values, echo)


COMMAND = ScoreCommand(
    "vil100",
    """Official VIL-100 F1 and mIoU per method, sequence and scenario, as MMA-Net's evaluate_iou.py
    and its CULane evaluator compute them (each sequence at its own size).""",
    options=(
        Option("--labels", "Ground truth as <sequence>/<frame>.lines.txt (MMA-Net's evaluation/txt/anno_txt).",
               kind="path", required=True),
        pred_roots("Predicted .lines.txt files mirroring --labels (one method, named by the folder or NAME), or a "
                   "folder whose subfolders each do (one method each). Repeatable; all are scored in one pass. "
                   "A missing file means no lanes."),
        Option("--pred-format", "Predictions as .lines.txt, or as MMA-Net's instance masks <sequence>/<frame>.png "
                                "(each grey value a lane), turned into lanes as its generate_iou_pred_txt.py does.",
               kind="choice", choices=("lines", "png"), default="lines", show_default=True),
        Option("--list", "Frames to score, <sequence>/<frame> a line (MMA-Net's /JPEGImages/<sequence>/<frame>.jpg "
                         "lines too). Default: every labelled frame.", name="list_file", kind="path"),
        Option("--image-root", "The dataset's JPEGImages: each sequence's size is its first listed frame's.",
               kind="path"),
        Option("--json-root", "The dataset's Json folder: each sequence's size from its first frame's "
                              "info.width/height.", kind="path"),
        Option("--sizes", 'JSON file of sizes: {"<sequence>": {"width": W, "height": H}, ...}.', name="sizes_file",
               kind="path"),
        Option("--iou", "IoU thresholds, scored in one pass. Default: 0.5,0.8.", metavar="T,T|START:STOP:STEP"),
        width("Lane width in pixels for F1 and mIoU, at every sequence's size (as MMA-Net's evaluator); the "
              "temporal metrics draw 30 px, as RVLD's script."),
        Option("--temporal/--no-temporal", "Also RVLD's temporal metrics Rs, Rj, Rm (evaluate_temporal.py), each "
                                           "threshold as tau.", default=True, show_default=True),
        *diagnosis("a lane is kept when its score in <frame>.scores.txt is at least the threshold; 1.0 without the "
                   "file"),
        *closing_options("Stop when any listed frame has no prediction or ground-truth file (default: no lanes, "
                         "a warning).",
                         "Folder for official.csv (every method, sequence, scenario and threshold), temporal.csv and "
                         "summary.md.", "sequences"),
    ),
    positional=("labels", "pred_roots"),
    report=_report,
)
