"""The layout of the views: the map (top-down, then one view following each robot) or the 3-D
world; the plots in tabs; the event log; the legend."""

from __future__ import annotations

import numpy as np
import rerun as rr
import rerun.blueprint as rrb

from sim_tools.rerun_kit import legend as legend_text
from sim_tools.rerun_kit.robots import Robots
from sim_tools.rerun_kit.style import MAP, TIMELINE, TOP, WORLD

WHITE = rrb.Background(kind="SolidColor", color=[255, 255, 255])


class Layout(Robots):
    """Builds the blueprint from what has been drawn so far."""

    def blueprint(self) -> rrb.Blueprint:
        """The layout: maps (top-down, then one view following each robot) or the 3-D view;
        plots in a few tabs; the event log; the legend (logged here: it lists what is known now).

        The time cursor follows the newest data: the end of a converted bag, "now" in a live view.
        """
        tabs = self._main_views()
        plots = [self._plot_view(tab) for tab in self.tab_table if tab in self.plot_tabs]
        side: list[tuple[rrb.View | rrb.Container, int]] = []
        if plots:
            side.append((rrb.Tabs(*plots, name="Plots"), 4))
        if self.has_events:
            columns = rrb.TextLogColumns(
                timeline_columns=[rrb.encodings.TimelineColumn(TIMELINE, visible=False)],
                text_log_columns=[rrb.encodings.TextLogColumn("LogLevel"), rrb.encodings.TextLogColumn("Body")],
            )
            side.append((rrb.TextLogView(origin="/events", name="Events", columns=columns), 2))
        self.rec.log("legend", rr.TextDocument(self.legend(), media_type=rr.MediaType.MARKDOWN), static=True)
        side.append((rrb.TextDocumentView(origin="/legend", name="Legend"), 3))
        main: rrb.Container = rrb.Tabs(*tabs, active_tab=0)
        column = rrb.Vertical(*(v for v, _ in side), row_shares=[share for _, share in side])
        main = rrb.Horizontal(main, column, column_shares=[3, 2])
        return rrb.Blueprint(
            main,
            rrb.TimePanel(timeline=TIMELINE, play_state="following", state="collapsed"),
            collapse_panels=True,
        )

    def _main_views(self) -> list[rrb.View]:
        """The map and a view following each robot (half as wide as its look says), or the 3-D view."""
        if not self.planar:
            return [rrb.Spatial3DView(origin=f"/{WORLD}", name="3-D", background=WHITE, eye_controls=self._eye_3d())]
        views: list[rrb.View] = [
            rrb.Spatial2DView(
                origin=f"/{TOP}", name="Map (top-down)", background=WHITE, visual_bounds=self._map_bounds()
            )
        ]
        for r in sorted(set(self._topic_robots) | set(self._robots)):
            half = self.look_of(r).follow_half_width_m
            views.append(
                rrb.Spatial2DView(
                    origin=f"/{MAP}/robots/{r}/follow",
                    contents=f"/{TOP}/**",
                    name=f"{r} (follows)",
                    background=WHITE,
                    visual_bounds=rrb.VisualBounds2D(x_range=[-half, half], y_range=[-half, half]),
                )
            )
        return views

    def legend(self) -> str:
        """What each colour and mark of the views means, for what this world has (markdown)."""
        if not self.planar:
            return next((d.legend_3d for d in self.drawings if d.legend_3d), "")
        entries = []
        for name in sorted(set(self._topic_robots) | set(self._robots)):
            robot = self._robots.get(name)
            entries.append(legend_text.robot_entry(name, robot.color, robot.number) if robot else name)
        return legend_text.mobile(self.topics, entries, self.drawings)

    def _plot_view(self, tab: str) -> rrb.TimeSeriesView:
        _, title, y_range, _ = self.tab_table[tab]
        if y_range is None and tab in self._tab_ranges:
            lo, hi = self._tab_ranges[tab]
            pad = 0.05 * max(hi - lo, 1e-6)
            y_range = (min(lo - pad, 0.0) if lo >= 0 else lo - pad, hi + pad)
        axis_x = None
        if len(self._t_range) == 2 and self._t_range[1] > self._t_range[0] and not self._epoch:
            lo_t, hi_t = self._t_range
            axis_x = rrb.TimeAxis(
                view_range=rrb.TimeRange(
                    start=rrb.TimeRangeBoundary.absolute(nanos=lo_t), end=rrb.TimeRangeBoundary.absolute(nanos=hi_t)
                )
            )
        return rrb.TimeSeriesView(
            origin=f"/plots/{tab}",
            name=title,
            axis_y=rrb.ScalarAxis(range=y_range) if y_range is not None else None,
            axis_x=axis_x,
            plot_legend=rrb.PlotLegend(corner="LeftTop", visible=True),
        )

    def _map_bounds(self) -> rrb.VisualBounds2D | None:
        """The map and everything drawn on it, with a margin; in view coordinates (y mirrored)."""
        if not np.all(np.isfinite(self._map_lo)):
            return None
        # room for the grid's labels left and below, and for a robot's label at the right wall
        lo, hi = self._map_lo - [0.7, 0.4], self._map_hi + np.array([0.4, 0.2])
        return rrb.VisualBounds2D(x_range=[lo[0], hi[0]], y_range=[-hi[1], -lo[1]])

    def _eye_3d(self) -> rrb.EyeControls3D | None:
        """Look at the workspace from the front right and above, far enough to see all of it."""
        if not np.all(np.isfinite(self._world_lo)):
            return None
        lo, hi = self._world_lo, self._world_hi
        centre = (lo + hi) / 2
        extent = float(max(np.max(hi - lo), 0.3))
        direction = np.array([1.0, -1.3, 0.8]) / np.linalg.norm([1.0, -1.3, 0.8])
        return rrb.EyeControls3D(
            kind="Orbital",
            position=(centre + 1.9 * extent * direction).tolist(),
            look_target=centre.tolist(),
            eye_up=[0.0, 0.0, 1.0],
        )
