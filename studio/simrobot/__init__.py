"""SIMROBOT's windows: the simulator page and the world editor, their drawing, world drafts and ROS
client."""
