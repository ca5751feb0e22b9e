"""`roneld-eval score openlane`, declared (roneld_eval.score_commands builds the command)."""

from __future__ import annotations

from typing import Any, Mapping

from ...score_commands import Echo, echo_diagnosis, Option, ScoreCommand, closing_options, diagnosis, pred_roots, width


def _matchings(values: dict[str, Any]) -> dict[str, Any]:
    """--any-category: only the matching that ignores categories."""
    from .score import MODES

    any_only = values.pop("any_only")
    return {**values, "modes": MODES[1:] if any_only else MODES}


def _report(score, values: Mapping[str, Any], echo: Echo) -> None:
    from .score import summary_table

    echo(f"{score.n_frames:,} images, {len(score.methods)} method{'s' if len(score.methods) > 1 else ''}, "
         f"width {values['width']}")
    echo(summary_table(score))
    echo_diagnosis(score, values, echo)


COMMAND = ScoreCommand(
    "openlane",
    """Official OpenLane 2D precision, recall and F1 per method, with lanes matched within their
    category (the evaluator's default) and whatever their category (its -k).""",
    options=(
        Option("--labels", "Ground truth as <segment>/<frame>.json (OpenLane's lane2d annotations).", kind="path",
               required=True),
        pred_roots("Predicted <segment>/<frame>.json files mirroring --labels (one method), or a folder of such "
                   "folders (one method each). Repeatable. A missing file means no lanes."),
        Option("--list", "Images to score, <segment>/<frame>.jpg a line (its test_list.txt). Default: every "
                         "annotation.", name="list_file", kind="path"),
        Option("--iou", "IoU thresholds, scored in one pass. Default: 0.3.", metavar="T,T|START:STOP:STEP"),
        width("Lane width in pixels."),
        Option("--any-category", "Only the matching that ignores categories (the evaluator's -k); default: both.",
               name="any_only", kind="flag"),
        *diagnosis(),
        *closing_options("Stop when any listed image has no prediction file (default: no lanes).",
                         "Folder for official.csv and summary.md.", "segments"),
    ),
    positional=("labels", "pred_roots"),
    prepare=_matchings,
    report=_report,
)
