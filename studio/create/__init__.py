"""The Create's windows: the simulator page, the map maker, the config maker, their drawing and
the Create's ROS client."""
