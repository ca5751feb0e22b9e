"""roneld-eval: evaluate lane detectors and extractors (the SCNN/ENet-SAD baseline, RONELD, and
any plug-in) on the lane benchmarks (CULane, TuSimple, VIL-100, OpenLane 2D and 3D, Apollo 3D
Synthetic, ONCE-3DLanes, CurveLanes, LLAMAS and any installed plug-in), with the RONELD paper's
protocol and each benchmark's official scores.

The CLI is a thin layer over these functions: `run`, `score(NAME, ...)` (`score_culane`,
`score_tusimple`: its older names), `show`, `synthesize`, `compare`, `replay_clip` do what
`roneld-eval run`, `score NAME`, `show`, `synth`, `compare` and `replay` do; `metric(name, ...)` is a
benchmark's official metric in memory, for training loops. `RoneldTracker` runs RONELD
frame by frame on a vehicle (`warm_up()` pays its one-time costs first). Names are imported
when first used, so `roneld-eval --help` stays quick.
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

from .version import __version__

# public name -> module that defines it
_EXPORTS = {
    "run": "api", "show": "api", "score": "api", "score_culane": "api", "score_tusimple": "api", "synthesize": "api",
    "compare": "comparison", "metric": "in_memory", "Metric": "in_memory", "MetricInputError": "in_memory",
    "evaluate": "api",
    "EvalConfig": "config",
    "read_dataset": "api",
    "load_maps": "maps",
    "Lane": "model", "Frame": "model", "Clip": "model", "Dataset": "model", "FrameMaps": "model",
    "Prediction": "extract.protocol", "Extractor": "extract.protocol",
    "RoneldTracker": "extract.roneld", "warm_up": "extract.online", "FrameRefused": "extract.online",
    "RoneldParams": "config", "MapGeometry": "geometry", "replay_clip": "replay",
    "RoneldEvalError": "errors", "InputError": "errors", "ConfigError": "errors",
}

__all__ = list(_EXPORTS) + ["__version__"]


def __getattr__(name: str) -> Any:
    module = _EXPORTS.get(name)
    if module is None:
        raise AttributeError(f"module 'roneld_eval' has no attribute {name!r}")
    value = getattr(importlib.import_module(f".{module}", __name__), name)
    globals()[name] = value  # later lookups skip this function
    return value


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(__all__))


if TYPE_CHECKING:  # what static checkers and editors see
    from .api import evaluate, read_dataset, run, score, score_culane, score_tusimple, show, synthesize  # noqa: F401
    from .comparison import compare  # noqa: F401
    from .config import EvalConfig, RoneldParams  # noqa: F401
    from .errors import ConfigError, InputError, RoneldEvalError  # noqa: F401
    from .extract.online import FrameRefused, warm_up  # noqa: F401
    from .extract.protocol import Extractor, Prediction  # noqa: F401
    from .extract.roneld import RoneldTracker  # noqa: F401
    from .geometry import MapGeometry  # noqa: F401
    from .in_memory import Metric, MetricInputError, metric  # noqa: F401
    from .replay import replay_clip  # noqa: F401
    from .maps import load_maps  # noqa: F401
    from .model import Clip, Dataset, Frame, FrameMaps, Lane  # noqa: F401
