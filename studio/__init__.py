"""``robot_sims studio``: the Create simulator, map maker and config maker in the browser.

A NiceGUI web app (Python only on our side). Its rclpy node is a ROS client like RViz: it talks
to ``create_world`` nodes through their topics, services and parameters, whether the studio
started them or they run in another terminal. The logic (map editing, drawing, file access) lives
in modules without NiceGUI or rclpy so it is tested without a browser.

A subpackage per family of windows (``create``, ``simrobot``, ``arm``, ``replay``) over the
``shell`` (the app and what every page shares, importing no page); :mod:`studio.main`, the entry
point, hands the pages to the shell. ``make lint`` checks that floor plan (pyproject.toml).
"""
