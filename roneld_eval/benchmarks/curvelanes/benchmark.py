"""CurveLanes (Xu et al., ECCV 2020): scored from lane files as CondLaneNet's metric scores it
(`score curvelanes`: score.py)."""

from __future__ import annotations

from .. import declared_command, from_module
from ..lane_files_only import LaneFilesOnly


class CurveLanesBenchmark(LaneFilesOnly):
    name = "curvelanes"
    display_name = "CurveLanes"
    no_run_reason = "its images come in several sizes, and RONELD's presets are for CULane- and TuSimple-sized maps"
    frames_per_clip = 1  # what `synth` writes a clip
    image_size = (2560, 1440)  # its largest; each image is scored at its own
    official_columns = {"method": "text", "score_threshold": "text", "chosen": "text", "hits": "count",
                        "predicted": "count", "truth": "count", "f1": "optional number"}
    official_key = ("method", "chosen")

    # loaded from this folder when first used (benchmarks.from_module): the command, its library
    # scorer (roneld_eval.score; a merge runs it on parts' arrays), the in-memory metric's core
    score_command = declared_command(".command")
    scorer = from_module(".score", "score_curvelanes")
    synth = from_module(".synth", "synth_curvelanes", call=True)
    metric = from_module(".metric", "CurveLanesMetric", call=True)


BENCHMARK = CurveLanesBenchmark()
