"""create_wall_follower.m's Python twin on the toolbox-style client: the same commands.

usage: python create_wall_follower.py NAMESPACE
"""

import sys
import time

from create_sim.client import CreateRobot

NOTHING = 3.0  # what the m-file reads ReadSonar's [] as
TOOLBOX_MIN = 0.17  # m: the toolbox's ReadSonar says [] this close or closer (the client: the reading)


def sonar(robot: CreateRobot, number: int) -> float:
    reading = robot.read_sonar(number)
    return NOTHING if reading is None or reading <= TOOLBOX_MIN else reading


with CreateRobot(namespace=sys.argv[1]) as robot:
    sonar(robot, 1)  # the first reading waits for the robot's messages: before tic, as serPort is
    # ready before a MATLAB program starts
    start = time.monotonic()  # tic
    while time.monotonic() - start < 5:
        right = sonar(robot, 1)
        front = sonar(robot, 2)
        if front < 0.25:
            robot.set_fwd_vel_ang_vel(0, 0.6)
        else:
            robot.set_fwd_vel_ang_vel(0.15, max(-0.8, min(0.8, -3 * (right - 0.25))))
        time.sleep(0.05)  # pause(0.05)
    robot.set_fwd_vel_ang_vel(0, 0)
