"""OpenLane (Chen et al., ECCV 2022), its 2D lanes: scored from lane JSON files as its lane2d
evaluator scores them (`score openlane`: score.py)."""

from __future__ import annotations

from .. import declared_command, from_module
from ..lane_files_only import LaneFilesOnly


class OpenLaneBenchmark(LaneFilesOnly):
    name = "openlane"
    display_name = "OpenLane"
    no_run_reason = ("RONELD's maps and presets are for 4-lane segmentation models, and its frames carry up to "
                     "some 20 lanes of 14 categories")
    frames_per_clip = 4  # what `synth` writes a clip
    image_size = (1920, 1280)
    kernel_groups = ("official",)
    official_columns = {"method": "text", "matching": "text", "threshold": "text", "tp": "count", "fp": "count",
                        "fn": "count", "f1": "optional number"}
    official_optional: dict[str, str] = {}
    official_key = ("method", "matching", "threshold")

    # loaded from this folder when first used (benchmarks.from_module): the command, its library
    # scorer (roneld_eval.score; a merge runs it on parts' arrays), the in-memory metric's core
    score_command = declared_command(".command")
    scorer = from_module(".score", "score_openlane")
    synth = from_module(".synth", "synth_openlane", call=True)
    metric = from_module(".metric", "OpenLaneMetric", call=True)


BENCHMARK = OpenLaneBenchmark()
