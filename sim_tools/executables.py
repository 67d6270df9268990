"""Every executable of robot_sims, declared once: name → (``module:function``, what it does).

setup.py reads this file by path (without importing the package) to install the
``robot_sims.executables`` entry points and the ``ros2 run`` wrappers; ``robot_sims --help``
prints the descriptions. Keep this module free of imports.
"""

EXECUTABLES: dict[str, tuple[str, str]] = {
    "create_world": ("create_sim.world_node:main", "iRobot Create world: one robot, map, sensors, odometry"),
    "create_teleop": ("create_sim.teleop:main", "drive the Create from the keyboard"),
    "create_bump_turn": ("create_sim.bump_turn:main", "example Create controller: drive, back up and turn on a bump"),
    "policy_controller": (
        "sim_tools.rl.policy_controller:main",
        "a learned Create policy (a policy file of sim_tools.rl) driving a create_world",
    ),
    "simrobot_world": ("simrobot_sim.world_node:main", "SIMROBOT world: many robots on a bitmap map (world_file)"),
    "simrobot_avoid": ("simrobot_sim.avoid:main", "SIMROBOT's demo obstacle avoidance driving one robot"),
    "arm": ("arm_sim.arm_node:main", "serial arm(s) from a DH robot config: joints, trajectories, meshes"),
    "record": ("sim_runtime.bag.record:main", "record topics into an MCAP bag (rosbag2-compatible)"),
    "replay": ("sim_runtime.bag.replay:main", "play a bag back with its original timing"),
    "bag_to_rerun": ("sim_tools.rerun_view.convert:main", "convert a bag into a Rerun recording (.rrd)"),
    "draw_tracks": ("sim_tools.rerun_view.tracks:main", "draw the map and every robot's track from a bag (PNG)"),
    "urdf": ("sim_tools.urdf_cli:main", "print the URDF of an arm's robot config, or of the Create (`urdf create`)"),
    "studio": ("studio.main:main", "web app: Create simulator view and controls, map maker, config maker"),
    "batch": ("sim_tools.batch.cli:main", "run a sweep of isolated episodes (locally or on Ray): table and plots"),
    "matlab_bridge": ("sim_tools.matlab.bridge:main", "serve one Create's toolbox calls to a MATLAB/Octave program"),
    "matlab_path": ("sim_tools.matlab.paths:main", "print the folder of the m-files (the Create toolbox) for addpath"),
    "bag_to_mat": ("sim_tools.matlab.bag_to_mat:main", "write a bag as a .mat file for MATLAB/Octave (load)"),
    "classroom": ("sim_tools.classroom.cli:main", "a course server (JupyterHub) and its assignments: init, serve, ..."),
}
