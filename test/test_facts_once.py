"""Each fact once: the Create's topic names and map colours are spelled only in ``create_sim/spec.py``,
SIMROBOT's topic and service names only in ``simrobot_sim/spec.py``.

The node, client, studio, Rerun, learning envs, bridges and fuzz adapters read them from there, so a
renamed topic or a new colour changes in one place. These tests read the source tree (not the
tests, not the docs) and name each literal that came back by file and line.
"""

from __future__ import annotations

import re
from collections.abc import Iterator
from pathlib import Path

import pytest

from create_sim import spec

ROOT = Path(__file__).resolve().parents[1]
SOURCE_DIRS = ("create_sim", "arm_sim", "simrobot_sim", "sim_tools", "studio", "sim_runtime")
SPEC = Path("create_sim/spec.py")
OTHER_FAMILIES = (
    # Their own topics share some leaves with the Create's (``odom``, ``cmd_vel``, ``scan``):
    # they are spelled in their own spec.py, and the base names no robot's topic.
    "simrobot_sim/",
    "arm_sim/",
    "sim_runtime/",
    "studio/simrobot/",
    "studio/arm/",
    "sim_tools/adapters/simrobot/",
    "sim_tools/adapters/arm/",
)
FAMILY_BLIND = ("studio/replay/",)
"""Reads the leaves every mobile family shares (``odom``) for any robot in a bag."""

# Names only the Create's topics carry: wrong anywhere outside spec.py.
CREATE_ONLY = [
    spec.OVERHEAD_POSE_TOPIC,
    spec.CAMERA_BEACONS_TOPIC,
    spec.BATTERY_TOPIC,
    spec.MAP_MARKERS_TOPIC,
]
# Names that are also frames, rate keys or noise keys (``odom``, ``scan``): wrong where a topic is
# named, that is as an argument of a call that subscribes, publishes or looks a topic up.
SHARED_LEAVES = [
    spec.CMD_VEL_TOPIC,
    spec.ODOM_TOPIC,
    spec.SCAN_TOPIC,
    spec.WALL_TOPIC,
    spec.VIRTUAL_WALL_TOPIC,
    spec.BUTTONS_TOPIC,
    spec.JOINT_STATES_TOPIC,
    spec.SET_POSE_TOPIC,
]
TOPIC_CALLS = (
    r"(create_publisher|create_subscription|create_command_subscription|create_sensor_publisher|"
    r"\bpub|\bsub|\.topic|\._msg|_detected|reading_age|resolve_topic_name|\bput)\("
)


def _literal(name: str) -> str:
    """A quoted literal of ``name``, relative or absolute (``"odom"``, ``'/odom'``); not a dict key
    (the rate and noise tables are keyed by the same words)."""
    return rf"""(?<![\w{{/])["']/?{re.escape(name)}["'](?!\s*:)"""


CREATE_ONLY_RE = re.compile("|".join(_literal(n) for n in CREATE_ONLY))
# ``cliff/<name>``, ``sonar/<name>``, ``bump/<side>`` spelled out, plain or in an f-string.
PER_SENSOR_RE = re.compile(r"""f?["']/?(bump|cliff|sonar)/""")
SHARED_IN_CALL_RE = re.compile(TOPIC_CALLS + r"[^()\n]*?(" + "|".join(_literal(n) for n in SHARED_LEAVES) + ")")
MAP_RGB = (spec.WALL_RGB, spec.LINE_RGB, spec.VIRTUAL_WALL_RGBA)
# The map's colours as hex, and the studio's own from before it read them from the spec.
COLOUR_RE = re.compile(
    "|".join(rf"""["']{re.escape(c)}["']""" for c in (*map(spec.hex_colour, MAP_RGB), "#222", "#2a4fd8", "#12a012")),
    re.IGNORECASE,
)


def _source_files() -> Iterator[Path]:
    for folder in SOURCE_DIRS:
        for path in sorted((ROOT / folder).rglob("*.py")):
            rel = path.relative_to(ROOT)
            if rel != SPEC:
                yield rel


def _hits(pattern: re.Pattern[str], *, skip: tuple[str, ...] = ()) -> list[str]:
    found = []
    for rel in _source_files():
        if rel.as_posix().startswith(skip):
            continue
        for number, line in enumerate((ROOT / rel).read_text(encoding="utf-8").splitlines(), 1):
            code = line.split("#", 1)[0] if pattern is not COLOUR_RE else line
            if pattern.search(code):
                found.append(f"{rel}:{number}: {line.strip()}")
    return found


def test_the_create_only_topic_names_are_spelled_only_in_its_spec() -> None:
    hits = _hits(CREATE_ONLY_RE, skip=OTHER_FAMILIES)
    assert not hits, "read these topic names from create_sim.spec:\n" + "\n".join(hits)


def test_the_per_sensor_topics_are_built_only_by_the_spec() -> None:
    hits = _hits(PER_SENSOR_RE, skip=OTHER_FAMILIES)
    assert not hits, "use spec.bump_topic / cliff_topic / sonar_topic:\n" + "\n".join(hits)


def test_no_create_topic_is_named_by_a_literal_where_it_is_subscribed_or_published() -> None:
    hits = _hits(SHARED_IN_CALL_RE, skip=OTHER_FAMILIES + FAMILY_BLIND)
    assert not hits, "read these topic names from create_sim.spec:\n" + "\n".join(hits)


def test_the_create_studio_draws_the_map_in_the_spec_colours() -> None:
    from studio.create import draw

    assert spec.hex_colour(spec.WALL_RGB) == draw.WALL_COLOUR
    assert spec.hex_colour(spec.LINE_RGB) == draw.LINE_COLOUR
    assert spec.hex_colour(spec.VIRTUAL_WALL_RGBA) == draw.VWALL_COLOUR
    hits = _hits(COLOUR_RE, skip=OTHER_FAMILIES)
    assert not hits, "the Create's colours live in create_sim/spec.py:\n" + "\n".join(hits)


