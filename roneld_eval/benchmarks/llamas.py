"""LLAMAS (Behrendt & Soussan, ICCV 2019 workshops): scored from lane files as its
culane_metric/evaluate.py scores them (`score llamas`: benchmarks/llamas_score.py)."""

from __future__ import annotations

from .lane_files_only import LaneFilesOnly


class LlamasBenchmark(LaneFilesOnly):
    name = "llamas"
    display_name = "LLAMAS"
    no_run_reason = ("running RONELD on its probability maps (<label>.json_<c>.png) is not built yet; score a "
                     "detector's lane files instead")
    frames_per_clip = 10  # what `synth` writes a clip
    command = "llamas_cli:score_llamas_command"
    image_size = (1276, 717)
    kernel_groups: tuple[str, ...] = ()
    official_columns = {"method": "text", "threshold": "text", "tp": "count", "fp": "count", "fn": "count",
                        "f1": "optional number"}
    official_optional: dict[str, str] = {}
    official_key = ("method", "threshold")


    def synthesize(self, out, clips: int, frames: int, seed: int, maps_format: str, progress):
        from ..datasets.llamas_synth import synth_llamas

        return synth_llamas(out, clips, frames, seed, progress=progress)


BENCHMARK = LlamasBenchmark()
