"""World files and map images: good files load, bad ones give errors naming what is wrong."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
import yaml
from PIL import Image

from sim_runtime.errors import InputError
from sim_runtime.paths import config_path
from simrobot_sim.model import SimrobotWorld
from simrobot_sim.world_file import load_bitmap, load_world


def write_map(path: Path, width: int = 200, height: int = 100, mode: str = "1") -> Path:
    img = np.full((height, width), 255, dtype=np.uint8)
    img[0, :] = img[-1, :] = img[:, 0] = img[:, -1] = 0
    img[:, 150:] = 0  # wall from x = 1.5 m
    Image.fromarray(img).convert(mode).save(path)
    return path


def write_world(tmp_path: Path, robots: list[dict] | None = None, **fields) -> Path:
    write_map(tmp_path / "map.png")
    data = {"map": "map.png", "robots": robots if robots is not None else [{"name": "a", "position": [0.5, 0.5]}]}
    data.update(fields)
    path = tmp_path / "world.yaml"
    path.write_text(yaml.safe_dump(data))
    return path


def test_shipped_demo_world_loads_with_seed_defaults():
    spec = load_world(config_path("simrobot/demo.yaml"))
    assert spec.walls.shape == (500, 500) and spec.resolution == 0.01 and spec.dt == 1.0
    assert spec.steps_limit == 300 and spec.lockstep
    assert [r.name for r in spec.robots] == ["r1", "r2", "r3", "r4"]
    r = spec.robots[0]
    assert (r.R, r.la, r.lb) == (0.01, 0.03, 0.0)
    s = r.sensors[0]
    assert (s.kind, s.position, s.range, s.rays) == ("ultrasonic", (0.05, 0.0), 0.30, 30)
    assert s.beamwidth == pytest.approx(math.radians(60))
    SimrobotWorld(spec)  # every robot is placed on free ground


def test_defaults_and_units(tmp_path):
    spec = load_world(
        write_world(
            tmp_path,
            [{"name": "a", "position": [0.5, 0.5], "heading": 90, "sensors": [{"name": "s", "type": "laser"}]}],
        )
    )
    r = spec.robots[0]
    assert r.heading == pytest.approx(math.pi / 2)  # degrees in the file, radians inside
    assert r.shape[2] == (0.04, 0.0) and r.color == (1.0, 1.0, 0.0) and r.power
    assert spec.steps_limit == math.inf and not spec.lockstep


@pytest.mark.parametrize(("value", "expected"), [(2.5, 3), (299.4, 299), (".inf", math.inf)])
def test_steps_limit_is_rounded_or_infinite(tmp_path, value, expected):
    path = write_world(tmp_path)
    path.write_text(path.read_text() + f"steps_limit: {value}\n")
    assert load_world(path).steps_limit == expected


@pytest.mark.parametrize("value", [0, -3, ".nan"])
def test_steps_limit_must_be_positive(tmp_path, value):
    path = write_world(tmp_path)
    path.write_text(path.read_text() + f"steps_limit: {value}\n")
    with pytest.raises(InputError, match="steps_limit"):
        load_world(path)


def test_greyscale_map_uses_the_documented_threshold(tmp_path):
    img = np.array([[127, 128, 0, 255]], dtype=np.uint8)
    Image.fromarray(img, mode="L").save(tmp_path / "g.png")
    assert load_bitmap(tmp_path / "g.png")[:, 0].tolist() == [True, False, True, False]


def test_one_bit_bmp_like_the_seed(tmp_path):
    walls = load_bitmap(write_map(tmp_path / "m.bmp"))
    assert walls.shape == (200, 100) and walls[150:, :].all() and not walls[1:150, 1:99].any()


def test_missing_map_image(tmp_path):
    path = write_world(tmp_path)
    (tmp_path / "map.png").unlink()
    with pytest.raises(InputError, match=r"map\.png.*not found"):
        load_world(path)


def test_unreadable_map_image(tmp_path):
    path = write_world(tmp_path)
    (tmp_path / "map.png").write_text("not an image")
    with pytest.raises(InputError, match="cannot read map image"):
        load_world(path)


def test_colour_map_image_is_refused(tmp_path):
    img = np.zeros((10, 10, 3), dtype=np.uint8)
    img[..., 0] = 255
    Image.fromarray(img, mode="RGB").save(tmp_path / "c.png")
    with pytest.raises(InputError, match="colour image"):
        load_bitmap(tmp_path / "c.png")


def test_grey_rgb_image_is_accepted(tmp_path):
    img = np.zeros((10, 10, 3), dtype=np.uint8)
    img[:, 5:] = 255
    Image.fromarray(img, mode="RGB").save(tmp_path / "g.png")
    assert load_bitmap(tmp_path / "g.png")[:5].all() and not load_bitmap(tmp_path / "g.png")[5:].any()


def test_robot_on_an_obstacle_names_it(tmp_path):
    spec = load_world(
        write_world(tmp_path, [{"name": "a", "position": [0.5, 0.5]}, {"name": "walker", "position": [1.52, 0.5]}])
    )
    with pytest.raises(InputError, match=r"robots\[1\] \('walker'\).*obstacle"):
        SimrobotWorld(spec)


def test_overlapping_robots_error_names_both(tmp_path):
    spec = load_world(
        write_world(tmp_path, [{"name": "first", "position": [0.5, 0.5]}, {"name": "second", "position": [0.52, 0.5]}])
    )
    with pytest.raises(InputError, match=r"'second'.*overlaps robot 'first'"):
        SimrobotWorld(spec)


def test_robot_outside_the_map(tmp_path):
    spec = load_world(write_world(tmp_path, [{"name": "a", "position": [5.0, 0.5]}]))
    with pytest.raises(InputError, match="does not fit inside the map"):
        SimrobotWorld(spec)


def test_duplicate_robot_names(tmp_path):
    with pytest.raises(InputError, match=r"robots\[1\]\.name: duplicate robot name 'a'"):
        load_world(write_world(tmp_path, [{"name": "a", "position": [0.5, 0.5]}, {"name": "a", "position": [1, 0.5]}]))


def test_a_sensors_ray_count_is_rays_or_the_originals_resolution(tmp_path):
    for key in ("rays", "resolution"):
        robot = {"name": "a", "position": [0.5, 0.5], "sensors": [{"name": "s", key: 12}]}
        assert load_world(write_world(tmp_path, [robot])).robots[0].sensors[0].rays == 12


@pytest.mark.parametrize(
    ("sensor", "message"),
    [
        ({"name": "s", "type": "radar"}, r"\('a'\)\.sensors\[0\]\.type: unknown sensor type 'radar'"),
        ({"name": "s", "range": 0}, r"sensors\[0\]\.range: must be > 0"),
        ({"name": "s", "range": -0.3}, r"sensors\[0\]\.range: must be > 0"),
        ({"name": "s", "resolution": 0}, r"sensors\[0\]\.resolution: .*positive integer"),
        ({"name": "s", "resolution": -5}, r"sensors\[0\]\.resolution: .*positive integer"),
        ({"name": "s", "resolution": 2.5}, r"sensors\[0\]\.resolution"),
        ({"name": "s", "rays": 0}, r"sensors\[0\]\.rays: .*positive integer"),
        ({"name": "s", "rays": 8, "resolution": 8}, r"sensors\[0\]: 'rays' and 'resolution' are the same field"),
        ({"name": "s", "range": float("nan")}, r"sensors\[0\]\.range: must be finite"),
        ({"name": "s", "beam": 3}, r"unknown field\(s\) 'beam'"),
    ],
)
def test_bad_sensors_name_robot_and_field(tmp_path, sensor, message):
    with pytest.raises(InputError, match=message):
        load_world(write_world(tmp_path, [{"name": "a", "position": [0.5, 0.5], "sensors": [sensor]}]))


@pytest.mark.parametrize(
    ("fields", "message"),
    [
        ({"resolution": 0}, "resolution: must be > 0"),
        ({"dt": -1}, "dt: must be > 0"),
        ({"map": 3}, "map: required"),
        ({"robots": []}, "at least one robot"),
    ],
)
def test_bad_world_fields(tmp_path, fields, message):
    with pytest.raises(InputError, match=message):
        load_world(write_world(tmp_path, **fields))


@pytest.mark.parametrize(
    ("robot", "message"),
    [
        ({"name": "a"}, r"\('a'\)\.position: required"),
        ({"name": "a", "position": [0.5, 0.5], "scale": 0}, r"\('a'\)\.scale: must be > 0"),
        ({"name": "a", "position": [0.5, 0.5], "R": -1}, r"\('a'\)\.R: must be > 0"),
        ({"name": "a", "position": [0.5, 0.5], "color": [2, 0, 0]}, r"\('a'\)\.color"),
        ({"name": "a", "position": [0.5, 0.5], "controller": "mystery"}, r"\('a'\)\.controller: unknown"),
        ({"name": "a", "position": [0.5, 0.5], "shape": [[0, 0], [1, 0]]}, r"\('a'\)\.shape"),
        ({"name": "1bad", "position": [0.5, 0.5]}, r"robots\[0\]\.name"),
    ],
)
def test_bad_robot_fields(tmp_path, robot, message):
    with pytest.raises(InputError, match=message):
        load_world(write_world(tmp_path, [robot]))


def test_too_many_robots_for_uint8_ids(tmp_path):
    robots = [{"name": f"r{i}", "position": [0.05 + 0.1 * (i % 14), 0.05 + 0.1 * (i // 14)]} for i in range(255)]
    spec = load_world(write_world(tmp_path, robots))
    with pytest.raises(InputError, match=r"255 robots.*uint8.*at most 254"):
        SimrobotWorld(spec)


def test_yaml_syntax_error_names_the_line(tmp_path):
    path = tmp_path / "w.yaml"
    path.write_text("map: m.png\nrobots: [\n  {name: a\n")
    with pytest.raises(InputError, match=r"w\.yaml:\d+: invalid YAML"):
        load_world(path)


def _png_header(width: int, height: int) -> bytes:
    """A 1-bit PNG announcing ``width`` x ``height`` pixels (its data a few bytes: the size is
    refused from the header, before any pixel is decoded)."""
    import struct
    import zlib

    def chunk(kind: bytes, body: bytes) -> bytes:
        return struct.pack(">I", len(body)) + kind + body + struct.pack(">I", zlib.crc32(kind + body) & 0xFFFFFFFF)

    header = struct.pack(">IIBBBBB", width, height, 1, 0, 0, 0, 0)
    data = chunk(b"IDAT", zlib.compress(b"\0" * 16))
    return b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", header) + data + chunk(b"IEND", b"")


@pytest.mark.parametrize("side", [13_000, 30_000, 200_000])
def test_a_map_image_beyond_the_documented_pixel_limit_is_refused_in_our_words(tmp_path, side):
    from simrobot_sim.world_file import MAX_MAP_PIXELS

    path = tmp_path / "huge.png"
    path.write_bytes(_png_header(side, side))
    with pytest.raises(InputError) as info:
        load_bitmap(path)
    message = str(info.value)
    assert f"the limit of {MAX_MAP_PIXELS}" in message and "docs/file_formats.md" in message
    assert "decompression bomb" not in message.lower() and len(message) < 300
    if side == 13_000:
        assert "13000 x 13000 = 169000000 pixels" in message
    assert f"{MAX_MAP_PIXELS:,}".replace(",", "") in (Path(__file__).parents[1] / "docs/file_formats.md").read_text(
        encoding="utf-8"
    ).replace(",", "").replace("_", "")


def test_a_map_image_just_under_the_pixel_limit_is_read(tmp_path):
    path = tmp_path / "wide.png"
    Image.new("1", (8000, 100), 1).save(path)
    assert load_bitmap(path).shape == (8000, 100)
