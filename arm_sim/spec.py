"""The arm world's spec: the names and rates that more than one part of the project reads.

An arm's geometry, limits and colours are in its robot config (``config/arm/*.yaml``, read by
:mod:`arm_sim.robot_config`); what is fixed here is the world node's physics rate and the names of
the topics and markers the studio and the Rerun views find the arms and the scene by.

>>> ARM_TOPICS
('joint_states', 'robot_markers', 'end_effector_pose')
>>> mesh_marker_ns("arm1")
'arm1/meshes'
"""

from __future__ import annotations

# ------------------------------------------------------------------------------ rates
PHYSICS_RATE = 100.0
"""Fixed physics rate (Hz) of the arm world; ``publish_rate`` is at most this."""
DEFAULT_PUBLISH_RATE = 50.0
"""Default ``publish_rate`` (Hz) of every arm's ``joint_states``, ``robot_markers``,
``end_effector_pose`` and ``/tf``."""

# ------------------------------------------------------------------------------ topics and markers
JOINT_STATES_TOPIC = "joint_states"
ROBOT_MARKERS_TOPIC = "robot_markers"
END_EFFECTOR_POSE_TOPIC = "end_effector_pose"
"""Per arm, under its prefix: joint positions, its meshes posed, its flange's pose."""
ARM_TOPICS = (JOINT_STATES_TOPIC, ROBOT_MARKERS_TOPIC, END_EFFECTOR_POSE_TOPIC)
"""The topics every arm publishes at ``publish_rate``."""
SCENE_MARKERS_TOPIC = "scene_markers"
"""The world's latched MarkerArray of its axes and scene objects."""
WORLD_AXES_NS = "world_axes"
"""Namespace of the world frame's axes on ``scene_markers``."""


def mesh_marker_ns(label: str) -> str:
    """Namespace of arm ``label``'s meshes on its ``robot_markers``."""
    return f"{label}/meshes"


def scene_marker_ns(name: str) -> str:
    """Namespace of scene object ``name`` on ``scene_markers``."""
    return f"scene/{name}"
