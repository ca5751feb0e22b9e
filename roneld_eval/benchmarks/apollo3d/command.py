"""`roneld-eval score apollo3d`, declared (roneld_eval.score_commands builds the command)."""

from __future__ import annotations

from typing import Any, Mapping

from ...score_commands import WORKERS, Echo, Option, ScoreCommand, Sharding, out, quiet


def _one_or_several(values: dict[str, Any]) -> dict[str, Any]:
    preds = values.pop("preds")
    return {**values, "pred": preds[0] if len(preds) == 1 else list(preds)}


def _report(score, values: Mapping[str, Any], echo: Echo) -> None:
    echo(f"{score.n_frames:,} image{'s' if score.n_frames != 1 else ''}; the threshold of the highest lane-line F "
         "is chosen on the test set, as Gen-LaneNet's evaluator chooses it")
    for method in score.methods:
        threshold = score.value(method, "threshold")
        echo(f"{method} (threshold {threshold:.2f}):" if len(score.methods) > 1 else f"threshold {threshold:.2f}:")
        for line in score.printed[method]:
            echo(f"  {line}")


COMMAND = ScoreCommand(
    "apollo3d",
    """Official Apollo 3D Synthetic AP, F, and x/z errors near and far for lane lines and centre lines, as
    Gen-LaneNet's evaluator (tools/eval_3D_lane.py) computes them.""",
    options=(
        Option("--labels", "A split's label file (test.json: JSON lines of raw_file, laneLines, "
                           "laneLines_visibility, centerLines, centerLines_visibility).", kind="path", required=True),
        Option("--pred", "Predictions, JSON lines of raw_file, laneLines, laneLines_prob, centerLines, "
                         "centerLines_prob (ground coordinates, metres). One method, named by the file's stem or "
                         "NAME. Repeatable: every method against one reading of the labels.",
               name="preds", required=True, multiple=True, metavar="FILE|NAME=FILE"),
        WORKERS,
        out("Folder for official.csv, sweep.csv and summary.md."),
        Sharding("clips"),
        quiet(),
    ),
    positional=("labels", "pred"),
    prepare=_one_or_several,
    report=_report,
    keeps_collections=True,
)
