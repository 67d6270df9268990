"""A submission whose module does not import (``05_broken_submissions.yaml``): a typo in an import."""

import numpyy  # noqa: F401  (the student's typo: numpy)
from rclpy.node import Node


class Driver(Node):
    def __init__(self, **kwargs):
        super().__init__("driver", **kwargs)
