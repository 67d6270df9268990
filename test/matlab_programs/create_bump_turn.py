"""create_bump_turn.m's Python twin on the toolbox-style client: the same commands.

usage: python create_bump_turn.py NAMESPACE
"""

import sys
import time

from create_sim.client import CreateRobot

with CreateRobot(namespace=sys.argv[1]) as robot:
    bumps = 0
    robot.bumps_wheel_drops()  # the first reading waits for the robot's messages: before tic, as
    # serPort is ready before a MATLAB program starts
    start = time.monotonic()  # tic
    while time.monotonic() - start < 30 and bumps < 2:
        bump_right, bump_left, _, _, _, bump_front = robot.bumps_wheel_drops()
        if bump_right or bump_left or bump_front:
            bumps += 1
            robot.travel_dist(0.2, -0.1)
            robot.turn_angle(0.2, 20)
        else:
            robot.set_fwd_vel_ang_vel(0.3, 0)
        time.sleep(0.05)  # pause(0.05)
    robot.set_fwd_vel_ang_vel(0, 0)
