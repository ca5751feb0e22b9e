"""CurveLanes (Xu et al., ECCV 2020): scored from lane files as CondLaneNet's metric scores it
(`score curvelanes`: benchmarks/curvelanes_score.py). `run` is not offered: its images come in
several sizes, and RONELD's presets are for CULane- and TuSimple-sized maps."""

from __future__ import annotations

from typing import Any

from ..errors import ConfigError

_NO_RUN = "CurveLanes is scored from lane files only (`roneld-eval score curvelanes`)"


class CurveLanesBenchmark:
    name = "curvelanes"
    display_name = "CurveLanes"
    image_size = (2560, 1440)  # its largest; each image is scored at its own
    default_preset: str | None = None
    frames_per_clip = 1
    fixture: str | None = None
    kernel_groups: tuple[str, ...] = ()
    missing_maps_hint = ""
    official_columns = {"method": "text", "score_threshold": "text", "chosen": "text", "hits": "count",
                        "predicted": "count", "truth": "count", "f1": "optional number"}
    official_optional: dict[str, str] = {}
    official_key = ("method", "chosen")

    def score_command(self):
        from .curvelanes_cli import score_curvelanes_command

        return score_curvelanes_command

    def read(self, *args: Any, **kwargs: Any):
        raise ConfigError(_NO_RUN)

    def synthesize(self, *args: Any, **kwargs: Any):
        raise ConfigError(_NO_RUN)

    def __getattr__(self, name: str):
        if name.startswith("__"):
            raise AttributeError(name)
        raise ConfigError(_NO_RUN)


BENCHMARK = CurveLanesBenchmark()
