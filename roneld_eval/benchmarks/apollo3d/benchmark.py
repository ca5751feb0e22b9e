"""Apollo 3D Synthetic (Guo et al., ECCV 2020, with Gen-LaneNet): 3-D lanes scored from prediction
files as Gen-LaneNet's evaluator scores them (`score apollo3d`: score.py, official.py)."""

from __future__ import annotations

from .. import declared_command, from_module
from ..lane_files_only import LaneFilesOnly


class Apollo3dBenchmark(LaneFilesOnly):
    name = "apollo3d"
    display_name = "Apollo 3D Synthetic"
    no_run_reason = "its lanes are 3-D, in metres, and RONELD's maps are of the image plane"
    frames_per_clip = 4  # what `synth` writes a scene
    image_size = (1920, 1080)
    official_columns = {"method": "text", "lane_type": "text", "frames": "count", "threshold": "number",
                        "recalled": "count", "precise": "count", "gt_lanes": "count", "pred_lanes": "count",
                        "matches": "count", "ap": "number", "f": "number"}
    official_key = ("method", "lane_type")

    # loaded from this folder when first used (benchmarks.from_module): the command, its library scorer
    # (roneld_eval.score; a merge runs it on parts' arrays), the in-memory metric's core
    score_command = declared_command(".command")
    scorer = from_module(".score", "score_apollo3d")
    synth = from_module(".synth", "synth_apollo3d", call=True)
    metric = from_module(".metric", "Apollo3dMetric", call=True)


BENCHMARK = Apollo3dBenchmark()
