"""What the benchmarks scored from lane files alone (OpenLane, CurveLanes, LLAMAS) share: no `run`,
refused in one line saying how to score them instead; their `synthesize` (when they have one)
writes labels and a detector's lanes for `score NAME` (synth.SynthResult.score_command)."""

from __future__ import annotations

from typing import Any

from ..errors import ConfigError


class LaneFilesOnly:
    """A benchmark offering `score NAME` only; a subclass names itself, its facts, the reason and
    its command (`score_command`)."""

    name: str
    display_name: str
    no_run_reason: str  # why `run` is not offered, said when it is asked for
    default_preset: str | None = None
    frames_per_clip = 1
    synth_maps_format = "lanes"  # `synth` writes labels and a detector's lane files
    fixture: str | None = None
    missing_maps_hint = ""
    kernel_groups: tuple[str, ...] = ()  # the numba kernels its scoring runs (none: NumPy and scipy alone)
    official_optional: dict[str, str] = {}

    def _refuse(self) -> ConfigError:
        return ConfigError(f"{self.display_name} is scored from lane files only (`roneld-eval score {self.name}`): "
                           f"{self.no_run_reason}")

    def read(self, *args: Any, **kwargs: Any):
        raise self._refuse()

    # a subclass's generator of labels and a detector's lanes, where it has one:
    # `synth = from_module(".synth", "synth_<name>", call=True)`, called (out, clips, frames, seed, progress=)
    synth: Any = None

    def synthesize(self, out, clips: int, frames: int, seed: int, maps_format: str, progress):
        if self.synth is None:
            raise self._refuse()
        return self.synth(out, clips, frames, seed, progress=progress)
