"""Lane extractors: the models' own baseline and RONELD (with and without PFT)."""

from .baseline import baseline_lanes, sample_rows
from .roneld import ActiveLanes, RoneldState, RoneldTracker, roneld_step

__all__ = ["baseline_lanes", "sample_rows", "ActiveLanes", "RoneldState", "RoneldTracker", "roneld_step"]
