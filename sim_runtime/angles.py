"""The one angle wrap of the project: headings and angle differences in [-pi, pi).

:func:`wrap_angle` is plain Python (a client program uses it without loading numba);
``wrap_angle_jit`` is the same function compiled for numba kernels, built on first use.
"""

from __future__ import annotations

import math
from typing import Any

_TWO_PI = 2.0 * math.pi
_THREE_PI = 3.0 * math.pi


def wrap_angle(a: float) -> float:
    """``a`` (radians) wrapped to [-pi, pi). An angle already in that range comes back unchanged,
    bit for bit (wrapping every step never drifts a heading), and one turn too far is one exact
    subtraction or addition of 2 pi; pi itself becomes -pi."""
    if -math.pi <= a < math.pi:
        return a
    if math.pi <= a < _THREE_PI:
        w = a - _TWO_PI
    elif -_THREE_PI <= a < -math.pi:
        w = a + _TWO_PI
    else:
        w = (a + math.pi) % _TWO_PI - math.pi
    # rounding may land just outside: on +pi (that is -pi here) or below -pi
    if w >= math.pi:
        w -= _TWO_PI
    elif w < -math.pi:
        w += _TWO_PI
    return w


def __getattr__(name: str) -> Any:
    # numba is imported only by the kernels that need it (see the module docstring)
    if name == "wrap_angle_jit":
        import numba

        jit = numba.njit(cache=True)(wrap_angle)
        globals()["wrap_angle_jit"] = jit
        return jit
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
