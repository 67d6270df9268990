"""The markers family: MarkerArray and Marker (top-down in a planar world, 3-D in an arm's),
meshes, and OccupancyGrid maps."""

from __future__ import annotations

import warnings

import numpy as np
import rerun as rr

from sim_runtime.msgs import yaw_from_quaternion
from sim_runtime.paths import mesh_path
from sim_tools.rerun_kit import shapes
from sim_tools.rerun_kit.robots import Robots
from sim_tools.rerun_kit.ros import basename, path_part, points, pose_transform, rgba, topic_path, yaw_transform
from sim_tools.rerun_kit.style import (
    ARROW,
    CUBE,
    CUBE_LIST,
    CYLINDER,
    DELETE,
    DELETEALL,
    LINE_LIST,
    LINE_STRIP,
    MAP,
    MESH,
    OCCUPIED,
    POINTS,
    SPHERE,
    SPHERE_LIST,
    TEXT,
    TRIANGLES,
    WORLD,
)


def _shape_2d(m, pts: np.ndarray, color, colors: list, width) -> rr.AsComponents | None:
    """A Marker's shape seen from above, in its own frame; None for meshes and triangles."""
    if m.type == TEXT:
        return rr.Points2D([[0.0, 0.0]], radii=0.0, colors=[color], labels=[m.text], show_labels=True)
    if m.type in (SPHERE, CYLINDER):
        return rr.Points2D([[0.0, 0.0]], radii=max(m.scale.x, 1e-3) / 2, colors=[color], draw_order=25)
    if m.type == LINE_STRIP:
        return rr.LineStrips2D([pts], radii=width, colors=[color])
    if m.type == LINE_LIST:
        segments = pts[: len(pts) // 2 * 2].reshape(-1, 2, 2)
        seg_colors = colors[::2] if len(colors) == len(pts) else colors
        return rr.LineStrips2D(segments, radii=width, colors=seg_colors)
    if m.type in (POINTS, SPHERE_LIST, CUBE_LIST):
        return rr.Points2D(pts, radii=max(m.scale.x, 1e-3) / 2, colors=colors)
    if m.type == CUBE:
        return rr.Boxes2D(half_sizes=[[m.scale.x / 2, m.scale.y / 2]], colors=[color])
    if m.type == ARROW:
        if len(pts) >= 2:
            return rr.Arrows2D(origins=pts[:1], vectors=pts[1:2] - pts[:1], colors=[color])
        return rr.Arrows2D(origins=[[0, 0]], vectors=[[m.scale.x, 0]], colors=[color])
    return None


def _shape_3d(m, pts: np.ndarray, color, colors: list, width: float) -> rr.AsComponents | None:
    """A Marker's shape in 3-D, in its own frame; None for a type not drawn."""
    if m.type in (SPHERE, TEXT):
        label = [m.text] if m.text and m.type == TEXT else None
        radius = m.scale.x / 2 if m.type == SPHERE else 0.01
        return rr.Points3D([[0.0, 0.0, 0.0]], radii=radius, colors=[color], labels=label, show_labels=bool(label))
    if m.type == LINE_STRIP:
        return rr.LineStrips3D([pts], radii=width / 2, colors=[color])
    if m.type == LINE_LIST:
        # per-vertex colours (an axes marker: x red, y green, z blue) colour each segment
        seg_colors = colors[::2] if len(colors) == len(pts) else colors
        return rr.LineStrips3D(pts[: len(pts) // 2 * 2].reshape(-1, 2, 3), radii=width / 2, colors=seg_colors)
    if m.type in (POINTS, SPHERE_LIST, CUBE_LIST):
        return rr.Points3D(pts, radii=width / 2, colors=colors)
    if m.type == CUBE:
        return rr.Boxes3D(half_sizes=[[m.scale.x / 2, m.scale.y / 2, m.scale.z / 2]], colors=[color], fill_mode="solid")
    if m.type == CYLINDER:
        return rr.Cylinders3D(lengths=[m.scale.z], radii=[m.scale.x / 2], colors=[color], fill_mode="solid")
    if m.type == ARROW:
        if len(pts) >= 2:
            return rr.Arrows3D(origins=pts[:1], vectors=pts[1:2] - pts[:1], radii=m.scale.x / 2, colors=[color])
        return rr.Arrows3D(origins=[[0, 0, 0]], vectors=[[m.scale.x, 0, 0]], radii=m.scale.y / 2, colors=[color])
    if m.type == TRIANGLES:
        return rr.Mesh3D(
            vertex_positions=pts, vertex_colors=colors if len(colors) == len(pts) else None, albedo_factor=color
        )
    return None


class Markers(Robots):
    """Draws visualization_msgs/MarkerArray and Marker, and nav_msgs/OccupancyGrid."""

    def _occupancy_grid(self, topic: str, msg) -> None:
        info = msg.info
        w, h = info.width, info.height
        if w * h == 0 or len(msg.data) != w * h:
            warnings.warn(f"{topic}: OccupancyGrid {w}x{h} with {len(msg.data)} cells; not drawn", stacklevel=2)
            return
        cells = np.asarray(msg.data, dtype=np.int8).reshape(h, w)
        # Row 0 is the lowest y, drawn at the bottom (the map frame is mirrored): walls dark,
        # free cells white, unknown light grey.
        wall = next((g for d in self.drawings if (g := d.grid_shade(self.topics)) is not None), OCCUPIED)
        image = np.where(cells >= 50, wall, np.where(cells < 0, 225, 255)).astype(np.uint8)
        res = info.resolution
        o = info.origin.position
        self._grow_map(np.array([[o.x, o.y], [o.x + w * res, o.y + h * res]]))
        entity = f"{MAP}/{topic_path(topic)}"
        q = info.origin.orientation
        quat = [q.x, q.y, q.z, q.w] if (q.x, q.y, q.z, q.w) != (0.0, 0.0, 0.0, 0.0) else [0.0, 0.0, 0.0, 1.0]
        self.rec.log(
            entity,
            rr.Transform3D(translation=[o.x, o.y, 0.0], quaternion=rr.Quaternion(xyzw=quat), scale=[res, res, 1.0]),
            rr.Image(image, color_model="L", draw_order=-30),
            static=True,
        )
        self._log_grid()

    def _marker_array(self, topic: str, msg) -> None:
        self._markers(topic, msg.markers)

    def _single_marker(self, topic: str, msg) -> None:
        self._markers(topic, [msg])

    def _markers(self, topic: str, markers) -> None:
        # Latched maps and scenes are static: visible at every time, even before they were published.
        leaf = basename(topic)
        static = leaf in self._static_topics
        is_map = leaf in self._map_topics
        label = leaf if is_map else f"markers/{topic_path(topic)}"
        seen: set[str] = set()
        grew = False
        if is_map:
            walls = [
                points(m.points)[:, :2] + [m.pose.position.x, m.pose.position.y]
                for m in markers
                if m.ns in self._wall_namespaces
            ]
            self._arena = shapes.extent(walls)
        for m in markers:
            if m.action == DELETEALL:
                for entity in self._marker_entities.pop(topic, set()):
                    self.rec.log(entity, rr.Clear(recursive=True))
                continue
            base = self.frame_entity(m.header.frame_id)
            entity = f"{base}/{label}/{path_part(m.ns)}/{m.id}"
            if m.action == DELETE:
                self.rec.log(entity, rr.Clear(recursive=True))
                continue
            seen.add(entity)
            if base == WORLD:
                self._marker_3d(entity, m, static)
            else:
                grew |= self._marker_2d(entity, m, static, base == MAP and is_map)
        self._after_markers(topic, markers, seen, grew, static)

    def _after_markers(self, topic: str, markers, seen: set[str], grew: bool, static: bool) -> None:
        outliner = self._outliners.get(basename(topic))
        if outliner is not None:
            self.use_outlines(outliner.outlines(markers), outliner.outline_match_m)
        if grew:
            self._log_grid()
        if not static:
            # Each message is the topic's full set (camera sightings come and go): clear the missing.
            for entity in self._marker_entities.get(topic, set()) - seen:
                self.rec.log(entity, rr.Clear(recursive=True))
            self._marker_entities[topic] = seen

    def _marker_2d(self, entity: str, m, static: bool, is_map: bool) -> bool:
        """A Marker seen from above; returns True if it grew the map's extent."""
        color = rgba(m.color)
        alpha = self._faded.get(m.ns)
        if alpha is not None:  # blended towards the white background: 2-D lines are opaque
            r, g, b = (int(round(255 - alpha * (255 - c))) for c in color[:3])
            color = (r, g, b, 255)
        pts = points(m.points)[:, :2]
        colors = [rgba(c) for c in m.colors] if len(m.colors) == len(m.points) and m.colors else [color]
        width = rr.Radius.ui_points(1.5) if alpha is not None else max(m.scale.x, 1e-3) / 2
        p = m.pose.position
        yaw = yaw_from_quaternion(m.pose.orientation)
        transform = yaw_transform(p.x, p.y, yaw)
        if alpha is not None and self._arena is not None and yaw == 0.0:  # walls block the field
            pts = shapes.clip_outline(pts, self._arena[0] - [p.x, p.y], self._arena[1] - [p.x, p.y])
        grew = False
        if is_map and static:
            before = (self._map_lo.copy(), self._map_hi.copy())
            self._grow_map(pts + np.array([p.x, p.y]) if len(pts) else np.array([[p.x, p.y]]))
            grew = not (np.array_equal(before[0], self._map_lo) and np.array_equal(before[1], self._map_hi))
        shape = _shape_2d(m, pts, color, colors, width)
        if shape is not None:  # meshes and triangles have no top-down drawing here
            self.rec.log(entity, transform, shape, static=static)
        return grew

    def _marker_3d(self, entity: str, m, static: bool) -> None:
        color = rgba(m.color)
        pts = points(m.points)
        colors = [rgba(c) for c in m.colors] if len(m.colors) == len(m.points) and m.colors else [color]
        p = m.pose.position
        self._grow_world(np.array([[p.x, p.y, p.z]]))
        if m.type == MESH:
            self._mesh(entity, m, color)
            return
        shape = _shape_3d(m, pts, color, colors, max(m.scale.x, 1e-3))
        if shape is not None:
            self.rec.log(entity, pose_transform(m.pose), shape, static=static)

    def _mesh(self, entity: str, m, color) -> None:
        uri = m.mesh_resource
        if self._static_meshes.get(entity) != uri:
            # The mesh is static: logged once per entity, later messages only move it.
            self._static_meshes[entity] = uri
            path = mesh_path(uri)  # file:// or package:// (an installed robot_sims publishes those)
            if path is None or not path.is_file():
                warnings.warn(f"marker {entity}: mesh {uri!r} is not a local file; not drawn", stacklevel=2)
            else:
                albedo = None if m.mesh_use_embedded_materials else color
                self.rec.log(entity, rr.Asset3D(path=path, albedo_factor=albedo), static=True)
        p, q = m.pose.position, m.pose.orientation
        scale = [m.scale.x or 1.0, m.scale.y or 1.0, m.scale.z or 1.0]
        self.rec.log(
            entity,
            rr.Transform3D(
                translation=[p.x, p.y, p.z], quaternion=rr.Quaternion(xyzw=[q.x, q.y, q.z, q.w]), scale=scale
            ),
        )
