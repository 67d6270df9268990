"""Time series (one tab per quantity, one colour per series) and the event log."""

from __future__ import annotations

import numpy as np
import rerun as rr

from sim_tools.rerun_kit.canvas import Canvas
from sim_tools.rerun_kit.ros import path_part
from sim_tools.rerun_kit.state import Series
from sim_tools.rerun_kit.style import CONSTANT_SPAN, KEEP_CONSTANT_TABS, SERIES_COLORS, TIMELINE, darker


class Plots(Canvas):
    """Plots values as series of a robot in a tab, and logs events."""

    def scalar(
        self,
        tab: str,
        robot: str,
        key: str,
        value: float,
        shade: int | None = None,
        name: str | None = None,
    ) -> None:
        """Plot ``value`` as series ``key`` (legend: ``name``, default the key) of ``robot`` in tab
        ``tab``; with a ``shade``, in the robot's world colour (0) or a darker one (1) once known."""
        entity = f"plots/{tab}/{path_part(robot)}/{path_part(key)}"
        name = name or key
        series = self._series.get(entity)
        if series is None:
            index = sum(1 for s in self._series.values() if s.tab == tab)
            color = SERIES_COLORS[index % len(SERIES_COLORS)]
            label = name if len({*self._topic_robots, robot}) <= 1 else f"{robot} {name}"
            series = self._series[entity] = Series(tab, label, color, robot, shade)
            if not self._batch:
                self._use_tab(tab)
                self._log_series_style(entity, series)
        if not self._batch:
            self._grow_tab(tab, value, value)
            self.rec.log(entity, rr.Scalars(value))
            return
        series.times.append(self._t_ns)
        series.values.append(value)

    def _log_series_style(self, entity: str, series: Series) -> None:
        robot = self._robots.get(series.robot)
        color = series.color
        if series.shade is not None and self._outlined and robot is not None and robot.color is not None:
            color = robot.color if series.shade == 0 else darker(robot.color)  # type: ignore[assignment]
        self.rec.log(entity, rr.SeriesLines(colors=[color], names=[series.name], widths=[1.5]), static=True)

    def _use_tab(self, tab: str) -> None:
        if tab not in self.plot_tabs:
            self.plot_tabs.add(tab)
            self.layout_version += 1

    def _grow_tab(self, tab: str, lo: float, hi: float) -> None:
        r = self._tab_ranges.setdefault(tab, [lo, hi])
        r[0], r[1] = min(r[0], lo), max(r[1], hi)

    def flush(self) -> None:
        """Send the plotted values kept so far (``batch_scalars``), leaving out series that never
        change; a no-op otherwise."""
        if not self._batch:
            return
        for entity, s in self._series.items():
            if not s.values:
                continue
            values = np.asarray(s.values, dtype=float)
            finite = values[np.isfinite(values)]
            if self._plotted(s, finite):
                self._send_series(entity, s, values, finite)
            s.times.clear()
            s.values.clear()

    @staticmethod
    def _plotted(s: Series, finite: np.ndarray) -> bool:
        """Whether a kept series is worth a plot: not empty, not constant, not rounding noise."""
        spread = np.abs(finite - np.median(finite)) if finite.size else finite
        # An odometry error is noise-only when nearly all of it is (a republished step can
        # pair one odometry message with the truth of the step before).
        noise = s.tab == "odom_error" and spread.size and float(np.percentile(spread, 99)) <= CONSTANT_SPAN
        constant = float(finite.max() - finite.min()) <= CONSTANT_SPAN if finite.size else True
        return not (finite.size == 0 or (constant and s.tab not in KEEP_CONSTANT_TABS) or noise)

    def _send_series(self, entity: str, s: Series, values: np.ndarray, finite: np.ndarray) -> None:
        self._use_tab(s.tab)
        self._grow_tab(s.tab, float(finite.min()), float(finite.max()))
        self._log_series_style(entity, s)
        if self._epoch:
            index = rr.TimeColumn(TIMELINE, timestamp=np.array(s.times, dtype="datetime64[ns]"))
        else:
            index = rr.TimeColumn(TIMELINE, duration=np.array(s.times, dtype="timedelta64[ns]"))
        self.rec.send_columns(entity, indexes=[index], columns=rr.Scalars.columns(scalars=values))

    def event(self, robot: str, text: str, level: rr.TextLogLevel) -> None:
        """A line in the Events log."""
        if not self.has_events:
            self.has_events = True
            self.layout_version += 1
        # The time is in the text too: the viewer's time column is too narrow to read.
        line = f"{self._t_ns / 1e9:8.2f} s  {robot}: {text}"
        self.rec.log(f"events/{path_part(robot)}", rr.TextLog(line, level=level))
