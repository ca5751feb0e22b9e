"""CurveLanes (Xu et al., ECCV 2020): scored from lane files as CondLaneNet's metric scores it
(`score curvelanes`: score.py)."""

from __future__ import annotations

from ..lane_files_only import LaneFilesOnly


class CurveLanesBenchmark(LaneFilesOnly):
    name = "curvelanes"
    display_name = "CurveLanes"
    no_run_reason = "its images come in several sizes, and RONELD's presets are for CULane- and TuSimple-sized maps"
    frames_per_clip = 1  # what `synth` writes a clip
    image_size = (2560, 1440)  # its largest; each image is scored at its own
    kernel_groups: tuple[str, ...] = ()
    official_columns = {"method": "text", "score_threshold": "text", "chosen": "text", "hits": "count",
                        "predicted": "count", "truth": "count", "f1": "optional number"}
    official_optional: dict[str, str] = {}
    official_key = ("method", "chosen")

    def scorer(self):
        """The library function behind `score curvelanes` (`roneld_eval.score("curvelanes", ...)`, and
        what merging its parts runs again on their arrays)."""
        from .score import score_curvelanes

        return score_curvelanes

    def metric(self, **options):
        """The official metric in memory (roneld_eval.metric): `score curvelanes`' options."""
        from .metric import CurveLanesMetric

        return CurveLanesMetric(**options)

    def score_command(self):
        from .cli import score_curvelanes_command

        return score_curvelanes_command

    def synthesize(self, out, clips: int, frames: int, seed: int, maps_format: str, progress):
        from .synth import synth_curvelanes

        return synth_curvelanes(out, clips, frames, seed, progress=progress)


BENCHMARK = CurveLanesBenchmark()
