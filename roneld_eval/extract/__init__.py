"""Lane extractors: the models' own baseline and RONELD (with and without PFT)."""

from .baseline import baseline_lanes, sample_rows
from .roneld import ActiveLanes, RoneldState, RoneldTracker, roneld_step

__all__ = ["baseline_lanes", "sample_rows", "ActiveLanes", "RoneldState", "RoneldTracker", "roneld_step"]


def warm_up() -> None:
    """Compile (or load from numba's cache) every extraction kernel, so timings exclude it."""
    import numpy as np

    from ..config import RoneldParams
    from .roneld import RoneldTracker

    maps = np.zeros((4, 40, 60), np.uint8)
    maps[1, 5:, 20] = 200
    maps[2, 5:, 40] = 200
    from ..config import BaselineParams
    from ..geometry import MapGeometry
    from ..model import FrameMaps

    tracker = RoneldTracker(RoneldParams())
    for _ in range(2):
        tracker(maps)
    baseline_lanes(FrameMaps(maps), BaselineParams(), MapGeometry(1640, 590, 60, 40))


__all__.append("warm_up")
