"""The SIMROBOT editor's number fields (no GUI): each field's label with its unit, its limits, and
the sentence saying what to type when a value is outside them.

The form reads every value through :meth:`Quantity.read`, so a value the world file would refuse
(a negative *m per cell*, zero rays) is refused in the field it was typed into, with the field's
own words, before anything is saved; and what is saved is what the fields show.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

from sim_runtime.errors import InputError
from simrobot_sim.world_file import MAX_RAYS

UNLIMITED = ("", "inf", "infinity", ".inf", "∞")
"""What a field with no limit (*steps limit*) takes for "none": blank or inf, as the original's Inf."""


@dataclass(frozen=True)
class Quantity:
    """One number field: ``label`` (unit included, as the page shows it), what to type (``what``)
    and its limits (``above``: strictly greater than ``minimum``)."""

    label: str
    what: str
    minimum: float | None = None
    above: bool = False
    maximum: float | None = None
    integer: bool = False
    unbounded: bool = False  # blank or inf: no limit (math.inf)

    def problem(self, value: Any) -> str | None:
        """What is wrong with ``value`` as the field shows it (None: nothing)."""
        try:
            self.read(value)
        except InputError as err:
            return str(err).removeprefix(f"{self.label}: ")
        return None

    def read(self, value: Any) -> float:
        """The field's value; InputError saying what to type, with the unit."""
        if isinstance(value, str):
            text = value.strip().replace(",", ".")  # the original took a comma as the fraction mark too
            if self.unbounded and text.lower() in UNLIMITED:
                return math.inf
            try:
                value = float(text)
            except ValueError:
                raise self.error(f"{value.strip()!r} is not a number") from None
        if value is None:
            raise self.error("empty")
        x = float(value)
        if math.isnan(x) or (math.isinf(x) and not self.unbounded):
            raise self.error(f"{x:g} is not a finite number")
        if self.integer and math.isfinite(x) and x != round(x):
            raise self.error(f"{x:g} is not a whole number")
        if self.minimum is not None and (x <= self.minimum if self.above else x < self.minimum):
            raise self.error(f"{x:g} is {'not above' if self.above else 'below'} {self.minimum:g}")
        if self.maximum is not None and x > self.maximum:
            raise self.error(f"{x:g} is above {self.maximum:g}")
        return x

    def error(self, problem: str) -> InputError:
        return InputError(f"{self.label}: {problem}: type {self.what}")


def length(label: str, what: str) -> Quantity:
    """Any position in metres."""
    return Quantity(label, f"{what} in metres (e.g. 0.05)")


def positive_length(label: str, what: str, example: str) -> Quantity:
    return Quantity(label, f"{what} in metres, above 0 (e.g. {example})", minimum=0.0, above=True)


def angle(label: str, what: str) -> Quantity:
    return Quantity(label, f"{what} in degrees (e.g. 90)")


# the world
RESOLUTION = positive_length("m per cell", "the size of one map cell", "0.01")
DT = Quantity("dt (s)", "the simulated seconds per step, above 0 (e.g. 0.1)", minimum=0.0, above=True)
STEPS_LIMIT = Quantity(
    "steps limit",
    "the number of steps the world runs, a whole number from 1 (blank or inf: no limit)",
    minimum=1.0,
    integer=True,
    unbounded=True,
)
STEP_TIME = Quantity(
    "step time (s)", "the least wall seconds one step of a replay is shown, 0 or more (e.g. 0.1)", minimum=0.0
)
BLANK_WIDTH = Quantity("width (m)", "the new map's width in metres, 0.05 or more (e.g. 3)", minimum=0.05)
BLANK_HEIGHT = Quantity("height (m)", "the new map's height in metres, 0.05 or more (e.g. 2)", minimum=0.05)
BRUSH = Quantity("brush (m)", "the brush's diameter in metres, 0.005 or more (e.g. 0.03)", minimum=0.005)

# a robot
X = length("x (m)", "the robot's x")
Y = length("y (m)", "the robot's y")
HEADING = angle("heading (°)", "the robot's heading (0 = east, counter-clockwise)")
SCALE = Quantity("scale", "a factor above 0 for the robot's size (1 = its shape as given)", minimum=0.0, above=True)
WHEEL_RADIUS = positive_length("wheel radius (m)", "the wheels' radius", "0.01")
HALF_TRACK = positive_length("half track (m)", "half the distance between the wheels", "0.03")
AXLE_OFFSET = length("axle offset (m)", "the pivot's distance from the wheel axle")
ROBOT_FIELDS = (X, Y, HEADING, SCALE, WHEEL_RADIUS, HALF_TRACK, AXLE_OFFSET)

# a sensor
SENSOR_X = length("x (m)", "the sensor's x on the robot (forward)")
SENSOR_Y = length("y (m)", "the sensor's y on the robot (left)")
AXIS = angle("axis (°)", "the sensor's direction from the robot's heading")
BEAMWIDTH = Quantity("beamwidth (°)", "the beam's width in degrees, 0 to 360 (e.g. 60)", minimum=0.0, maximum=360.0)
RANGE = positive_length("range (m)", "how far the sensor sees", "0.3")
RAYS = Quantity(
    "rays",
    f"the number of rays, a whole number from 1 to {MAX_RAYS} (e.g. 30)",
    minimum=1,
    maximum=MAX_RAYS,
    integer=True,
)
SENSOR_FIELDS = (SENSOR_X, SENSOR_Y, AXIS, BEAMWIDTH, RANGE, RAYS)


def steps_text(steps: float) -> str:
    """A steps limit as its field shows it (blank: none)."""
    return "" if math.isinf(steps) else f"{steps:g}"
