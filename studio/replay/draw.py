"""What the Replay page draws of a frame, as SVG and HTML (no GUI here): an occupancy grid,
marker outlines, small robots, joint gauges and the side panel."""

from __future__ import annotations

import base64
import io
import math
from html import escape

import numpy as np

from studio.replay.frames import Frame, RobotFrame, planar
from studio.shell import svg

TRACK_POINTS_DRAWN = 2000
"""A long track is drawn through this many of its points (a 10-minute run has ~8,000): the frame
sent to the browser stays ~25 kB however long the run."""
TOPICS_LISTED = 120
"""The side panel lists at most this many topics (a 200-robot SIMROBOT bag has a thousand)."""


def grid_image_svg(view: svg.View, grid) -> str:
    """A SIMROBOT OccupancyGrid as an embedded PNG placed in the view (walls black, unknown grey)."""
    from PIL import Image

    info = grid.info
    cells = np.asarray(grid.data, dtype=np.int8).reshape(info.height, info.width)
    grey = np.where(cells < 0, 200, np.where(cells >= 50, 0, 255)).astype(np.uint8)[::-1]  # row 0 = lowest y
    buf = io.BytesIO()
    Image.fromarray(grey, "L").save(buf, "PNG")
    x0, y0 = info.origin.position.x, info.origin.position.y
    left, top = view.to_px(x0, y0 + info.height * info.resolution)
    width, height = info.width * info.resolution * view.scale, info.height * info.resolution * view.scale
    return (
        f'<image x="{float(left):.1f}" y="{float(top):.1f}" width="{width:.1f}" height="{height:.1f}" '
        f'preserveAspectRatio="none" style="image-rendering:pixelated" '
        f'href="data:image/png;base64,{base64.b64encode(buf.getvalue()).decode()}"/>'
    )


def drawn_track(track: np.ndarray | None) -> np.ndarray | None:
    """The track thinned to TRACK_POINTS_DRAWN points, its first and last kept."""
    if track is None or len(track) <= TRACK_POINTS_DRAWN:
        return track
    return track[np.linspace(0, len(track) - 1, TRACK_POINTS_DRAWN).round().astype(int)]


def markers_svg(view: svg.View, markers) -> str:
    """Line and point markers (SIMROBOT's ``/robots`` outlines, a learning env's goal region) in
    their colours, on the map."""
    parts = []
    for m in markers.markers:
        if m.action != 0 or not m.points:
            continue
        x0, y0, yaw = planar(m.pose)
        local = np.array([(p.x, p.y) for p in m.points], dtype=float)
        c, s = math.cos(yaw), math.sin(yaw)
        px, py = view.to_px(x0 + c * local[:, 0] - s * local[:, 1], y0 + s * local[:, 0] + c * local[:, 1])
        pts = " ".join(f"{a:.1f},{b:.1f}" for a, b in zip(px.tolist(), py.tolist(), strict=True))
        colour = svg.rgb_hex((m.color.r, m.color.g, m.color.b))
        parts.append(f'<polyline class="outline" points="{pts}" fill="none" stroke="{colour}" stroke-width="2"/>')
    return "".join(parts)


def small_robot_svg(view: svg.View, rf: RobotFrame, radius_m: float = 0.05) -> str:
    """A SIMROBOT (or any non-Create) robot: disc, heading, name, its track; red when crashed."""
    parts = []
    track = drawn_track(rf.track)
    if track is not None and len(track) > 1:
        tx, ty = view.to_px(track[:, 0], track[:, 1])
        pts = " ".join(f"{a:.1f},{b:.1f}" for a, b in zip(tx.tolist(), ty.tolist(), strict=True))
        parts.append(f'<polyline points="{pts}" fill="none" stroke="#8e44ad" stroke-width="1.5"/>')
    if rf.pose is None:
        return "".join(parts)
    x, y, th = rf.pose
    px, py = view.to_px(x, y)
    hx, hy = view.to_px(x + radius_m * math.cos(th), y + radius_m * math.sin(th))
    r = max(radius_m * view.scale, 4.0)
    fill = "#e74c3c" if rf.crashed else "#3498db"
    parts.append(
        f'<circle cx="{px:.1f}" cy="{py:.1f}" r="{r:.1f}" fill="{fill}" fill-opacity="0.5" stroke="#000"/>'
        f'<line x1="{px:.1f}" y1="{py:.1f}" x2="{hx:.1f}" y2="{hy:.1f}" stroke="#000" stroke-width="2"/>'
        f'<text x="{px:.1f}" y="{py - r - 3:.1f}" font-size="12" text-anchor="middle">{escape(rf.robot.label)}</text>'
    )
    return "".join(parts)


