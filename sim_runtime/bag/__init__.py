"""rosbag2-compatible MCAP bags.

- `reader`: `open_bag(path)` reads bag folders or single .mcap files (ours, rosbag2's,
  Foxglove's), tolerating truncated or corrupt files.
- `writer`: `BagWriter` writes bag folders (.mcap splits + metadata.yaml v9); `reindex`
  recovers a bag whose recorder was killed. `mcapfile` is its lean MCAP file writer and
  `msgdefs` builds the ``ros2msg`` schema text from the installed `.msg` files.
- `record` / `replay`: the nodes and command lines behind `robot_sims record` and
  `robot_sims replay` (usage in their module docstrings).

`reader`, `writer`, `mcapfile` and `msgdefs` do not import rclpy (message deserialisation
in `BagMessage.msg` imports it on first use).
"""
