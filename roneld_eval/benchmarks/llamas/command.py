"""`roneld-eval score llamas`, declared (roneld_eval.score_commands builds the command)."""

from __future__ import annotations

from typing import Any, Mapping

from ...score_commands import Echo, echo_diagnosis, Option, ScoreCommand, closing_options, diagnosis, pred_roots, width


def _report(score, values: Mapping[str, Any], echo: Echo) -> None:
    from .score import summary_table

    echo(f"{score.n_frames:,} labels, {len(score.methods)} method{'s' if len(score.methods) > 1 else ''}"
         + (f", width {values['width']}" if score.mf1s else ""))
    echo(summary_table(score).to_markdown(), nl=False)
    if score.diagnosed is not None:
        echo("")  # the table ends its own last line
    echo_diagnosis(score, values, echo)


COMMAND = ScoreCommand(
    "llamas",
    """Official LLAMAS precision, recall and F1 per method, as unsupervised_llamas'
    culane_metric/evaluate.py computes them, with the F1@0.75 and mF1 papers print; and the AP
    of probability maps per class, as its evaluation/evaluate_segmentation.py computes it.""",
    options=(
        Option("--labels", "One split's labels: <recording>/<frame>.json below it (LLAMAS's labels/valid), every "
                           "one scored.", kind="path", required=True),
        pred_roots("Predicted <recording>/<frame>.lines.txt (CULane format) for every label (one method), or a "
                   "folder of such folders (one method each), scored for F1. Repeatable. A missing file means "
                   "no lanes.", required=False),
        Option("--maps", "Probability maps <recording>/<frame>.json_<c>.png (c = 1..4: l1, l0, r0, r1; grey 0..255) "
                         "for every label, or a folder of such folders, scored for AP as evaluate_segmentation.py "
                         "--multi_class does. Repeatable; a method given both gets both.", name="map_roots",
               multiple=True, metavar="DIR|NAME=DIR"),
        Option("--iou", "IoU thresholds, scored in one pass. Default: 0.50:0.95:0.05 (F1@0.5, F1@0.75 and mF1).",
               metavar="T,T|START:STOP:STEP"),
        width("Lane width in pixels (evaluate.py's --width)."),
        *diagnosis(),
        *closing_options("Stop when any label has no prediction file (default: no lanes).",
                         "Folder for official.csv, summary.csv and summary.md.", "recordings"),
    ),
    positional=("labels", "pred_roots"),
    scorer_keywords={"map_roots": "maps"},
    report=_report,
)
