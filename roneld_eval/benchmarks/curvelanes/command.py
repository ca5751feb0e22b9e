"""`roneld-eval score curvelanes`, declared (roneld_eval.score_commands builds the command)."""

from __future__ import annotations

from typing import Any, Mapping

from ...score_commands import Echo, echo_diagnosis, Option, ScoreCommand, closing_options, diagnosis, pred_roots


def _thresholds(value: str | None) -> tuple[float, ...]:
    from .score import VEGA_THRESHOLDS

    if value is None:
        return VEGA_THRESHOLDS
    if value.strip().lower() == "none":
        return ()
    try:
        return tuple(float(part) for part in value.split(","))
    except ValueError:
        raise ValueError(f"{value!r} is not numbers separated by commas") from None


def _report(score, values: Mapping[str, Any], echo: Echo) -> None:
    echo(f"{score.n_frames:,} images, {len(score.methods)} method{'s' if len(score.methods) > 1 else ''}")
    echo("| method | score threshold | chosen | precision (%) | recall (%) | F1 (%) |")
    echo("|---|---|---|---|---|---|")
    for row in score.rows.rows:
        echo(f"| {row[0]} | {row[1]:g} | {row[2]} | {100 * row[6]:.2f} | {100 * row[7]:.2f} | {100 * row[8]:.2f} |")
    echo_diagnosis(score, values, echo)


COMMAND = ScoreCommand(
    "curvelanes",
    """CurveLanes precision, recall and F1 per method, as CondLaneNet's lane_metric.py computes them
    (the same as vega's LaneMetricCore; CurveLanes has no official tool).""",
    options=(
        Option("--labels", "Ground truth as <name>.lines.json (CurveLanes' labels folder).", kind="path",
               required=True),
        pred_roots("Predicted <name>.lines.json files mirroring --labels (one method), or a folder of such "
                   "folders (one method each). Repeatable. A missing file means no lanes."),
        Option("--image-root", "The images (<name>.jpg): each image is scored at its own size, read from its "
                               "header.", kind="path", required=True),
        Option("--list", "Images to score, <name>.jpg a line. Default: every label file.", name="list_file",
               kind="path"),
        Option("--score-threshold", "A lane given with a score is kept when its score is above this (lanes "
                                    "without one always are).", kind="float", default=0.0, show_default=True),
        Option("--best-of", "Also give the best F1 over these score thresholds, labelled as chosen on the test set. "
                            "Default: vega's list (auto_lane.yml, 0f1d0d0: 0.56, 0.60, 0.63, ..., 0.93); none: only "
                            "the fixed --score-threshold.", metavar="T,T,...", parse=_thresholds),
        *diagnosis("a lane is kept when its score is above the threshold, one without a score always; the whole "
                   "curve behind --best-of"),
        *closing_options("Stop when any listed image has no prediction file (default: no lanes).",
                         "Folder for official.csv.", "images"),
    ),
    positional=("labels", "pred_roots", "image_root"),
    report=_report,
)
