"""OpenLane (Chen et al., ECCV 2022), its 2D lanes: scored from lane JSON files as its
lane2d evaluator scores them (`score openlane`: benchmarks/openlane_score.py). `run` is not
offered: RONELD's maps and presets are for 4-lane segmentation models, and OpenLane's frames
carry up to some 20 lanes of 14 categories."""

from __future__ import annotations

from typing import Any

from ..errors import ConfigError

_NO_RUN = "OpenLane is scored from lane files only (`roneld-eval score openlane`)"


class OpenLaneBenchmark:
    name = "openlane"
    display_name = "OpenLane"
    image_size = (1920, 1280)
    default_preset: str | None = None
    frames_per_clip = 1
    fixture: str | None = None
    kernel_groups = ("official",)
    missing_maps_hint = ""
    official_columns = {"method": "text", "matching": "text", "threshold": "text", "tp": "count", "fp": "count",
                        "fn": "count", "f1": "optional number"}
    official_optional: dict[str, str] = {}
    official_key = ("method", "matching", "threshold")

    def score_command(self):
        from .openlane_cli import score_openlane_command

        return score_openlane_command

    def read(self, *args: Any, **kwargs: Any):
        raise ConfigError(_NO_RUN)

    def synthesize(self, *args: Any, **kwargs: Any):
        raise ConfigError(_NO_RUN)

    def __getattr__(self, name: str):
        if name.startswith("__"):
            raise AttributeError(name)
        raise ConfigError(_NO_RUN)


BENCHMARK = OpenLaneBenchmark()
