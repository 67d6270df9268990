"""Submissions that break before their first step, the ways real ones do
(``05_broken_submissions.yaml``). Each is built once when the sweep is checked, under the sweep's
time and memory limits:

- ``Unfinished``: its constructor raises (a typo in an attribute name);
- ``CrashesWhenBuilt``: segfaults while it is built (a bad C extension);
- ``WaitsForever``: waits in its constructor for a message nobody can deliver yet;
- ``HoardsWhenBuilt``: allocates 3 GB while it is built.

``students/typo_import.py`` does not even import. ``robot_sims batch`` names every one of them in
one run, or with ``--broken-as-rows`` grades each as error rows with the reason.
"""

import ctypes

import numpy as np
from rclpy.node import Node


class Unfinished(Node):
    def __init__(self, **kwargs):
        super().__init__("unfinished", **kwargs)
        self.speed = self.declare_parameter("speed", 0.2).value
        self.turn = self.sped * 2  # the student's typo


class CrashesWhenBuilt(Node):
    def __init__(self, **kwargs):
        super().__init__("crashes_when_built", **kwargs)
        ctypes.string_at(0)


class WaitsForever(Node):
    def __init__(self, **kwargs):
        super().__init__("waits_forever", **kwargs)
        self.first_scan = None
        while self.first_scan is None:  # nothing spins this node yet: it never comes
            pass


class HoardsWhenBuilt(Node):
    def __init__(self, **kwargs):
        super().__init__("hoards_when_built", **kwargs)
        self.table = [np.ones(50_000_000 // 8) for _ in range(60)]  # 3 GB
