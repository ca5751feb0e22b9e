"""OpenLane 3D (Chen et al., ECCV 2022, with PersFormer): 3-D lanes scored from result files as
OpenLane's lane3d evaluator scores them (`score openlane3d`: score.py, official.py)."""

from __future__ import annotations

from .. import declared_command, from_module
from ..lane_files_only import LaneFilesOnly


class OpenLane3dBenchmark(LaneFilesOnly):
    name = "openlane3d"
    display_name = "OpenLane 3D"
    no_run_reason = "its lanes are 3-D, in metres, and RONELD's maps are of the image plane"
    frames_per_clip = 4  # what `synth` writes a segment
    image_size = (1920, 1280)
    official_columns = {"method": "text", "scenario": "text", "frames": "count", "recalled": "count",
                        "precise": "count", "category_right": "count", "gt_lanes": "count", "pred_lanes": "count",
                        "matches": "count", "f": "optional number"}
    official_key = ("method", "scenario")

    # loaded from this folder when first used (benchmarks.from_module): the command, its library scorer
    # (roneld_eval.score; a merge runs it on parts' arrays), the in-memory metric's core
    score_command = declared_command(".command")
    scorer = from_module(".score", "score_openlane3d")
    synth = from_module(".synth", "synth_openlane3d", call=True)
    metric = from_module(".metric", "OpenLane3dMetric", call=True)


BENCHMARK = OpenLane3dBenchmark()
