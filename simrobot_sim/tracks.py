"""Where :func:`draw_tracks` used to live; it is :func:`sim_runtime.track_plot.draw_tracks` now."""

from sim_runtime.track_plot import draw_tracks

__all__ = ["draw_tracks"]
