"""VIL-100 (Zhang et al., ICCV 2021): 20 test videos of 100 frames, each at its own size, scored
as MMA-Net's evaluator scores them (`score vil100`: benchmarks/vil100_score.py). `run` on
VIL-100 maps is not offered yet: a run's frames share one image size, and VIL-100's sequences
come in eight."""

from __future__ import annotations

from typing import Any

from ..errors import ConfigError

_NO_RUN = ("VIL-100 is scored from lane files only (`roneld-eval score vil100`): `run` and `synth` need one "
           "image size for a whole dataset, and its sequences come in eight")


class Vil100Benchmark:
    name = "vil100"
    display_name = "VIL-100"
    image_size = (1920, 1080)  # the largest of its sizes; each sequence is scored at its own
    default_preset: str | None = None  # no `run` yet
    frames_per_clip = 100
    fixture: str | None = None
    kernel_groups = ("official",)
    missing_maps_hint = ""
    official_columns = {"method": "text", "category": "text", "threshold": "text", "tp": "count", "fp": "count",
                        "fn": "count", "f1": "optional number", "miou": "optional number"}
    official_optional: dict[str, str] = {}
    official_key = ("method", "category", "threshold")

    def score_command(self):
        from .vil100_cli import score_vil100_command

        return score_vil100_command

    def read(self, *args: Any, **kwargs: Any):
        raise ConfigError(_NO_RUN)

    def synthesize(self, *args: Any, **kwargs: Any):
        raise ConfigError(_NO_RUN)

    def __getattr__(self, name: str):
        # Every other stage of `run` (with_labels, prepare, score, tally, lane_file, ...): unreachable,
        # as `read` refuses first; said the same way if a caller asks anyway.
        if name.startswith("__"):
            raise AttributeError(name)
        raise ConfigError(_NO_RUN)


BENCHMARK = Vil100Benchmark()
