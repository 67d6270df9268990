"""``robot_sims batch SWEEP.yaml``: many isolated, deterministic episodes → one table and plots.

Nothing here names a simulator: what each one gives a sweep (its world entries, world node,
controllers, probe, metrics, random poses) is its adapter's ``world`` part, found in the registry
(:mod:`sim_tools.adapters`; the contract: :mod:`sim_tools.adapters.contract`).

- :mod:`.sweep` reads the sweep file and expands it into the episodes of :mod:`.plan` (no ROS
  imports), after the checks of :mod:`.precheck`;
- :mod:`.episode` runs one episode in the calling process (a fresh rclpy context, the world stepped
  directly, the controllers in the same executor or on the direct bus of :mod:`.bus`);
- :mod:`.metrics` computes the simulator's built-in metrics and loads the user's;
- :mod:`.engines` runs episodes on local worker processes or on Ray;
- :mod:`.output` writes the table (Parquet, CSV), the summary and the plots;
- :mod:`.cli` is the executable.
"""
