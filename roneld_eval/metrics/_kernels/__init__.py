"""Numba kernels of the metrics: exact lane rasterisation and the official CULane spline.

The official CULane evaluator draws each lane with OpenCV's `cv::line` (8-connected,
thickness 30). Its pixels decide TP/FP/FN, and OpenCV's rasteriser changed between versions
(pip's OpenCV 5 differs from the 4.6 the evaluator links here on long segments), so we do
not call OpenCV: these kernels compute the same pixels as OpenCV 4.6's 16-bit fixed-point
algorithm (a filled quad per segment, its outline, a filled disc at each vertex), in our own
code, verified against masks the official tool's spline and OpenCV 4.6 drew
(tests/golden/). Masks are drawn into canvases cropped to the lane's bounding box.
"""

from __future__ import annotations

from typing import Any

from numba import types

from . import canvas, cxx, lane_errors, lanes, matching, run_tables, runs, spline
from .cxx import (  # noqa: F401
    XY_SHIFT,
    XY_ONE,
    HALF,
    INT_MIN,
    DBL_EPSILON,
    SPLINE_SAMPLES,
    c_div,
    to_int32,
)
from .spline import (  # noqa: F401
    official_spline,
    official_spline_pixels,
    _round_float32,
)
from .canvas import (  # noqa: F401
    _span,
    disc_half_widths,
    _segment_quad,
    draw_polyline,
    short_quad_extras,
    polyline_box,
    rasterise,
    overlap,
    rasterise_with_area,
)
from .run_tables import (  # noqa: F401
    STEP_REACH,
    step_extras,
    _quad_unclipped,
    CLIP_REACH,
    clip_extras,
    _clipped_edge,
)
from .runs import (  # noqa: F401
    EMPTY_LO,
    EMPTY_HI,
    polyline_runs,
    canvas_runs,
    rasterise_runs,
    run_overlap,
)
from .lanes import (  # noqa: F401
    official_pixels,
    official_pixels_by_pow,
    official_lane,
    official_lane_runs,
    map_pixels,
    map_spline_pixels,
    map_lane,
    map_lane_runs,
    lane_set_runs,
    lane_set_ious,
)
from .matching import (  # noqa: F401
    matched_ious,
    matched_columns,
)
from .lane_errors import lane_error_counts, swept_true_positives  # noqa: F401

# Every module of kernels, for kernels.dispatchers() and the warm-up tests.
MODULES = (cxx, spline, canvas, run_tables, runs, lanes, matching, lane_errors)

# ---- the argument types raster.py calls the kernels above with ------------------------------
# Compiled ahead of a run by roneld_eval.kernels (numba compiles one specialisation per tuple
# of argument types); raster.py passes exactly these (lane points read-only, as Lane holds them).
_POINTS = types.Array(types.float64, 2, "C", readonly=True)
_TABLE = types.Array(types.int64, 3, "C")
_COUNTS = types.Array(types.int64, 1, "C")
_MASK = types.Array(types.uint8, 2, "C")
_RUNS = types.Array(types.int64, 2, "C")  # LaneMask.lo, .hi
_I, _F, _B = types.int64, types.float64, types.boolean
_TABLES = (_TABLE, _COUNTS, _TABLE, _COUNTS)  # short_quad_extras(thickness)
# step_extras(thickness, STEP_REACH) and clip_extras(thickness) (raster._step_extras)
_STEPS = (_TABLE, _COUNTS, types.Array(types.int64, 2, "C"), types.Array(types.int64, 5, "C"), _TABLE)
# raster.official_mask_set and map_mask_set (the lanes' points end to end, and where each starts)
_LANE_SET = (types.Array(types.float64, 2, "C"), _COUNTS, _B, _B, _F, _F, _F, _B, _I, _I, _I) + _STEPS
_SET_IOUS = (_RUNS, _RUNS, _RUNS, _RUNS, _RUNS, _RUNS)  # LaneRuns.ious: (meta, lo, hi) of each set

ENTRY_SIGNATURES: dict[str, list[tuple[Any, tuple]]] = {
    # raster's tables (_step_extras) and LaneMask.intersection: every protocol needs them. The
    # canvas's (short_quad_extras, raster._quad_extras) are compiled only where a lane needs the
    # canvas (LaneRuns.packed), which a real lane hardly ever does.
    "tables": [
        (step_extras, (_I, _I)),
        (clip_extras, (_I,)),
        (overlap, (_I, _I, _MASK, _I, _I, _MASK)),
        (run_overlap, (_I, _RUNS, _RUNS, _I, _RUNS, _RUNS)),
    ],
    # lane_iou_f1.official_masks (raster.official_mask_set) and LaneRuns.ious
    "official": [
        (lane_set_runs, _LANE_SET),
        (lane_set_ious, _SET_IOUS),
        (matched_ious, (types.Array(types.float64, 2, "C"), _COUNTS, _COUNTS, _F)),
    ],
    # paper.ego_masks and side_ious (raster.map_mask_set): the same kernels
    "paper": [(lane_set_runs, _LANE_SET), (lane_set_ious, _SET_IOUS)],
    # lanes drawn from integer vertices into a top view (raster.mask_from_pixels: ONCE-3DLanes' IoU)
    "topview": [(short_quad_extras, (_I,)),
                (rasterise_with_area, (types.Array(types.int64, 1, "C"), types.Array(types.int64, 1, "C"), _I, _I, _I)
                 + _TABLES)],
    # --diagnose (metrics.lane_errors): who matched whom, and the error types at every threshold
    "diagnosis": [
        (matched_columns, (types.Array(types.float64, 2, "C"), _COUNTS, _COUNTS, _F)),
        (lane_error_counts, (types.Array(types.float64, 2, "C"), _COUNTS, types.Array(types.float64, 1, "C"),
                             types.Array(types.float64, 1, "C"), _F)),
        (swept_true_positives, (types.Array(types.float64, 2, "C"), types.Array(types.float64, 1, "C"),
                                types.Array(types.float64, 1, "C"), types.Array(types.float64, 1, "C"), _B, _F)),
    ],
}
# Kernels that the entries above call, listed with the argument types their callers pass, so that
# a first run can compile them in another process beforehand (roneld_eval.kernels.STEPS): a
# caller then loads them from numba's cache instead of compiling them itself.
_LANE = types.Array(types.float64, 2, "C")  # lane_set_runs' points[starts[i]:starts[i + 1]]
_PIXELS = types.Array(types.int64, 1, "C")
CALLEE_SIGNATURES: list[tuple[Any, tuple]] = [
    (polyline_runs, (_PIXELS, _PIXELS, _I, _I, _I) + _STEPS),
    (official_pixels, (_LANE,)),
    (map_spline_pixels, (_LANE, _B, _F, _F, _F, _B)),
]
# The pixel-by-pixel references the runs are tested and benchmarked against (metrics.reference),
# and one lane at a time (raster.official_mask, map_mask: tests and benchmarks): compiled only
# where they are used, so that a first run of the tool does not pay for them.
REFERENCE_SIGNATURES: list[tuple[Any, tuple]] = [
    (official_lane, (_POINTS, _I, _I, _I) + _TABLES),
    (map_lane, (_POINTS, _B, _F, _F, _F, _B, _I, _I, _I) + _TABLES),
]
