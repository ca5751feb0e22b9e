"""Scoring as it was before masks became runs per row, for benchmarks and tests only.

`drawn_masks()` makes the official and the paper's protocol draw every lane pixel by pixel
into a canvas again, one call per lane (raster.official_mask_set_by_canvas,
raster.map_mask_set_by_canvas), and count overlaps pixel by pixel, in this process and in
worker processes forked while it is active.
Results are the same bytes either way (tests/test_runs.py checks it on whole runs);
scripts/bench_run.py --compare-scoring times one against the other.
"""

from __future__ import annotations

from contextlib import contextmanager
from typing import Iterator

from .._numba_cache import compile_now
from . import _kernels, lane_iou_f1, paper, raster


@contextmanager
def drawn_masks() -> Iterator[None]:
    """Within the block, official and paper masks are drawn on canvases (the old path)."""
    for kernel, signature in _kernels.REFERENCE_SIGNATURES:  # before any timing starts
        compile_now(kernel, signature)
    saved = lane_iou_f1.official_mask_set, paper.map_mask_set
    lane_iou_f1.official_mask_set = raster.official_mask_set_by_canvas
    paper.map_mask_set = raster.map_mask_set_by_canvas
    try:
        yield
    finally:
        lane_iou_f1.official_mask_set, paper.map_mask_set = saved
