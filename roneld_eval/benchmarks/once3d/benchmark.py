"""ONCE-3DLanes (Yan et al., CVPR 2022): 3-D lanes scored from prediction files as its evaluator
scores them (`score once3d`: score.py, official.py)."""

from __future__ import annotations

from .. import declared_command, from_module
from ..lane_files_only import LaneFilesOnly


class Once3dBenchmark(LaneFilesOnly):
    name = "once3d"
    display_name = "ONCE-3DLanes"
    no_run_reason = "its lanes are 3-D, in metres, and RONELD's maps are of the image plane"
    frames_per_clip = 4  # what `synth` writes a segment
    image_size = (1920, 1020)
    official_columns = {"method": "text", "threshold": "text", "score_above": "number", "gt_lanes": "count",
                        "pred_lanes": "count", "tp": "count", "f1": "optional number"}
    official_key = ("method", "threshold")

    # loaded from this folder when first used (benchmarks.from_module): the command, its library scorer
    # (roneld_eval.score; a merge runs it on parts' arrays), the in-memory metric's core
    score_command = declared_command(".command")
    scorer = from_module(".score", "score_once3d")
    synth = from_module(".synth", "synth_once3d", call=True)
    metric = from_module(".metric", "Once3dMetric", call=True)


BENCHMARK = Once3dBenchmark()
