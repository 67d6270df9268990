"""create_square.m's Python twin on the toolbox-style client: the same commands.

usage: python create_square.py NAMESPACE
"""

import sys

from create_sim.client import CreateRobot

with CreateRobot(namespace=sys.argv[1]) as robot:
    for _side in range(4):
        robot.travel_dist(0.25, 0.25)
        robot.turn_angle(0.2, 90)
