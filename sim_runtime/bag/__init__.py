"""rosbag2-compatible MCAP bags: read (`reader`), write (`writer`), record and replay nodes.

`reader` and `writer` have no rclpy dependency at import time beyond message deserialisation
on demand; `record` and `replay` are the nodes behind `robot_sims record` and `robot_sims replay`.
"""
