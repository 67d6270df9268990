"""Create map and config file parsers: the original's formats, warnings for unknown rows, errors for bad values."""

from __future__ import annotations

import math
import warnings

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from create_sim.configfile import NoiseConfig, load_config, parse_config
from create_sim.mapfile import CreateMap, load_map, parse_map
from sim_runtime.errors import InputError
from sim_runtime.paths import config_path


def parse_quietly(text: str, parser=parse_map):
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        return parser(text, "test.map")


# ------------------------------------------------------------------------------------------ map
def test_every_map_row_type_is_read():
    world = parse_quietly(
        "wall 2.30 1.59 4.46 2.71\n"
        "line -4.612 -1 2.905 -1.95\n"
        "beacon 1.267 -1.310 [1.0 0.5 0.0] beac04\n"
        "virtwall 2.560 -3.390 -2.725 2\n"
    )
    np.testing.assert_array_equal(world.walls, [[2.30, 1.59, 4.46, 2.71]])
    np.testing.assert_array_equal(world.lines, [[-4.612, -1, 2.905, -1.95]])
    np.testing.assert_array_equal(world.beacon_xy, [[1.267, -1.310]])
    np.testing.assert_array_equal(world.beacon_rgb, [[1.0, 0.5, 0.0]])
    assert world.beacon_ids == ["beac04"]
    np.testing.assert_array_equal(world.virtwalls, [[2.560, -3.390, -2.725, 2]])


def test_comments_blank_rows_whitespace_and_keyword_case():
    world = parse_quietly(
        "% a comment row\n"
        "\n"
        "   \t \n"
        "  WALL\t0 0   1 1   % trailing comment\n"
        "\tWall 1 1 2 2\t\n"
        "LiNe 0 0 0 1%no space before the comment\n"
        "%wall 9 9 9 9\n"
    )
    np.testing.assert_array_equal(world.walls, [[0, 0, 1, 1], [1, 1, 2, 2]])
    np.testing.assert_array_equal(world.lines, [[0, 0, 0, 1]])


def test_beacon_ids_keep_their_case_and_brackets_may_be_spaced():
    world = parse_quietly("BEACON 0 0 [0 0 1] BlueOne\nbeacon 1 2 [ 1, 0.5, 0 ] b2\n")
    assert world.beacon_ids == ["BlueOne", "b2"]
    np.testing.assert_array_equal(world.beacon_rgb, [[0, 0, 1], [1, 0.5, 0]])
    np.testing.assert_array_equal(world.beacon_xy, [[0, 0], [1, 2]])


def test_empty_map_has_empty_arrays_of_the_right_shape():
    world = parse_quietly("% nothing here\n")
    assert world.walls.shape == (0, 4) and world.lines.shape == (0, 4)
    assert world.beacon_xy.shape == (0, 2) and world.beacon_rgb.shape == (0, 3)
    assert world.virtwalls.shape == (0, 4) and world.beacon_ids == []


def test_unrecognised_row_warns_with_file_and_line_and_is_skipped():
    with pytest.warns(UserWarning, match=r"rooms\.map:2: unrecognized row 'door 1 2 3 4'"):
        world = parse_map("wall 0 0 1 0\ndoor 1 2 3 4\nwall 1 0 1 1\n", "rooms.map")
    assert len(world.walls) == 2


@pytest.mark.parametrize(
    ("row", "value"),
    [
        ("wall 0 0 1", "needs 4 numbers"),
        ("wall 0 0 1 1 5", "got 5"),
        ("wall 0 0 1 NaN", "'NaN'"),
        ("line 0 inf 1 1", "'inf'"),
        ("line 0 abc 1 1", "'abc'"),
        ("virtwall 0 0 0 4", "'4'"),
        ("virtwall 0 0 0 0", "'0'"),
        ("virtwall 0 0 0 1.5", "'1.5'"),
        ("virtwall 0 0 0", "needs 4 numbers"),
        ("beacon 0 0 1 0 0 id", "x y \\[r g b\\] id"),
        ("beacon 0 0 [1 0] id", "3 values"),
        ("beacon 0 0 [1 0 2] id", "b = 2.0 is outside 0..1"),
        ("beacon 0 0 [1 0 0]", "one word"),
        ("beacon 0 0 [1 0 0] two words", "one word"),
        ("beacon x 0 [1 0 0] id", "'x'"),
        ("wall 1e300 0 -1e300 0", "wall x1: '1e300' is beyond ±1e\\+06 m"),
        ("line 0 0 0 -1000000.5", "line y2: '-1000000.5' is beyond"),
        ("beacon 2e6 0 [1 0 0] id", "beacon x: '2e6' is beyond"),
        ("virtwall 0 -1.1e6 0 1", "virtwall y: '-1.1e6' is beyond"),
    ],
)
def test_bad_value_in_a_known_row_names_file_line_and_value(row, value):
    with pytest.raises(InputError, match=rf"^rooms\.map:3: .*{value}"):
        parse_map(f"% header\nwall 0 0 1 1\n{row}\n", "rooms.map")


