"""Draw robot tracks over an occupancy map into a PNG (matplotlib, Agg backend; no ROS): used by
SIMROBOT's demo, the `draw_tracks` executable and the studio, whichever simulator made the tracks."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path

import numpy as np


def draw_tracks(
    occupancy: np.ndarray | None,
    resolution: float,
    origin: Sequence[float] | np.ndarray,
    tracks: Mapping[str, np.ndarray],
    colors: Mapping[str, Sequence[float]],
    out_path: str | Path,
    *,
    title: str | None = None,
) -> Path:
    """Write a PNG of the map with every robot's track in its colour (the original's "Draw tracks").

    ``occupancy``: 2-D array laid out as ``nav_msgs/OccupancyGrid`` data reshaped to
    ``(height, width)`` — row 0 is the map's lowest y — where values >= 50 are obstacles, 0-49 free
    and -1 unknown (a bool array works too: True = obstacle); None draws the tracks alone.
    ``resolution`` (m/cell) and ``origin`` (x, y of the lower-left corner) place it in metres.
    ``tracks``: ``{name: (N, 2) xy in metres}``; ``colors``: ``{name: (r, g, b) in 0-1}`` (grey
    when missing). The start of each track is a circle, the end a square. Returns the path.
    """
    # a bare Figure renders with Agg and never touches pyplot's global backend
    from matplotlib.figure import Figure

    out_path = Path(out_path)
    fig = Figure(figsize=(7, 7), dpi=120)
    ax = fig.add_subplot(1, 1, 1)
    if occupancy is not None:
        occ = np.asarray(occupancy)
        if occ.dtype == np.bool_:
            shade = np.where(occ, 0.0, 1.0)
        else:
            shade = np.where(occ >= 50, 0.0, np.where(occ < 0, 0.75, 1.0))
        h, w = shade.shape
        x0, y0 = float(origin[0]), float(origin[1])
        ax.imshow(
            shade,
            cmap="gray",
            vmin=0.0,
            vmax=1.0,
            origin="lower",
            interpolation="nearest",
            extent=(x0, x0 + w * resolution, y0, y0 + h * resolution),
        )
    for name, xy in tracks.items():
        xy = np.asarray(xy, dtype=float).reshape(-1, 2)
        if len(xy) == 0:
            continue
        color = tuple(colors.get(name, (0.5, 0.5, 0.5)))
        # bright colours (yellow) vanish on white: a thin dark outline keeps them visible
        ax.plot(xy[:, 0], xy[:, 1], "-", color="black", linewidth=2.6, alpha=0.5)
        ax.plot(xy[:, 0], xy[:, 1], "-", color=color, linewidth=1.6, label=name)
        ax.plot(xy[0, 0], xy[0, 1], "o", color=color, markeredgecolor="black", markersize=6)
        ax.plot(xy[-1, 0], xy[-1, 1], "s", color=color, markeredgecolor="black", markersize=6)
    ax.set_aspect("equal")
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    if title:
        ax.set_title(title)
    if tracks and len(tracks) <= 20:
        ax.legend(loc="best", fontsize="small")
    out_path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(out_path)
    return out_path
