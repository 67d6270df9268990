"""``draw_tracks BAG -o tracks.png``: the map and every robot's track from any bag.

The map is the bag's last ``/map`` (OccupancyGrid, SIMROBOT) or the walls of its ``map_markers``
(Create) rasterised; tracks are the ground-truth poses (``overhead_pose``/``pose``), or ``odom``
for a robot without them; colours are the world's outlines' (SIMROBOT). Which topics and marker
namespaces those are, the simulators' drawings say (:mod:`sim_tools.rerun_view.logger`). Drawn by
:func:`sim_runtime.track_plot.draw_tracks` (the original's "draw tracks").
"""

from __future__ import annotations

import argparse
import sys
import warnings
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from sim_runtime.bag.reader import CorruptMessage, UnknownMessageType, open_bag
from sim_runtime.errors import InputError
from sim_runtime.track_plot import draw_tracks
from sim_tools.rerun_kit.contract import Outline, outline_at
from sim_tools.rerun_kit.style import LINE_LIST, robot_color
from sim_tools.rerun_view.logger import registered_drawings

RASTER_RESOLUTION = 0.01
"""m per pixel when walls (line segments) are rasterised into an occupancy image."""
MARGIN = 0.2


@dataclass
class TrackData:
    """What a bag holds for a tracks picture, as :func:`sim_runtime.track_plot.draw_tracks` takes it:
    occupancy laid out as OccupancyGrid data (row 0 = lowest y; >= 50 or True = obstacle) or None,
    its resolution (m/cell) and origin (x, y of the lower-left corner), tracks (name → (N, 2) xy in
    ``map``) and colours (name → rgb 0–1)."""

    image: np.ndarray | None = None
    resolution: float = RASTER_RESOLUTION
    origin: tuple[float, float] = (0.0, 0.0)
    tracks: dict[str, np.ndarray] = field(default_factory=dict)
    colors: dict[str, tuple[float, float, float]] = field(default_factory=dict)


POSE_TYPE = "geometry_msgs/msg/PoseStamped"
MARKERS_TYPE = "visualization_msgs/msg/MarkerArray"


def _namespace(topic: str) -> str:
    return topic.strip("/").rpartition("/")[0] or "robot"


def _leaf(topic: str) -> str:
    return topic.rpartition("/")[2]


def tracks_from_bag(bag_path: str | Path) -> TrackData:
    """Read the map and the robots' tracks from a bag (folder or .mcap)."""
    bag = open_bag(bag_path)
    drawings = registered_drawings()
    truth_names = {t for d in drawings for t in d.truth_pose_topics}
    truth = {t for t, kind in bag.topics.items() if _leaf(t) in truth_names and kind == POSE_TYPE}
    odom = {t for t, kind in bag.topics.items() if _leaf(t) == "odom" and kind == "nav_msgs/msg/Odometry"}
    truth_robots = {_namespace(t) for t in truth}
    odom = {t for t in odom if _namespace(t) not in truth_robots}  # odometry only where no truth
    maps = {t for t, kind in bag.topics.items() if kind == "nav_msgs/msg/OccupancyGrid"}
    map_names = {t for d in drawings for t in d.map_marker_topics}
    markers = {t for t, kind in bag.topics.items() if _leaf(t) in map_names and kind == MARKERS_TYPE}
    outliners = {t: d for d in drawings for t in d.outline_topics}
    outline_topics = {
        t: outliners[_leaf(t)]
        for t, kind in bag.topics.items()
        if _leaf(t) in outliners and kind.endswith("/MarkerArray")
    }
    wall_namespaces = {n for d in drawings for n in d.wall_namespaces}
    outlines: list[Outline] = []
    match_m = 0.0

    points: dict[str, list[tuple[float, float]]] = {}
    grid = None
    walls: list[np.ndarray] = []
    for m in bag.messages(topics=truth | odom | maps | markers | set(outline_topics)):
        try:
            msg = m.msg
        except (UnknownMessageType, CorruptMessage) as err:
            warnings.warn(f"{bag.path}: {err}; skipped", stacklevel=2)
            continue
        if m.topic in outline_topics:
            if not outlines:  # the first: robots at their start
                outlines = outline_topics[m.topic].outlines(msg.markers)
                match_m = outline_topics[m.topic].outline_match_m
        elif m.topic in maps:
            grid = msg
        elif m.topic in markers:
            walls = [_marker_segments(mk) for mk in msg.markers if mk.ns in wall_namespaces and mk.type == LINE_LIST]
        else:
            pose = msg.pose.pose if m.topic in odom else msg.pose
            points.setdefault(_namespace(m.topic), []).append((pose.position.x, pose.position.y))
    return _track_data(points, outlines, match_m, grid, walls)


