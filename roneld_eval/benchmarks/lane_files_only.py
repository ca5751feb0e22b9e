"""What the benchmarks scored from lane files alone (OpenLane, CurveLanes, LLAMAS) share: no `run`,
refused in one line saying how to score them instead; their `synthesize` (when they have one)
writes labels and a detector's lanes for `score NAME` (synth.SynthResult.score_command)."""

from __future__ import annotations

import importlib
from typing import Any

from ..errors import ConfigError


class LaneFilesOnly:
    """A benchmark offering `score NAME` only; a subclass names itself, its facts, the reason and
    its command ("module:function" in this package)."""

    name: str
    display_name: str
    no_run_reason: str  # why `run` is not offered, said when it is asked for
    command: str  # "vil100_cli:score_vil100_command"
    default_preset: str | None = None
    frames_per_clip = 1
    synth_maps_format = "lanes"  # `synth` writes labels and a detector's lane files
    fixture: str | None = None
    missing_maps_hint = ""

    def score_command(self):
        module, _, function = self.command.partition(":")
        return getattr(importlib.import_module(f".{module}", __package__), function)

    def _refuse(self) -> ConfigError:
        return ConfigError(f"{self.display_name} is scored from lane files only (`roneld-eval score {self.name}`): "
                           f"{self.no_run_reason}")

    def read(self, *args: Any, **kwargs: Any):
        raise self._refuse()

    def synthesize(self, *args: Any, **kwargs: Any):
        raise self._refuse()

    def __getattr__(self, name: str):
        # Every other stage of `run` (with_labels, prepare, score, tally, ...): unreachable, as
        # `read` refuses first; said the same way if a caller asks anyway.
        if name.startswith("__"):
            raise AttributeError(name)
        raise self._refuse()
