"""``robot_sims studio``: the shell (:mod:`studio.shell`) serving every family of pages.

The entry point is the only module that knows all the families: it imports their pages (once the
options are checked, so a mistyped option answers before NiceGUI and rclpy load) and hands them to
the shell, which imports none.
"""

from __future__ import annotations

from studio.shell.app import Pages, run


def pages() -> Pages:
    """The studio's ROS client (the Create's: the arm page shares its node) and every page."""
    from studio.arm import page as arm_page
    from studio.create import config_page, map_page, sim_page
    from studio.create.ros_client import CreateRos
    from studio.replay import page as replay_page
    from studio.simrobot import editor_page as simrobot_editor_page
    from studio.simrobot import page as simrobot_page

    return Pages(
        make_ros=CreateRos,
        register=[
            sim_page.register,
            map_page.register,
            config_page.register,
            arm_page.register,
            replay_page.register,
            simrobot_page.register,
            simrobot_editor_page.register,
        ],
    )


def main(argv: list[str] | None = None) -> int:
    """Entry point ``studio``."""
    return run(argv, pages)