def test_missing_map_file_is_named(tmp_path):
    missing = tmp_path / "nope.map"
    with pytest.raises(InputError, match=r"nope\.map: map file not found"):
        load_map(missing)


def test_load_map_names_the_file_in_errors(tmp_path):
    path = tmp_path / "bad.map"
    path.write_text("wall 0 0 1 1\nwall 0 0 x 1\n")
    with pytest.raises(InputError, match=rf"^{path}:2: wall x2: 'x' is not a number"):
        load_map(path)


def test_shipped_example_map_loads_without_warnings():
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        world = load_map(config_path("create/example.map"))
    assert len(world.walls) >= 10 and len(world.lines) >= 2
    assert "Red1" in world.beacon_ids and len(world.virtwalls) == 2


# ------------------------------------------------------------------------------------------ config
def test_every_config_row_is_read_and_unlisted_sensors_are_noise_free():
    config = parse_quietly(
        "% SensorName NoiseMean NoiseStandardDev\n  odometry 0.092 0.05  % trailing\nSONAR\t0\t0.004\ncom_delay 0.1\n",
        parse_config,
    )
    assert config.noise["odometry"] == (0.092, 0.05)
    assert config.noise["sonar"] == (0.0, 0.004)
    assert config.noise["lidar"] == (0.0, 0.0)
    assert config.com_delay == 0.1


def test_default_config_is_ideal():
    config = NoiseConfig()
    assert config.com_delay == 0.0
    assert all(config.noise[name] == (0.0, 0.0) for name in ("wall", "cliff", "odometry", "sonar", "lidar", "camera"))


def test_shipped_configs_hold_the_seed_example_values_and_an_ideal_robot():
    example = load_config(config_path("create/example_config.txt"))
    assert example.noise == {
        "wall": (0.0, 0.01),
        "cliff": (3.0, 6.9),
        "odometry": (-0.02, 0.06),
        "sonar": (0.0, 0.004),
        "lidar": (0.0, 0.001),
        "camera": (0.0, 0.02),
    }
    assert example.com_delay == 0.12
    assert load_config(config_path("create/ideal_config.txt")) == NoiseConfig()


def test_imu_row_is_accepted_with_a_warning():
    with pytest.warns(UserWarning, match=r"c\.cfg:1: 'imu' noise ignored"):
        config = parse_config("imu 0.1 0.2\n", "c.cfg")
    assert "imu" not in config.noise


def test_unrecognised_config_row_warns_and_is_skipped():
    with pytest.warns(UserWarning, match=r"c\.cfg:2: unrecognized row 'gps 0 1'"):
        config = parse_config("wall 0 0.01\ngps 0 1\n", "c.cfg")
    assert config.noise["wall"] == (0.0, 0.01)


@pytest.mark.parametrize(
    ("row", "value"),
    [
        ("wall 0", "needs 2 numbers"),
        ("lidar 0 nan", "'nan'"),
        ("camera 0 -0.1", "std '-0.1' must be >= 0"),
        ("com_delay", "needs 1 number"),
        ("com_delay soon", "'soon'"),
        ("com_delay -1", "'-1' must be in 0..3600 s"),
        ("com_delay 1e300", "'1e300' must be in 0..3600 s"),
        ("camera 1e300 0", "camera noise '1e300 0' beyond ±1e\\+06"),
        ("lidar 0 2e6", "lidar noise '0 2e6' beyond"),
    ],
)
def test_bad_config_value_names_file_line_and_value(row, value):
    with pytest.raises(InputError, match=rf"^c\.cfg:2: .*{value}"):
        parse_config(f"cliff 3 6.9\n{row}\n", "c.cfg")


def test_missing_config_file_is_named(tmp_path):
    with pytest.raises(InputError, match=r"gone\.txt: config file not found"):
        load_config(tmp_path / "gone.txt")