def test_the_spec_hex_colour_is_the_rgb_of_the_markers() -> None:
    assert spec.hex_colour((0.1, 0.1, 0.1)) == "#1a1a1a"
    assert spec.hex_colour((0.0, 0.7, 0.0, 0.8)) == "#00b200"  # alpha is the SVG's business


def test_the_turn_rate_limit_is_the_wheels_spinning_in_opposite_directions() -> None:
    from create_sim import client
    from create_sim.model import CreateModel
    from sim_tools.rl import create_nav

    assert spec.MAX_TURN_RATE_RADPS == 2 * spec.MAX_WHEEL_SPEED_MPS / spec.WHEEL_BASE_M
    assert client.MAX_TURN_RATE == create_nav.MAX_W == spec.MAX_TURN_RATE_RADPS
    assert client.WHEEL_BASE == CreateModel.WHEEL_BASE == spec.WHEEL_BASE_M
    assert client.MAX_WHEEL_SPEED == CreateModel.MAX_WHEEL_SPEED == spec.MAX_WHEEL_SPEED_MPS
    assert client.CLIFF_NAMES == spec.CLIFF_NAMES
    assert CreateModel.LIDAR_BEAMS == spec.LIDAR_BEAMS


def test_the_arm_topic_names_are_spelled_only_in_the_arm_spec() -> None:
    from arm_sim import spec as arm_spec

    names = (*arm_spec.ARM_TOPICS, arm_spec.SCENE_MARKERS_TOPIC)
    pattern = re.compile("|".join(_literal(n) for n in names))
    # joint_states is also the Create's wheels' topic, read from the Create's spec there.
    hits = [h for h in _hits(pattern, skip=("arm_sim/spec.py",)) if not h.startswith("create_sim/")]
    assert not hits, "read these topic names from arm_sim.spec:\n" + "\n".join(hits)


# ------------------------------------------------------------------------------ SIMROBOT
SIMROBOT_SPEC = "simrobot_sim/spec.py"
SIMROBOT_FAMILY = ("simrobot_sim/", "studio/simrobot/", "sim_tools/adapters/simrobot/")


def _simrobot_spec():
    from simrobot_sim import spec as simrobot_spec

    return simrobot_spec


def test_the_simrobot_only_topic_and_service_names_are_spelled_only_in_its_spec() -> None:
    s = _simrobot_spec()
    # ("crashed" and "power" are also the words of a robot's state: the family test below finds them as topics)
    names = (s.WHEEL_CMD_TOPIC, s.SET_POWER_SERVICE, s.CLEAR_CRASH_SERVICE, s.ROBOT_STATES_TOPIC)
    pattern = re.compile("|".join(_literal(n) for n in names))
    hits = _hits(pattern, skip=(SIMROBOT_SPEC, *FAMILY_BLIND))  # the replay reads any family's bags by leaf
    assert not hits, "read these names from simrobot_sim.spec:\n" + "\n".join(hits)


def test_no_simrobot_robot_topic_is_spelled_out_under_a_robots_name() -> None:
    leaves = "|".join(re.escape(leaf) for leaf in _simrobot_spec().ROBOT_ENDPOINTS)
    # f"{name}/odom", f"{robot}/set_power": build them with spec.robot_topic
    pattern = re.compile(rf"""f["']\{{[^{{}}"']+\}}/({leaves})["'/]""")
    hits = _hits(pattern, skip=(SIMROBOT_SPEC,))
    assert not hits, "use simrobot_sim.spec.robot_topic and its names:\n" + "\n".join(hits)


def test_the_simrobot_family_names_no_robot_topic_by_a_literal() -> None:
    s = _simrobot_spec()
    names = (*s.ROBOT_ENDPOINTS, s.MAP_TOPIC, s.ROBOTS_TOPIC)
    literal = "(" + "|".join(_literal(n) for n in names) + ")"
    in_call = re.compile(TOPIC_CALLS + r"[^()\n]*?" + literal)
    handler_key = re.compile(r"\(" + literal + r""",\s*["'][a-z_]+/msg/""")  # (leaf, type) → drawer
    topic_tuple = re.compile(r"_topics\s*=\s*\(" + literal)
    hits = [
        h
        for pattern in (in_call, handler_key, topic_tuple)
        for h in _hits(pattern, skip=(SIMROBOT_SPEC,))
        if h.startswith(SIMROBOT_FAMILY)
    ]
    assert not hits, "read these topic names from simrobot_sim.spec:\n" + "\n".join(hits)


@pytest.mark.parametrize(
    "leaf", ["cmd_vel", "wheel_cmd", "odom", "pose", "crashed", "power", "set_power", "clear_crash"]
)
def test_a_simrobot_sensor_may_not_take_the_name_of_one_of_its_robots_topics(leaf: str) -> None:
    from sim_runtime.errors import InputError
    from sim_runtime.paths import config_path
    from simrobot_sim.world_file import parse_world

    assert leaf in _simrobot_spec().ROBOT_ENDPOINTS
    sensor = {"name": leaf, "type": "ultrasonic", "position": [0.05, 0], "axis": 0, "range": 0.3}
    world = {"map": "demo_map.png", "robots": [{"name": "r1", "position": [1.3, 1.55], "sensors": [sensor]}]}
    with pytest.raises(InputError, match="clashes with a robot topic"):
        parse_world(world, "world.yaml", config_path("simrobot/demo.yaml").parent)
