"""Numba kernels (and the action scaling) the learning environments share."""

from __future__ import annotations

import numba
import numpy as np
from gymnasium import spaces


@numba.njit(cache=True)
def clip_into(out: np.ndarray, at: int, value: np.ndarray, lo: float, hi: float) -> int:
    """``out[at:at + n] = clip(value, lo, hi)``, n = len(value) (1-D arrays), in the value's
    precision (as ``np.clip`` then a cast), NaN kept; the index after. One kernel call: numpy's
    two ufunc calls with their scalar conversions cost twice as much on every env step."""
    for i in range(value.shape[0]):
        v = value[i]
        out[at + i] = v if v != v else min(max(v, value.dtype.type(lo)), value.dtype.type(hi))
    return at + value.shape[0]


def normalized_box(box: spaces.Box) -> spaces.Box:
    """``[-1, 1]`` in every dimension of ``box``: the action space of an env made with
    ``normalize_actions=True`` (what Stable-Baselines3 and most learners expect)."""
    return spaces.Box(-1.0, 1.0, shape=box.shape, dtype=np.float32)


def physical_action(action: np.ndarray, low: np.ndarray, high: np.ndarray) -> np.ndarray:
    """A normalised action (``[-1, 1]``, clipped there first) mapped linearly onto ``[low, high]``:
    -1 → low, 0 → the middle, 1 → high (float64)."""
    a = np.clip(np.asarray(action, dtype=float), -1.0, 1.0)
    return low + 0.5 * (a + 1.0) * (high - low)
