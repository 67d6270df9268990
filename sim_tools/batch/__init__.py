"""``robot_sims batch SWEEP.yaml``: many isolated, deterministic episodes → one table and plots.

- :mod:`.sweep` reads the sweep file and expands it into episodes (no ROS imports);
- :mod:`.episode` runs one episode in the calling process (a fresh rclpy context, the world stepped
  directly, the controllers in the same executor or on the direct bus of :mod:`.bus`);
- :mod:`.metrics` holds the built-in metrics per simulator and loads the user's;
- :mod:`.engines` runs episodes on local worker processes or on Ray;
- :mod:`.output` writes the table (Parquet, CSV), the summary and the plots;
- :mod:`.cli` is the executable.
"""
