"""Numbers as the official C++ tools compute them: C's integer division and 32-bit wrap, OpenCV's fixed point."""

from __future__ import annotations



from ..._numba_cache import cached_njit


XY_SHIFT = 16
XY_ONE = 1 << XY_SHIFT
HALF = XY_ONE >> 1
INT_MIN = -(1 << 31)
DBL_EPSILON = 2.220446049250313e-16
SPLINE_SAMPLES = 50  # SCNN lane_evaluation: splineInterpTimes(lane, 50): samples per lane segment


# ---- numbers as C++ sees them -------------------------------------------------------------


@cached_njit(nogil=True)
def c_div(a, b):
    """C integer division (truncates toward zero; Python's // floors)."""
    q = abs(a) // abs(b)
    return q if (a >= 0) == (b >= 0) else -q


@cached_njit(nogil=True)
def to_int32(value):
    """A 64-bit integer cast to C's 32-bit int (two's complement wrap)."""
    return ((value + (1 << 31)) & 0xFFFFFFFF) - (1 << 31)
