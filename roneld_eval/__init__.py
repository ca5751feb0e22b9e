"""roneld-eval: evaluate lane extractors (the SCNN/ENet-SAD baseline and RONELD) on CULane and
TuSimple from stored CNN probability maps, with the RONELD paper's protocol and the official
CULane and TuSimple scores.

The CLI is a thin layer over these functions: `run`, `score_culane`, `score_tusimple`,
`show`, `synthesize` do what `roneld-eval run`, `score culane`, `score tusimple`, `show` and
`synth` do.
"""

__version__ = "0.1.0"

from .api import run, score_culane, score_tusimple, show, synthesize  # noqa: E402
from .config import EvalConfig  # noqa: E402
from .datasets import read_dataset  # noqa: E402
from .errors import ConfigError, InputError, RoneldEvalError  # noqa: E402
from .evaluation import evaluate  # noqa: E402
from .maps import load_maps  # noqa: E402
from .model import Clip, Dataset, Frame, FrameMaps, Lane  # noqa: E402

__all__ = [
    "run",
    "show",
    "evaluate",
    "score_culane",
    "score_tusimple",
    "synthesize",
    "EvalConfig",
    "read_dataset",
    "load_maps",
    "Lane",
    "Frame",
    "Clip",
    "Dataset",
    "FrameMaps",
    "RoneldEvalError",
    "InputError",
    "ConfigError",
    "__version__",
]
