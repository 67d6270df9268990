"""Rotation conversions as numba kernels, shared by the arm's hot path and message conversion;
no ROS imports."""

from __future__ import annotations

import math

import numba
import numpy as np


@numba.njit(cache=True)
def quaternions_xyzw(frames: np.ndarray) -> np.ndarray:
    """Unit quaternions (m, 4) as x, y, z, w of the rotations of poses (m, 4, 4) (Shepperd)."""
    m = frames.shape[0]
    out = np.empty((m, 4))
    for k in range(m):
        R = frames[k]
        tr = R[0, 0] + R[1, 1] + R[2, 2]
        if tr > 0.0:
            s = 2.0 * math.sqrt(tr + 1.0)
            w, x, y, z = 0.25 * s, (R[2, 1] - R[1, 2]) / s, (R[0, 2] - R[2, 0]) / s, (R[1, 0] - R[0, 1]) / s
        elif R[0, 0] > R[1, 1] and R[0, 0] > R[2, 2]:
            s = 2.0 * math.sqrt(1.0 + R[0, 0] - R[1, 1] - R[2, 2])
            w, x, y, z = (R[2, 1] - R[1, 2]) / s, 0.25 * s, (R[0, 1] + R[1, 0]) / s, (R[0, 2] + R[2, 0]) / s
        elif R[1, 1] > R[2, 2]:
            s = 2.0 * math.sqrt(1.0 + R[1, 1] - R[0, 0] - R[2, 2])
            w, x, y, z = (R[0, 2] - R[2, 0]) / s, (R[0, 1] + R[1, 0]) / s, 0.25 * s, (R[1, 2] + R[2, 1]) / s
        else:
            s = 2.0 * math.sqrt(1.0 + R[2, 2] - R[0, 0] - R[1, 1])
            w, x, y, z = (R[1, 0] - R[0, 1]) / s, (R[0, 2] + R[2, 0]) / s, (R[1, 2] + R[2, 1]) / s, 0.25 * s
        out[k, 0] = x
        out[k, 1] = y
        out[k, 2] = z
        out[k, 3] = w
    return out
