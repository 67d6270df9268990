"""``robot_sims studio``: the shell (:mod:`studio.shell`) serving every family of pages.

The entry point is the only module that knows all the families: it lists them with their pages
(once the options are checked, so a mistyped option answers before NiceGUI and rclpy load) and
hands them to the shell, which imports none and knows each only as a
:class:`~studio.shell.app.Family`.
"""

from __future__ import annotations

from typing import Any

from studio.shell.app import Family, run


def families() -> list[Family[Any]]:
    """Every family with its pages, in the order of the pages' routes."""
    from studio.arm import page as arm_page
    from studio.arm.family import ArmFamily
    from studio.create import config_page, map_page, sim_page, submit_page
    from studio.create.family import CreateFamily
    from studio.replay import page as replay_page
    from studio.replay.family import ReplayFamily
    from studio.simrobot import editor_page as simrobot_editor_page
    from studio.simrobot import page as simrobot_page
    from studio.simrobot.family import SimrobotFamily

    return [
        CreateFamily([sim_page.register, map_page.register, config_page.register, submit_page.register]),
        ArmFamily([arm_page.register]),
        ReplayFamily([replay_page.register]),
        SimrobotFamily([simrobot_page.register, simrobot_editor_page.register]),
    ]


def main(argv: list[str] | None = None) -> int:
    """Entry point ``studio``."""
    return run(argv, families)
