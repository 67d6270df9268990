"""Outlines the Rerun views draw, in metres in the frame they are logged in: a sensor's beam,
the arc of its echo, a mark's cross; and cutting an outline to a box."""

from __future__ import annotations

import numpy as np


def fan(fov: float, reach: float, steps: int = 16) -> np.ndarray:
    """Outline of a beam: from the mount out to ``reach`` across ``fov`` (rad) and back."""
    return np.vstack([[0.0, 0.0], arc(fov, reach, steps), [0.0, 0.0]]).astype(np.float32)


def arc(fov: float, reach: float, steps: int = 16) -> np.ndarray:
    """The arc ``reach`` from the mount across ``fov`` (rad): where an echo can be."""
    a = np.linspace(-fov / 2, fov / 2, steps)
    return np.column_stack([reach * np.cos(a), reach * np.sin(a)]).astype(np.float32)


def cross(x: float, y: float, half: float) -> list[np.ndarray]:
    """An x at (x, y), ``half`` each way: two strokes."""
    return [
        np.array([[x - half, y - half], [x + half, y + half]]),
        np.array([[x - half, y + half], [x + half, y - half]]),
    ]


def extent(point_sets: list[np.ndarray]) -> tuple[np.ndarray, np.ndarray] | None:
    """The box around the points, if it has an area."""
    pts = np.concatenate([p.reshape(-1, 2) for p in point_sets]) if point_sets else np.zeros((0, 2))
    if not len(pts) or np.any(pts.max(axis=0) - pts.min(axis=0) <= 0):
        return None
    return pts.min(axis=0), pts.max(axis=0)


def clip_outline(pts: np.ndarray, lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
    """A closed outline (last point = first) cut to the box lo–hi (Sutherland–Hodgman); an open
    line is returned as it is."""
    if len(pts) < 4 or not np.allclose(pts[0], pts[-1]):
        return pts
    poly = [tuple(map(float, p)) for p in pts[:-1]]
    for axis, bound, sign in ((0, lo[0], 1), (0, hi[0], -1), (1, lo[1], 1), (1, hi[1], -1)):
        out: list[tuple[float, ...]] = []
        for prev, cur in zip(poly[-1:] + poly[:-1], poly, strict=True):
            if (sign * (cur[axis] - bound) >= 0) != (sign * (prev[axis] - bound) >= 0):
                t = (bound - prev[axis]) / (cur[axis] - prev[axis])
                out.append(tuple(a + t * (b - a) for a, b in zip(prev, cur, strict=True)))
            if sign * (cur[axis] - bound) >= 0:
                out.append(cur)
        poly = out
    return np.array(poly + poly[:1], dtype=np.float32).reshape(-1, 2)
