"""What a benchmark (or map format) of another package builds on: the names this module exports
are kept stable for them, as `tests/toy_benchmark/toy_lanes.py`, written as a third party's
package would be, uses them (README "Your own benchmark"). Loaded on first use.

- the protocol and its pieces: `Benchmark`, `LaneFile`, `CategoryPanel`, `OfficialRecord`,
  `OfficialTally`; the data: `Lane`, `Frame`, `Clip`, `Dataset`, and `Prediction` (what `score`
  is handed: one method's lanes of a frame); errors: `InputError`, `ConfigError`;
- lane files: `read_lines_txt`, `format_lines_txt`, `parse_lines_txt` (CULane's `.lines.txt`),
  `LinesPerFrame` and `JsonLinesFile` (a detector's files read back by `run --maps-format lanes`),
  `MapFormat` (a maps format of its own);
- synthetic sets: `SynthResult`, `Camera`, `Scene` (what `scene_sequence` gives, frame by frame),
  `scene_sequence`, `clip_style`, `channel_lanes`, `render_maps`, `write_maps`;
- compare's tables: `Grid`, `Column`, `Stat`, `Text`, `EMPTY`, `all_found`, `method_name`,
  `ordered_methods`;
- its `score NAME` command, declared as data: `ScoreCommand`, `Option`, `command_of` (the click
  command of a declaration);
- its tests: `check_benchmark(name, folder)` (the contract every registered benchmark keeps,
  roneld_eval.contract), raising `ContractBroken`.
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

_EXPORTS = {
    "Benchmark": "benchmarks", "LaneFile": "benchmarks", "CategoryPanel": "benchmarks",
    "OfficialRecord": "benchmarks", "OfficialTally": "benchmarks",
    "Lane": "model", "Frame": "model", "Clip": "model", "Dataset": "model", "Prediction": "extract.protocol",
    "InputError": "errors", "ConfigError": "errors",
    "read_lines_txt": "lanes_io", "format_lines_txt": "lanes_io", "parse_lines_txt": "lanes_io",
    "LinesPerFrame": "maps.lanes", "JsonLinesFile": "maps.lanes", "MapFormat": "maps.formats",
    "SynthResult": "synth", "Camera": "synth", "Scene": "synth", "scene_sequence": "synth", "clip_style": "synth",
    "channel_lanes": "synth", "render_maps": "synth", "write_maps": "synth",
    "Grid": "comparison.tables", "Column": "comparison.tables", "Stat": "comparison.tables",
    "Text": "comparison.tables", "EMPTY": "comparison.tables",
    "all_found": "comparison.groups", "method_name": "comparison.groups", "ordered_methods": "comparison.groups",
    "ScoreCommand": "score_commands", "Option": "score_commands", "command_of": "score_commands",
    "check_benchmark": "contract", "ContractBroken": "contract",
}

__all__ = list(_EXPORTS)


def __getattr__(name: str) -> Any:
    module = _EXPORTS.get(name)
    if module is None:
        raise AttributeError(f"module 'roneld_eval.kit' has no attribute {name!r}")
    value = getattr(importlib.import_module(f"..{module}", __name__), name)
    globals()[name] = value
    return value


if TYPE_CHECKING:
    from .benchmarks import Benchmark, CategoryPanel, LaneFile, OfficialRecord, OfficialTally  # noqa: F401
    from .comparison.groups import all_found, method_name, ordered_methods  # noqa: F401
    from .comparison.tables import EMPTY, Column, Grid, Stat, Text  # noqa: F401
    from .contract import ContractBroken, check_benchmark  # noqa: F401
    from .errors import ConfigError, InputError  # noqa: F401
    from .extract.protocol import Prediction  # noqa: F401
    from .lanes_io import format_lines_txt, parse_lines_txt, read_lines_txt  # noqa: F401
    from .maps.formats import MapFormat  # noqa: F401
    from .maps.lanes import JsonLinesFile, LinesPerFrame  # noqa: F401
    from .model import Clip, Dataset, Frame, Lane  # noqa: F401
    from .score_commands import Option, ScoreCommand, command_of  # noqa: F401
    from .synth import Camera, Scene, SynthResult, channel_lanes, clip_style, render_maps, scene_sequence, write_maps  # noqa: F401
