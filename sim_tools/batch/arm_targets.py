"""``arm_targets``, the arm controller of batch sweeps, under the name sweeps have always used
(an episode's key holds it): it lives in :mod:`sim_tools.adapters.arm.targets_node`."""

from sim_tools.adapters.arm.targets_node import ArmTargetsNode, target_poses

__all__ = ["ArmTargetsNode", "target_poses"]
