"""VIL-100 (Zhang et al., ICCV 2021): 20 test videos of 100 frames, each at its own size, scored
as MMA-Net's evaluator scores them (`score vil100`: benchmarks/vil100_score.py)."""

from __future__ import annotations

from .lane_files_only import LaneFilesOnly


class Vil100Benchmark(LaneFilesOnly):
    name = "vil100"
    display_name = "VIL-100"
    no_run_reason = "`run` and `synth` need one image size for a whole dataset, and its sequences come in eight"
    command = "vil100_cli:score_vil100_command"
    image_size = (1920, 1080)  # the largest of its sizes; each sequence is scored at its own
    frames_per_clip = 100
    kernel_groups = ("official",)
    official_columns = {"method": "text", "category": "text", "threshold": "text", "tp": "count", "fp": "count",
                        "fn": "count", "f1": "optional number", "miou": "optional number"}
    official_optional: dict[str, str] = {}
    official_key = ("method", "category", "threshold")


BENCHMARK = Vil100Benchmark()