def _track_data(points, outlines: list[Outline], match_m: float, grid, walls: list[np.ndarray]) -> TrackData:
    names = sorted(points)
    data = TrackData(
        tracks={n: np.array(points[n], dtype=float) for n in names},
        colors={n: _color(n, names, points[n][0], outlines, match_m) for n in names},
    )
    if grid is not None:
        info = grid.info
        data.image = np.asarray(grid.data, dtype=np.int8).reshape(info.height, info.width)
        data.resolution = float(info.resolution)
        data.origin = (info.origin.position.x, info.origin.position.y)
    elif walls:
        data.image, data.origin = _rasterise(np.concatenate(walls), list(data.tracks.values()))
    return data


def _color(
    name: str, names: list[str], start: tuple[float, float], outlines: list[Outline], match_m: float
) -> tuple[float, float, float]:
    """The world's colour for the robot (its outline at its start), else the views' palette; rgb 0–1."""
    outline = outline_at(outlines, *start, match_m)
    r, g, b = outline.color if outline is not None else robot_color(name, names)
    return r / 255, g / 255, b / 255


def _marker_segments(marker) -> np.ndarray:
    pts = np.array([(p.x, p.y) for p in marker.points], dtype=float).reshape(-1, 2)
    return pts[: len(pts) // 2 * 2].reshape(-1, 2, 2)


def _rasterise(segments: np.ndarray, tracks: list[np.ndarray]) -> tuple[np.ndarray, tuple[float, float]]:
    from PIL import Image, ImageDraw

    xy = np.concatenate([segments.reshape(-1, 2), *[t for t in tracks if len(t)]])
    lo, hi = xy.min(axis=0) - MARGIN, xy.max(axis=0) + MARGIN
    w, h = (np.ceil((hi - lo) / RASTER_RESOLUTION).astype(int) + 1).tolist()
    img = Image.new("1", (w, h), 0)
    draw = ImageDraw.Draw(img)
    width = max(1, round(0.03 / RASTER_RESOLUTION))
    for (x0, y0), (x1, y1) in segments:
        # pixel (column, row) = cell (x, y) from the lower-left corner: row 0 is the lowest y
        draw.line(
            [
                ((x0 - lo[0]) / RASTER_RESOLUTION, (y0 - lo[1]) / RASTER_RESOLUTION),
                ((x1 - lo[0]) / RASTER_RESOLUTION, (y1 - lo[1]) / RASTER_RESOLUTION),
            ],
            fill=1,
            width=width,
        )
    return np.array(img, dtype=bool), (float(lo[0]), float(lo[1]))


def main(args: list[str] | None = None) -> None:
    """Entry point ``draw_tracks``."""
    parser = argparse.ArgumentParser(prog="draw_tracks", description="PNG of the map and every robot's track.")
    parser.add_argument("bag", help="bag folder or .mcap file")
    parser.add_argument("-o", "--output", default="tracks.png", help="output PNG (default tracks.png)")
    opts = parser.parse_args(args)
    try:
        data = tracks_from_bag(opts.bag)
        if not data.tracks:
            raise InputError.at(opts.bag, None, "no robot poses (overhead_pose, pose or odom) in this bag")
        draw_tracks(data.image, data.resolution, data.origin, data.tracks, data.colors, opts.output)
    except InputError as err:
        print(f"draw_tracks: error: {err}", file=sys.stderr)
        raise SystemExit(2) from err
    lengths = ", ".join(f"{n} {np.sum(np.hypot(*np.diff(t, axis=0).T)):.2f} m" for n, t in data.tracks.items())
    print(f"wrote {opts.output} ({lengths})")


if __name__ == "__main__":
    main()