# ------------------------------------------------------------------------------------------ properties
finite = st.floats(min_value=-1e6, max_value=1e6, allow_nan=False, allow_infinity=False)
unit = st.floats(min_value=0.0, max_value=1.0)
ids = st.text(
    alphabet=st.characters(codec="ascii", categories=("L", "N")) | st.sampled_from("_-."), min_size=1, max_size=8
)


@st.composite
def maps(draw):
    n_walls = draw(st.integers(0, 5))
    n_lines = draw(st.integers(0, 5))
    n_beacons = draw(st.integers(0, 4))
    n_virt = draw(st.integers(0, 3))
    return CreateMap(
        walls=np.array(
            draw(st.lists(st.lists(finite, min_size=4, max_size=4), min_size=n_walls, max_size=n_walls))
        ).reshape(-1, 4),
        lines=np.array(
            draw(st.lists(st.lists(finite, min_size=4, max_size=4), min_size=n_lines, max_size=n_lines))
        ).reshape(-1, 4),
        beacon_xy=np.array(
            draw(st.lists(st.lists(finite, min_size=2, max_size=2), min_size=n_beacons, max_size=n_beacons))
        ).reshape(-1, 2),
        beacon_rgb=np.array(
            draw(st.lists(st.lists(unit, min_size=3, max_size=3), min_size=n_beacons, max_size=n_beacons))
        ).reshape(-1, 3),
        beacon_ids=draw(st.lists(ids, min_size=n_beacons, max_size=n_beacons)),
        virtwalls=np.array(
            [
                [*draw(st.lists(finite, min_size=3, max_size=3)), draw(st.sampled_from([1.0, 2.0, 3.0]))]
                for _ in range(n_virt)
            ]
        ).reshape(-1, 4),
    )


def restyle(text: str, data) -> str:
    """The same file with random keyword case, whitespace, blank rows and comments."""
    rows = []
    for row in text.splitlines():
        keyword, _, rest = row.partition(" ")
        if not keyword.startswith("%"):
            keyword = "".join(c.upper() if data.draw(st.booleans()) else c for c in keyword)
        gap = data.draw(st.sampled_from([" ", "\t", "  ", " \t "]))
        lead = data.draw(st.sampled_from(["", " ", "\t"]))
        trail = data.draw(st.sampled_from(["", " ", "\t", " % note", "%x"]))
        rows.append(lead + keyword + gap + rest.replace(" ", gap) + trail)
        if data.draw(st.booleans()):
            rows.append(data.draw(st.sampled_from(["", "   ", "% comment", "\t% wall 1 2 3 4"])))
    return "\n".join(rows)


@settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(world=maps(), data=st.data())
def test_valid_maps_round_trip(world, data):
    text = restyle(world.to_text(), data)
    parsed = parse_quietly(text)
    for name in ("walls", "lines", "beacon_xy", "beacon_rgb", "virtwalls"):
        np.testing.assert_array_equal(getattr(parsed, name), getattr(world, name))
    assert parsed.beacon_ids == world.beacon_ids


@settings(max_examples=100, deadline=None)
@given(
    noise=st.fixed_dictionaries(
        {
            name: st.tuples(finite, st.floats(min_value=0.0, max_value=1e3))
            for name in ("wall", "cliff", "odometry", "sonar", "lidar", "camera")
        }
    ),
    delay=st.floats(min_value=0.0, max_value=10.0),
    data=st.data(),
)
def test_valid_configs_round_trip(noise, delay, data):
    config = NoiseConfig(noise=dict(noise), com_delay=delay)
    assert parse_quietly(restyle(config.to_text(), data), parse_config) == config


garbage_rows = st.lists(
    st.one_of(
        st.text(max_size=40),
        st.builds(
            lambda k, rest: f"{k} {rest}",
            st.sampled_from(["wall", "LINE", "beacon", "virtwall", "com_delay", "lidar", "imu", "cliff"]),
            st.text(alphabet="0123456789.-+eE[], \tnaifNI%abc", max_size=30),
        ),
    ),
    max_size=8,
)


@settings(max_examples=300, deadline=None)
@given(rows=garbage_rows)
def test_garbage_never_raises_anything_but_input_error(rows):
    text = "\n".join(rows)
    for parser in (parse_map, parse_config):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            try:
                result = parser(text, "junk.txt")
            except InputError as error:
                message = str(error)
                assert message.startswith("junk.txt:")
                continue
        if parser is parse_map:
            assert all(np.isfinite(a).all() for a in (result.walls, result.lines, result.beacon_xy, result.virtwalls))
        else:
            assert all(math.isfinite(m) and s >= 0 for m, s in result.noise.values())
