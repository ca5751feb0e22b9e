"""`roneld-eval score openlane3d`, declared (roneld_eval.score_commands builds the command)."""

from __future__ import annotations

from typing import Any, Mapping

from ...score_commands import Echo, Option, ScoreCommand, closing_options, pred_roots


def _report(score, values: Mapping[str, Any], echo: Echo) -> None:
    from .score import summary_table

    echo(f"{score.n_frames:,} image{'s' if score.n_frames != 1 else ''}, {len(score.methods)} "
         f"method{'s' if len(score.methods) > 1 else ''}; "
         f"{score.describe()}")
    echo(summary_table(score))


COMMAND = ScoreCommand(
    "openlane3d",
    """Official OpenLane 3D F, recall, precision, category accuracy and x/z errors near and far per
    method, as OpenLane's lane3d evaluator (eval_3D_lane.py) computes them, over the list and
    each scenario list.""",
    options=(
        Option("--labels", "Ground truth as <segment>/<frame>.json (OpenLane's lane3d annotations, with each "
                           "camera's extrinsic).", kind="path", required=True),
        pred_roots("Result files <segment>/<frame>.json mirroring --labels (one method: lane_lines of xyz in "
                   "ground coordinates and category), or a folder of such folders (one method each). Repeatable. "
                   "A missing file means no lanes."),
        Option("--list", "Images to score, <segment>/<frame>.jpg a line (its test_list.txt). Default: every "
                         "annotation.", name="list_file", kind="path"),
        Option("--scenarios", "A folder of scenarios, each a folder of its annotations (lane3d_1000/test/: "
                              "up_down_case/, curve_case/, ...) or a <case>.txt image list: also every number over "
                              "each scenario's images.", kind="path"),
        Option("--protocol", "Which evaluation: 'file', the file-based one of OpenLane's lane3d and PersFormer "
                             "(every lane of each file's lane_lines), or 'persformer-train', PersFormer's "
                             "training-time one (laneLines with laneLines_prob: a lane kept when its highest class "
                             "probability is above --prob-threshold, its category the most probable).",
               choices=("file", "persformer-train"), kind="choice", default="file", show_default=True),
        Option("--prob-threshold", "With --protocol persformer-train: the probability a lane's highest class must "
                                   "exceed. Default: 0.5.", kind="float", metavar="P"),
        *closing_options("Stop when any listed image has no result file (default: no lanes).",
                         "Folder for official.csv and summary.md.", "segments"),
    ),
    positional=("labels", "pred_roots"),
    report=_report,
)
