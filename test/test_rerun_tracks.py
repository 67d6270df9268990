"""draw_tracks from any bag: map (OccupancyGrid or rasterised Create walls) and every robot's track."""

from __future__ import annotations

import math

import numpy as np
import pytest
from PIL import Image
from rerun_test_helpers import create_messages, simrobot_messages, write_bag

from sim_tools.rerun_kit.style import ROBOT_COLORS
from sim_tools.rerun_view.tracks import main, tracks_from_bag


def test_create_bag_gives_wall_raster_and_truth_track(tmp_path):
    bag = write_bag(tmp_path / "c.mcap", create_messages(steps=50))
    data = tracks_from_bag(bag)
    assert list(data.tracks) == ["robot"]
    track = data.tracks["robot"]
    assert track.shape == (50, 2)  # overhead_pose, not odom
    assert track[-1] == pytest.approx([math.sin(0.5 * math.pi * 49 / 50), 1 - math.cos(0.5 * math.pi * 49 / 50)])
    # wall y = -2 from x = -2 to 2: the row of y = -2 is obstacle, a row 0.5 m above it is free
    img, res, (ox, oy) = data.image, data.resolution, data.origin
    row = lambda y: round((y - oy) / res)  # noqa: E731 - OccupancyGrid layout: row 0 = lowest y
    col = lambda x: round((x - ox) / res)  # noqa: E731
    assert img[row(-2.0), col(0.0)] and img[row(0.0), col(2.0)]
    assert not img[row(-1.5), col(0.0)]


def test_simrobot_bag_uses_the_occupancy_grid_as_published(tmp_path):
    bag = write_bag(tmp_path / "s.mcap", simrobot_messages())
    data = tracks_from_bag(bag)
    assert data.image.shape == (10, 20) and data.resolution == pytest.approx(0.1)
    assert data.origin == pytest.approx((-1.0, 0.0))
    assert (data.image[:, 0] == 100).all() and (data.image == 100).sum() == 10 + 9
    assert (data.image[4:7, 10:13] == 100).all()  # row 0 = lowest y, as in the message
    assert data.tracks["r1"][:, 0] == pytest.approx([0.0, 0.1, 0.2, 0.3, 0.4])


def test_draw_tracks_writes_a_png_with_the_track_colour(tmp_path, capsys):
    bag = write_bag(tmp_path / "c.mcap", create_messages(steps=50))
    out = tmp_path / "tracks.png"
    main([str(bag), "-o", str(out)])
    assert "robot 1.5" in capsys.readouterr().out  # quarter circle of radius 1: 1.57 m
    pixels = np.asarray(Image.open(out).convert("RGB")).reshape(-1, 3).astype(int)
    colour = np.array(ROBOT_COLORS[0])
    assert (np.abs(pixels - colour).sum(axis=1) < 30).sum() > 50  # the track is drawn in its colour


def test_bag_without_poses_is_a_clear_error(tmp_path, capsys):
    bag = write_bag(tmp_path / "m.mcap", simrobot_messages()[:1])
    with pytest.raises(SystemExit):
        main([str(bag), "-o", str(tmp_path / "t.png")])
    assert "no robot poses" in capsys.readouterr().err
