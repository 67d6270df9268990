"""Numba kernels the learning environments share."""

from __future__ import annotations

import numba
import numpy as np


@numba.njit(cache=True)
def clip_into(out: np.ndarray, at: int, value: np.ndarray, lo: float, hi: float) -> int:
    """``out[at:at + n] = clip(value, lo, hi)``, n = len(value) (1-D arrays), in the value's
    precision (as ``np.clip`` then a cast), NaN kept; the index after. One kernel call: numpy's
    two ufunc calls with their scalar conversions cost twice as much on every env step."""
    for i in range(value.shape[0]):
        v = value[i]
        out[at + i] = v if v != v else min(max(v, value.dtype.type(lo)), value.dtype.type(hi))
    return at + value.shape[0]