def joints_svg(frame: Frame) -> str:
    """Each arm's joints as gauges in the view's corner: a bar from 0 to the angle on a ±π scale."""
    parts = []
    y = 24.0
    half = 150.0  # px for π
    for arm, joints in frame.joints.items():
        parts.append(f'<text x="10" y="{y:.0f}" font-size="14" font-weight="bold">arm {escape(arm or "/")}</text>')
        y += 10
        for name, position in joints:
            y += 22
            x0 = 120 + half
            end = x0 + half * max(-1.0, min(1.0, position / math.pi))
            parts.append(
                f'<text x="10" y="{y + 4:.0f}" font-size="12">{escape(name)}</text>'
                f'<line x1="120" y1="{y:.0f}" x2="{120 + 2 * half:.0f}" y2="{y:.0f}" stroke="#ddd" stroke-width="8"/>'
                f'<line class="joint" x1="{x0:.0f}" y1="{y:.0f}" x2="{end:.1f}" y2="{y:.0f}" stroke="#1565c0" '
                f'stroke-width="8"/><text x="{130 + 2 * half:.0f}" y="{y + 4:.0f}" font-size="12" '
                f'font-family="monospace">{position:+.3f} rad</text>'
            )
        y += 30
    return "".join(parts)


def _num(value: float | None, digits: int = 3) -> str:
    return "–" if value is None else f"{value:.{digits}f}"


def panel_html(frame: Frame) -> str:
    """The side panel: poses, arms, commands so far and every topic's latest message."""
    rows = []
    for rf in frame.robots:
        pose = rf.pose or (None, None, None)
        rows.append(
            f"<tr><td class='pr-3 text-gray-600'>{escape(rf.robot.label)} pose x, y, θ</td>"
            f"<td class='font-mono studio-replay-pose'>{_num(pose[0])} {_num(pose[1])} {_num(pose[2])}</td></tr>"
        )
        if rf.velocity is not None:
            rows.append(
                f"<tr><td class='pr-3 text-gray-600'>{escape(rf.robot.label)} v, ω</td>"
                f"<td class='font-mono'>{_num(rf.velocity[0])} {_num(rf.velocity[1])}</td></tr>"
            )
    for arm, joints in frame.joints.items():
        values = "<br>".join(f"{escape(n)} {p:.3f} rad" for n, p in joints)
        rows.append(
            f"<tr><td class='pr-3 text-gray-600'>{escape(arm or '/')} joints</td>"
            f"<td class='font-mono'>{values}</td></tr>"
        )
        if arm in frame.end_effectors:
            x, y, z = frame.end_effectors[arm][:3]
            rows.append(
                f"<tr><td class='pr-3 text-gray-600'>{escape(arm or '/')} end effector</td>"
                f"<td class='font-mono'>{x:.3f} {y:.3f} {z:.3f}</td></tr>"
            )
    commands = "".join(
        f"<tr><td class='pr-2 font-mono'>{t:.3f}</td><td class='pr-2'>{escape(topic)}</td>"
        f"<td class='font-mono'>{escape(text)}</td></tr>"
        for t, topic, text in frame.commands
    )
    latest = "".join(
        f"<tr><td class='pr-2'>{escape(topic)}</td><td class='pr-2 font-mono text-gray-500'>{age:.2f}</td>"
        f"<td class='font-mono'>{escape(text)}</td></tr>"
        for topic, age, text in frame.latest[:TOPICS_LISTED]
    )
    if len(frame.latest) > TOPICS_LISTED:
        latest += f"<tr><td colspan='3'>… and {len(frame.latest) - TOPICS_LISTED} more topics</td></tr>"
    return (
        f"<table class='text-sm'>{''.join(rows)}</table>"
        "<div class='font-bold mt-2'>Commands sent (newest first)</div>"
        f"<table class='text-sm studio-replay-commands'>{commands or '<tr><td>none yet</td></tr>'}</table>"
        "<div class='font-bold mt-2'>Messages at this instant (topic, age s, value)</div>"
        f"<table class='text-xs studio-replay-latest'>{latest}</table>"
    )
