"""The studio driven as a student drives it: a real Chromium (Debian's) through Selenium.

One studio process and one browser serve the whole module; the tests run in order (draw a
map, start a world on it, drive, set the pose, edit a config, record). Without Debian's
``chromium`` and ``chromium-driver`` the module is skipped with one line saying how to enable it.
``STUDIO_SCREENSHOTS=1`` also saves each page's screenshot into docs/.
"""

from __future__ import annotations

import math
import os
import pty
import signal
import socket
import subprocess
import sys
import threading
import time
from pathlib import Path

import pytest
from studio_browser_support import NO_CHROMIUM

if NO_CHROMIUM:
    pytest.skip(NO_CHROMIUM, allow_module_level=True)

import yaml
from geometry_msgs.msg import PoseStamped, Twist
from nav_msgs.msg import Odometry
from rcl_interfaces.srv import GetParameters
from selenium.webdriver.common.action_chains import ActionChains
from selenium.webdriver.common.actions.wheel_input import ScrollOrigin
from selenium.webdriver.common.by import By
from selenium.webdriver.common.keys import Keys
from studio_browser_support import (
    ROOT,
    click,
    click_text,
    find,
    free_port,
    listener_node,
    open_page,
    screenshot,
    studio_domain,
    studio_env,
    type_into,
    wait,
    what_happened,
)
from visualization_msgs.msg import MarkerArray

from create_sim.configfile import load_config
from create_sim.mapfile import load_map
from sim_runtime.msgs import yaw_from_quaternion
from sim_runtime.qos import ANY_PUBLISHER_QOS, COMMAND_PUBLISHER_QOS, LATCHED_QOS
from sim_runtime.testing import Collector, spin_until
from sim_tools.cli import executable_command

SCALE = 60.0  # the pages' initial px per metre, view centred on (0, 0)
NS = "/box"
STUDIO_DOMAIN = studio_domain(50)


@pytest.fixture(scope="module")
def workspace(tmp_path_factory) -> Path:
    return tmp_path_factory.mktemp("studio_ws")


def click_at(driver, image, x_m: float, y_m: float) -> None:
    """Click the view at world point (x, y) (the page's initial view: centre 0,0)."""
    ActionChains(driver).move_to_element_with_offset(image, round(x_m * SCALE), round(-y_m * SCALE)).click().perform()


def view_transform(driver) -> tuple[float, float, float]:
    """The simulator view's centre (m) and scale (px/m), as the page draws them."""
    values = wait(
        driver,
        lambda d: d.execute_script(
            "const g = document.querySelector('.studio-view g.view');"
            "return g && [g.dataset.centreX, g.dataset.centreY, g.dataset.scale];"
        ),
    )
    return tuple(float(v) for v in values)


@pytest.fixture(scope="module")
def listener():
    """The test's own ROS node, in the studio's domain: what the world publishes, read as any client would."""
    with listener_node(STUDIO_DOMAIN, "studio_test_listener") as (executor, node):
        odom = Collector(node, Odometry, f"{NS}/odom", ANY_PUBLISHER_QOS)
        pose = Collector(node, PoseStamped, f"{NS}/overhead_pose", ANY_PUBLISHER_QOS)
        yield executor, odom, pose


CUT_LABELS = (
    "return [...document.querySelectorAll('.q-field__label, .q-checkbox__label, .q-toggle__label, .q-btn .block')]"
    ".filter(e => e.offsetParent !== null && e.scrollWidth > e.clientWidth + 1).map(e => e.textContent)"
)
"""The visible labels the page cuts short (a field's "wheel radiu…")."""


@pytest.mark.parametrize("page", ["/", "/map", "/config", "/arm", "/replay"])
def test_no_field_label_is_cut_short(browser, studio_url, page):
    open_page(browser, studio_url + page)
    for header in browser.find_elements(By.CSS_SELECTOR, ".q-expansion-item .q-item"):
        # the folded parts too (New world, Load Map / Load Config, New arm world); clicked in the
        # page, as a busy browser may still be unfolding the one above over this header
        browser.execute_script("arguments[0].click()", header)
    wait(browser, lambda d: d.find_elements(By.CSS_SELECTOR, ".q-field__label"))
    # Unfolding parts grow for a moment: a label is cut short if it still is once they have grown.
    cut = browser.execute_script(CUT_LABELS)
    deadline = time.monotonic() + 10
    while cut and time.monotonic() < deadline:
        time.sleep(0.2)
        cut = browser.execute_script(CUT_LABELS)
    assert cut == []


def test_the_map_maker_draws_a_box_of_walls_and_saves_it(browser, studio_url, workspace):
    open_page(browser, studio_url + "/map")
    image = find(browser, ".studio-map-view")
    click_text(browser, "Rectangle", ".studio-tools")
    click_at(browser, image, -2.0, 1.5)
    click_at(browser, image, 2.0, -1.5)
    click_text(browser, "Beacon", ".studio-tools")
    click_at(browser, image, 1.0, 0.5)
    click_text(browser, "Line", ".studio-tools")
    click_at(browser, image, -1.8, -0.5)
    click_at(browser, image, 0.5, -0.5)
    click_text(browser, "Virtual wall", ".studio-tools")
    click_at(browser, image, 1.8, -1.3)
    click_at(browser, image, 1.8, 0.0)
    wait(browser, lambda d: "4 walls, 1 lines, 1 beacons, 1 virtual walls" in d.page_source)
    type_into(browser, ".studio-map-file", "box.map")
    find(browser, ".studio-map-save").click()
    wait(browser, lambda d: "saved box.map" in find(d, ".studio-map-message").text)
    screenshot(browser, "map_maker")

    world = load_map(workspace / "box.map")
    corners = {(x, y) for wall in world.walls.tolist() for x, y in (wall[:2], wall[2:])}
    assert corners == {(-2.0, 1.5), (2.0, 1.5), (2.0, -1.5), (-2.0, -1.5)}
    assert world.beacon_ids == ["b1"] and world.beacon_xy.tolist() == [[1.0, 0.5]]
    assert world.lines.tolist() == [[-1.8, -0.5, 0.5, -0.5]]
    assert world.virtwalls.tolist() == [[1.8, -1.3, pytest.approx(math.pi / 2), 2.0]]

    find(browser, ".studio-map-save").click()  # a second save must not overwrite silently
    wait(browser, lambda d: "file exists" in find(d, ".studio-map-message").text)
    type_into(browser, ".studio-map-file", "../escape.map")
    find(browser, ".studio-map-save").click()
    wait(browser, lambda d: "outside the workspace" in find(d, ".studio-map-message").text)
    assert not (workspace.parent / "escape.map").exists()


def test_leaving_the_map_maker_with_an_unsaved_edit_asks_first(browser):
    # The page cancels the beforeunload event (the browser then asks "Leave site?"); WebDriver
    # answers that prompt by itself, so the event is sent here as the browser sends it.
    leaving_asks = (
        "const e = new Event('beforeunload', {cancelable: true}); window.dispatchEvent(e); return e.defaultPrevented;"
    )
    assert browser.execute_script(leaving_asks) is False  # everything saved
    click_text(browser, "Beacon", ".studio-tools")
    click_at(browser, find(browser, ".studio-map-view"), -1.0, 1.0)
    wait(browser, lambda d: d.execute_script(leaving_asks) is True)
    click_text(browser, "Undo")  # back to the saved map: nothing to lose
    wait(browser, lambda d: d.execute_script(leaving_asks) is False)


def test_an_upload_that_is_binary_or_too_large_says_why_it_was_not_loaded(browser, tmp_path):
    (tmp_path / "photo.png").write_bytes(b"\x89PNG\r\n\x1a\n" + bytes(range(256)))
    (tmp_path / "huge.map").write_text("% padding\n" * 200_000)  # 2 MB
    find(browser, ".q-uploader input[type=file]").send_keys(str(tmp_path / "photo.png"))
    wait(browser, lambda d: "photo.png: not a text file (byte 0 is not UTF-8)" in find(d, ".studio-upload-error").text)
    assert "photo.png: not a text file" in find(browser, ".studio-map-message").text
    wait(browser, lambda d: not d.find_elements(By.CSS_SELECTOR, ".q-uploader__file"))  # no thumbnail, no ✓ 100 %
    find(browser, ".q-uploader input[type=file]").send_keys(str(tmp_path / "huge.map"))  # the uploader was redrawn
    wait(
        browser,
        lambda d: "upload refused: a map file may be at most 1,000,000 bytes" in find(d, ".studio-upload-error").text,
    )
    assert not browser.find_elements(By.CSS_SELECTOR, ".q-uploader__file")
    in_view = "const r = arguments[0].getBoundingClientRect(); return r.bottom <= window.innerHeight && r.height > 0;"
    assert browser.execute_script(in_view, find(browser, ".studio-upload-error"))  # beside the uploader, in sight


def test_a_new_world_on_the_saved_map_shows_the_lidar_hitting_its_walls(browser, studio_url, listener):
    open_page(browser, studio_url + "/")
    find(browser, ".studio-new-world").click()
    type_into(browser, ".studio-world-map", "box.map")
    type_into(browser, ".studio-world-ns", NS)
    find(browser, ".studio-start-world").click()
    executor, odom, _pose = listener
    started = spin_until(executor, lambda: odom.last is not None, timeout=30.0)
    assert started, f"the world did not start: {find(browser, '.studio-world-error').text!r}"

    def lidar_points(d):  # read in one script: the view redraws its layers many times a second
        return d.execute_script(
            "const p = document.querySelector('.studio-view polyline.lidar'); return p && p.getAttribute('points');"
        )

    points = wait(browser, lidar_points, timeout=20.0)
    cx, cy, scale = view_transform(browser)
    pts = [tuple(map(float, p.split(","))) for p in points.split()]
    assert len(pts) == 681
    xs = [cx + (px - 400) / scale for px, _ in pts]
    ys = [cy - (py - 300) / scale for _, py in pts]
    # Every beam ends on the box's walls (2 m and 1.5 m from its centre), none at the 4 m limit.
    assert max(abs(x) for x in xs) == pytest.approx(2.0, abs=0.05)
    assert max(abs(y) for y in ys) == pytest.approx(1.5, abs=0.05)
    assert all(abs(x) < 2.05 and abs(y) < 1.55 for x, y in zip(xs, ys, strict=True))

    def plotted(d):  # Read Sensors' LIDAR plot: range by beam angle
        return d.execute_script(
            "const p = document.querySelector('.studio-lidar-plot polyline.lidar-ranges');"
            "return p && p.getAttribute('points');"
        )

    beams = [tuple(map(float, p.split(","))) for p in wait(browser, plotted, timeout=20.0).split()]
    assert len(beams) == 681
    assert [x for x, _y in beams] == sorted(x for x, _y in beams)  # right-most beam first, as the scan
    assert len({y for _x, y in beams}) > 20  # the walls at their distances, not one flat line


def test_the_keyboard_drives_the_create_forward(browser, listener):
    executor, odom, _pose = listener
    find(browser, ".studio-forward").click()  # 0.1 m/s; the keys must still work after a click
    wait(browser, lambda d: d.execute_script("return document.activeElement === document.body"))  # focus given back
    ActionChains(browser).send_keys(Keys.ARROW_UP).perform()  # 0.2 m/s
    assert spin_until(executor, lambda: odom.last.twist.twist.linear.x == pytest.approx(0.2), timeout=15.0)
    assert spin_until(executor, lambda: odom.last.pose.pose.position.x > 0.05, timeout=15.0)
    ActionChains(browser).send_keys(" ").perform()  # stop, without pressing the clicked button again
    assert spin_until(executor, lambda: odom.last.twist.twist.linear.x == 0.0, timeout=15.0)
    ActionChains(browser).send_keys("w").perform()  # WASD as create_teleop
    assert spin_until(executor, lambda: odom.last.twist.twist.linear.x == pytest.approx(0.1), timeout=15.0)
    ActionChains(browser).send_keys(Keys.ENTER).perform()
    assert spin_until(executor, lambda: odom.last.twist.twist.linear.x == 0.0, timeout=15.0)


def test_the_driving_keys_drive_without_scrolling_the_page(browser, listener):
    executor, odom, _pose = listener
    browser.execute_script("document.body.style.minHeight = '5000px'; window.scrollTo(0, 0)")  # a long page
    wait(browser, lambda d: d.execute_script("return document.body.dataset.driving") == "1")
    try:
        ActionChains(browser).send_keys(Keys.ARROW_DOWN).send_keys(Keys.ARROW_DOWN).perform()
        assert spin_until(executor, lambda: odom.last.twist.twist.linear.x == pytest.approx(-0.2), timeout=15.0)
        ActionChains(browser).send_keys(" ").perform()
        assert spin_until(executor, lambda: odom.last.twist.twist.linear.x == 0.0, timeout=15.0)
        assert browser.execute_script("return window.scrollY") == 0  # ↓ and Space scrolled 80 px and a screen
        browser.execute_script("document.body.dataset.driving = ''")  # a page that drives nothing: keys scroll
        ActionChains(browser).send_keys(Keys.ARROW_DOWN).perform()
        wait(browser, lambda d: d.execute_script("return window.scrollY") > 0)
    finally:
        ActionChains(browser).send_keys(" ").perform()  # the last ↓ drove too
        browser.execute_script("document.body.style.minHeight = ''; document.body.dataset.driving = '1'")
        browser.execute_script("window.scrollTo(0, 0)")
    assert spin_until(executor, lambda: odom.last.twist.twist.linear.x == 0.0, timeout=15.0)


def test_a_key_press_steps_from_the_worlds_last_command_whoever_sent_it(browser, listener):
    executor, odom, _pose = listener
    ActionChains(browser).send_keys("w").send_keys("w").perform()
    assert spin_until(executor, lambda: odom.last.twist.twist.linear.x == pytest.approx(0.2), timeout=15.0)
    other_tab = executor.get_nodes()[0].create_publisher(Twist, f"{NS}/cmd_vel", COMMAND_PUBLISHER_QOS)
    # Published once both the world and the studio hear this publisher (a first message before that is lost).
    assert spin_until(executor, lambda: other_tab.get_subscription_count() >= 2, timeout=15.0)
    other_tab.publish(Twist())  # another tab, teleop or controller stops the robot
    assert spin_until(executor, lambda: odom.last.twist.twist.linear.x == 0.0, timeout=15.0)
    wait(browser, lambda d: "v 0.00 m/s" in find(d, "body").text)
    ActionChains(browser).send_keys("w").perform()  # one step up from the stop: 0.1, not 0.3
    assert spin_until(executor, lambda: odom.last.twist.twist.linear.x > 0.0, timeout=15.0)
    assert odom.last.twist.twist.linear.x == pytest.approx(0.1)
    ActionChains(browser).send_keys(" ").perform()
    assert spin_until(executor, lambda: odom.last.twist.twist.linear.x == 0.0, timeout=15.0)
    executor.get_nodes()[0].destroy_publisher(other_tab)


def test_dragging_in_set_position_mode_sets_the_pose(browser, listener):
    executor, _odom, pose = listener
    click_text(browser, "Set position", ".studio-mouse-mode")
    image = find(browser, ".studio-view")
    size = browser.execute_script("const r = arguments[0].getBoundingClientRect(); return [r.width, r.height];", image)
    assert size == [800, 600]
    scale_before = view_transform(browser)[2]
    ActionChains(browser).scroll_from_origin(ScrollOrigin.from_element(image, 100, 50), 0, -100).perform()
    wait(browser, lambda d: view_transform(d)[2] > scale_before)  # the wheel zooms in about the pointer
    assert browser.execute_script("return window.scrollY") == 0  # ... and does not scroll the page
    cx, cy, scale = view_transform(browser)
    # Press at world (-1, -0.5), drag straight up (+y): position, then heading +90 degrees.
    dx, dy = round((-1.0 - cx) * scale), round(-(-0.5 - cy) * scale)
    assert browser.execute_script("return window.scrollY") == 0  # the page fits: nothing scrolls mid-drag
    ActionChains(browser).move_to_element_with_offset(image, dx, dy).click_and_hold().move_to_element_with_offset(
        image, dx, dy - 80
    ).release().perform()

    def moved():
        p = pose.last.pose
        return abs(yaw_from_quaternion(p.orientation) - math.pi / 2) < 0.05

    assert spin_until(executor, moved, timeout=15.0), "set_pose was not applied"
    p = pose.last.pose.position
    assert (p.x, p.y) == (pytest.approx(-1.0, abs=1.5 / scale), pytest.approx(-0.5, abs=1.5 / scale))
    # A click on the box's right wall (x = 2 m): the world's set_pose service refuses, and says why.
    dx, dy = round((1.95 - cx) * scale), round(-(0.0 - cy) * scale)
    ActionChains(browser).move_to_element_with_offset(image, dx, dy).click_and_hold().release().perform()
    wait(browser, lambda d: "set_pose refused" in find(d, "body").text)
    assert "wall" in find(browser, "body").text.split("set_pose refused", 1)[1].split("\n", 1)[0]
    assert pose.last.pose.position.x == pytest.approx(-1.0, abs=1.5 / scale)  # it stayed where it was
    click_text(browser, "Pan", ".studio-mouse-mode")


def test_start_runs_create_bump_turn_on_the_selected_robot_and_stop_ends_it(browser, listener):
    executor, odom, _pose = listener
    find(browser, ".studio-controller-start").click()
    assert spin_until(executor, lambda: odom.last.twist.twist.linear.x > 0.2, timeout=30.0), (
        "the controller did not drive"
    )
    if os.environ.get("STUDIO_SCREENSHOTS"):  # a stretch of track for the picture
        spin_until(executor, lambda: odom.last.pose.pose.position.y > 0.8, timeout=10.0)
        screenshot(browser, "simulator")
    find(browser, ".studio-controller-stop").click()
    assert spin_until(executor, lambda: odom.last.twist.twist.linear.x == 0.0, timeout=15.0)


def test_a_world_on_a_missing_map_shows_its_one_line_error(browser, studio_url):
    open_page(browser, studio_url + "/")
    find(browser, ".studio-new-world").click()
    type_into(browser, ".studio-world-map", "missing.map")
    type_into(browser, ".studio-world-ns", "/bad")
    find(browser, ".studio-start-world").click()
    error = wait(browser, lambda d: "error" in (t := find(d, ".studio-world-error").text) and t, timeout=60.0)
    assert error.startswith("/bad: error: ") and "missing.map" in error and "\n" not in error


def test_the_config_maker_saves_an_edited_noise_value(browser, studio_url, workspace):
    open_page(browser, studio_url + "/config")
    type_into(browser, ".studio-lidar-std", "-1")
    type_into(browser, ".studio-config-file", "negative.cfg")
    find(browser, ".studio-config-save").click()
    wait(browser, lambda d: "lidar std -1.0 must be >= 0" in find(d, ".studio-config-message").text)
    assert find(browser, ".studio-lidar-std input").get_attribute("value") == "-1"  # kept, not made 0
    assert "must be ≥ 0" in find(browser, ".studio-lidar-std").text and not (workspace / "negative.cfg").exists()
    type_into(browser, ".studio-lidar-std", "0.05")
    type_into(browser, ".studio-com-delay", "0.1")
    type_into(browser, ".studio-config-file", "noisy.cfg")
    find(browser, ".studio-config-save").click()
    wait(browser, lambda d: "saved noisy.cfg" in find(d, ".studio-config-message").text)
    screenshot(browser, "config_maker")
    config = load_config(workspace / "noisy.cfg")
    assert config.noise["lidar"] == (0.0, 0.05)
    assert config.com_delay == 0.1
    assert config.noise["sonar"] == (0.0, 0.0)
    click_text(browser, "Apply to the running world")
    wait(browser, lambda d: "applied it to" in find(d, ".studio-config-message").text, timeout=40.0)
    assert "applied it to the world in /box" in find(browser, ".studio-config-message").text


def test_apply_to_the_running_world_loads_the_map_or_shows_why_not(browser, studio_url, workspace, listener):
    executor, _odom, pose = listener
    node = executor.get_nodes()[0]
    markers = Collector(node, MarkerArray, f"{NS}/map_markers", LATCHED_QOS)
    assert spin_until(executor, lambda: markers.last is not None, timeout=10.0)
    x, y = pose.last.pose.position.x, pose.last.pose.position.y
    (workspace / "box2.map").write_text((workspace / "box.map").read_text() + "wall -3 2 3 2\n")
    (workspace / "blocked.map").write_text(f"wall {x - 1} {y} {x + 1} {y}\n")

    def walls() -> int:
        return sum(len(m.points) // 2 for m in markers.last.markers if m.ns == "walls")

    open_page(browser, studio_url + "/map")
    type_into(browser, ".studio-map-file", "box2.map")
    find(browser, ".studio-map-load").click()
    wait(browser, lambda d: "loaded box2.map" in find(d, ".studio-map-message").text)
    click_text(browser, "Apply to the running world")
    wait(browser, lambda d: "applied it to the world in /box" in find(d, ".studio-map-message").text, timeout=40.0)
    assert spin_until(executor, lambda: walls() == 5, timeout=10.0)

    type_into(browser, ".studio-map-file", "blocked.map")
    find(browser, ".studio-map-load").click()
    wait(browser, lambda d: "loaded blocked.map" in find(d, ".studio-map-message").text)
    click_text(browser, "Apply to the running world")
    wait(browser, lambda d: "inside a wall" in find(d, ".studio-map-message").text, timeout=40.0)
    assert walls() == 5  # the world kept its map


def test_load_map_and_load_config_give_the_selected_world_a_file_or_say_why_not(
    browser, studio_url, workspace, listener
):
    executor, _odom, _pose = listener
    node = executor.get_nodes()[0]
    markers = Collector(node, MarkerArray, f"{NS}/map_markers", LATCHED_QOS)
    assert spin_until(executor, lambda: markers.last is not None, timeout=10.0)
    params = node.create_client(GetParameters, f"{NS}/create_world/get_parameters")

    def config_file() -> str:
        future = params.call_async(GetParameters.Request(names=["config_file"]))
        assert spin_until(executor, future.done, timeout=10.0)
        return future.result().values[0].string_value

    open_page(browser, studio_url + "/")
    click(browser, ".studio-world-files .q-item")
    wait(browser, lambda d: find(d, ".studio-robot .q-field__native").text.strip() == NS)
    type_into(browser, ".studio-load-map-file", "box.map")  # 4 walls: the world has box2.map's 5
    click(browser, ".studio-load-map")
    wait(browser, lambda d: "loaded box.map into the world in /box" in find(d, ".studio-world-files-message").text)
    assert spin_until(executor, lambda: sum(len(m.points) // 2 for m in markers.last.markers if m.ns == "walls") == 4)
    type_into(browser, ".studio-load-config-file", "noisy.cfg")
    click(browser, ".studio-load-config")
    wait(browser, lambda d: "loaded noisy.cfg" in find(d, ".studio-world-files-message").text, timeout=40.0)
    assert config_file() == str(workspace / "noisy.cfg")
    type_into(browser, ".studio-load-map-file", "blocked.map")  # a wall through the robot
    click(browser, ".studio-load-map")
    wait(
        browser, lambda d: "kept its map" in (t := find(d, ".studio-world-files-message").text) and "inside a wall" in t
    )
    type_into(browser, ".studio-load-map-file", "nowhere.map")
    click(browser, ".studio-load-map")
    wait(
        browser,
        lambda d: "nowhere.map: map file not found in the workspace" in find(d, ".studio-world-files-message").text,
    )


def test_the_speed_selector_sets_the_worlds_real_time_factor(browser, studio_url, listener):
    executor, _odom, _pose = listener
    client = executor.get_nodes()[0].create_client(GetParameters, f"{NS}/create_world/get_parameters")

    def rtf() -> float:
        future = client.call_async(GetParameters.Request(names=["real_time_factor"]))
        assert spin_until(executor, future.done, timeout=10.0)
        return future.result().values[0].double_value

    open_page(browser, studio_url + "/")
    wait(browser, lambda d: robot_shown(d) == NS)  # the tab has its robot: the controls reach it
    find(browser, ".studio-rtf").click()
    wait(browser, lambda d: d.find_element(By.XPATH, "//*[contains(@class,'q-item') and contains(., '2×')]")).click()
    assert spin_until(executor, lambda: rtf() == 2.0, timeout=30.0), what_happened(browser)


def test_pause_holds_the_world_and_step_advances_it_one_physics_step(browser, studio_url, listener):
    executor, odom, _pose = listener
    client = executor.get_nodes()[0].create_client(GetParameters, f"{NS}/create_world/get_parameters")

    def paused() -> bool:
        future = client.call_async(GetParameters.Request(names=["paused"]))
        assert spin_until(executor, future.done, timeout=10.0)
        return future.result().values[0].bool_value

    def stamp() -> float:
        return odom.last.header.stamp.sec + 1e-9 * odom.last.header.stamp.nanosec

    open_page(browser, studio_url + "/")
    wait(browser, lambda d: robot_shown(d) == NS)  # the tab has its robot: the controls reach it
    find(browser, ".studio-pause").click()
    try:
        assert spin_until(executor, paused, timeout=30.0), what_happened(browser)
        spin_until(executor, lambda: False, timeout=0.2)  # what was in flight has arrived
        odom.clear()
        assert not spin_until(executor, lambda: odom.msgs, timeout=1.0)  # a paused world publishes nothing
        for _ in range(2):  # two physics steps of 10 ms: one odometry message (50 Hz)
            click_text(browser, "Step")
            wait(browser, lambda d: "sim time" in d.find_element(By.CSS_SELECTOR, ".q-notification").text)
        assert spin_until(executor, lambda: len(odom.msgs) == 1, timeout=10.0)
        held_at = stamp()
        find(browser, ".studio-pause").click()  # resume
        assert spin_until(executor, lambda: stamp() > held_at + 0.5, timeout=20.0)
    finally:
        if paused():
            find(browser, ".studio-pause").click()


def test_a_world_started_in_another_terminal_appears_beside_the_selected_one_and_goes_when_it_stops(
    browser, studio_url
):
    args = ["--ros-args", "-r", "__ns:=/other", "-r", "/clock:=/other/clock", "-p", "initial_pose:=[3.0, 0.0, 0.0]"]
    env = studio_env(STUDIO_DOMAIN)
    other = subprocess.Popen(executable_command("create_world", args), cwd=ROOT, stdout=subprocess.DEVNULL, env=env)
    try:
        open_page(browser, studio_url + "/")
        drawn = "return [...document.querySelectorAll('.studio-view text')].map(t => t.textContent)"
        wait(browser, lambda d: "/other" in d.execute_script(drawn) and "/box" in d.execute_script(drawn), timeout=30.0)
    finally:
        other.terminate()
        other.wait(timeout=20)
    wait(browser, lambda d: "/other" not in d.execute_script(drawn), timeout=30.0)


def test_a_second_world_gets_the_next_free_namespace_and_clock_and_an_occupied_one_is_refused(
    browser, studio_url, listener
):
    executor, _odom, _pose = listener
    node = executor.get_nodes()[0]
    open_page(browser, studio_url + "/")
    find(browser, ".studio-new-world").click()
    wait(browser, lambda d: find(d, ".studio-world-ns input").get_attribute("value") == "/create1")
    type_into(browser, ".studio-world-map", "box.map")
    find(browser, ".studio-start-world").click()
    assert spin_until(executor, lambda: node.count_publishers("/create1/clock") == 1, timeout=60.0)
    owners = [(p.node_namespace, p.node_name) for p in node.get_publishers_info_by_topic("/clock")]
    assert owners == [(NS, "create_world")]  # the first world keeps /clock, alone
    wait(browser, lambda d: find(d, ".studio-world-ns input").get_attribute("value") == "/create2")
    type_into(browser, ".studio-world-ns", NS)
    find(browser, ".studio-start-world").click()
    wait(browser, lambda d: f"already runs in {NS}" in find(d, ".studio-world-error").text)


def robot_shown(driver) -> str:
    """The robot the Simulator page's selector shows ('' while none)."""
    return find(driver, ".studio-robot .q-field__native").text.strip()


def pick_robot(driver, ns: str) -> None:
    find(driver, ".studio-robot").click()
    item = f"//*[contains(@class,'q-item') and normalize-space(.)='{ns}']"
    wait(driver, lambda d: d.find_element(By.XPATH, item)).click()
    wait(driver, lambda d: robot_shown(d) == ns)


def test_each_tab_keeps_the_robot_it_picked_over_a_reload(browser, studio_url):
    first = browser.current_window_handle
    open_page(browser, studio_url + "/")
    pick_robot(browser, NS)
    browser.switch_to.new_window("tab")
    try:
        open_page(browser, studio_url + "/")
        pick_robot(browser, "/create1")  # the robot picked last, by another tab
    finally:
        browser.close()
        browser.switch_to.window(first)
    open_page(browser, studio_url + "/")  # reloaded
    shown = wait(browser, lambda d: robot_shown(d) in (NS, "/create1") and robot_shown(d))
    assert shown == NS
    open_page(browser, studio_url + "/")  # and once more: still its own
    wait(browser, lambda d: robot_shown(d) == NS)


def test_save_data_says_recording_once_every_topic_is_subscribed_and_keeps_one_timeline(
    browser, studio_url, workspace, listener
):
    executor, _odom, _pose = listener
    node = executor.get_nodes()[0]
    open_page(browser, studio_url + "/")
    published = [t for t, _types in node.get_topic_names_and_types() if node.count_publishers(t) and "/_" not in t]
    assert f"{NS}/scan" in published and "/create1/scan" in published

    def recorded(topic: str) -> bool:
        subscribers = node.get_subscriptions_info_by_topic(topic)
        return not node.count_publishers(topic) or any(s.node_name.startswith("studio_record_") for s in subscribers)

    started = time.monotonic()
    find(browser, ".studio-record").click()
    wait(browser, lambda d: find(d, ".studio-record-label").text.startswith("recording to"), timeout=40.0)
    # What the label promises (our node sees the graph a moment after the studio does).
    assert spin_until(executor, lambda: all(recorded(t) for t in published), timeout=2.0), [
        t for t in published if not recorded(t)
    ]
    assert "(wall time: 2 worlds, each with its own sim time)" in find(browser, ".studio-record-label").text
    bag = workspace / "studio_data" / "SimulatorOutputData_1"
    wait(browser, lambda d: any(bag.glob("*.mcap")), timeout=20.0)
    find(browser, ".studio-record").click()
    wait(browser, lambda d: "saved studio_data/SimulatorOutputData_1" in find(d, ".studio-record-label").text)
    took = time.monotonic() - started  # the recorder has ended: its metadata.yaml is complete
    info = yaml.safe_load((bag / "metadata.yaml").read_text())["rosbag2_bagfile_information"]
    assert 0 < info["duration"]["nanoseconds"] / 1e9 < took  # one timeline: not the sum of two worlds' clocks


def test_ctrl_c_stops_the_studio_and_its_world_with_status_0_within_5_s(browser, tmp_path):
    domain = studio_domain(54)
    port = free_port()
    log = tmp_path / "studio.log"
    with log.open("w") as out:  # its own session: Ctrl-C reaches the whole group, as in a terminal
        studio = subprocess.Popen(
            [sys.executable, "-m", "studio", "--workspace", str(tmp_path), "--port", str(port)],
            stdout=out, stderr=subprocess.STDOUT, cwd=ROOT, env=studio_env(domain), start_new_session=True,
        )  # fmt: skip
    try:
        wait(browser, lambda d: accepts_connections(port), timeout=60.0)
        open_page(browser, f"http://127.0.0.1:{port}/")  # a connected tab: the case that ended in a traceback
        find(browser, ".studio-new-world").click()
        click(browser, ".studio-start-world")  # once the expansion has opened
        wait(browser, lambda d: "studio: following" in log.read_text(), timeout=60.0)
        assert len(worlds_in(domain)) == 1
        os.killpg(studio.pid, signal.SIGINT)
        # A ceiling, not a speed claim: its children get one shared stop timeout (3 s, the
        # recorder 1 s more, then SIGKILL); status 0 says none of it was cut short.
        status = studio.wait(timeout=60.0)
    finally:
        if studio.poll() is None:
            os.killpg(studio.pid, signal.SIGKILL)
            studio.wait()
    output = log.read_text()
    assert status == 0 and "Traceback" not in output, output[-3000:]
    assert worlds_in(domain) == []


def test_closing_the_studios_terminal_stops_every_world_and_finishes_the_recording(browser, tmp_path):
    domain = studio_domain(62)  # the other studio modules use 50-55 and 60
    port = free_port()
    terminal, studio_side = pty.openpty()  # the studio's output is a terminal that then goes away
    output: list[bytes] = []
    studio = subprocess.Popen(
        [sys.executable, "-m", "studio", "--workspace", str(tmp_path), "--port", str(port)],
        stdout=studio_side, stderr=studio_side, cwd=ROOT, env=studio_env(domain), start_new_session=True,
    )  # fmt: skip
    os.close(studio_side)
    reader = threading.Thread(target=read_terminal, args=(terminal, output), daemon=True)
    reader.start()
    try:
        wait(browser, lambda d: accepts_connections(port), timeout=60.0)
        open_page(browser, f"http://127.0.0.1:{port}/")
        find(browser, ".studio-new-world").click()
        click(browser, ".studio-start-world")
        # Generous: a world compiles its kernels first when numba's cache is cold (minutes when loaded).
        wait(browser, lambda d: b"studio: following" in b"".join(output), timeout=150.0)
        find(browser, ".studio-record").click()
        wait(browser, lambda d: find(d, ".studio-record-label").text.startswith("recording to"), timeout=40.0)
        bag = tmp_path / "studio_data" / "SimulatorOutputData_1"
        wait(browser, lambda d: any(bag.glob("*.mcap")), timeout=20.0)
        assert len(worlds_in(domain)) == 1 and len(worlds_in(domain, b"studio_record_")) == 1
        os.close(terminal)  # the terminal window closes: its output goes nowhere, then the hang-up
        reader.join(timeout=5.0)
        os.killpg(studio.pid, signal.SIGHUP)
        status = studio.wait(timeout=30.0)
    finally:
        if studio.poll() is None:  # the test failed first: Ctrl-C, so its worlds do not outlive it
            os.killpg(studio.pid, signal.SIGINT)
            try:
                studio.wait(timeout=20.0)
            except subprocess.TimeoutExpired:
                os.killpg(studio.pid, signal.SIGKILL)
                studio.wait()
    shown = b"".join(output).decode(errors="replace")
    assert status == 0, shown[-3000:]
    assert worlds_in(domain) == [] and worlds_in(domain, b"studio_record_") == []
    info = yaml.safe_load((bag / "metadata.yaml").read_text())["rosbag2_bagfile_information"]
    assert info["message_count"] > 0  # the recorder finished its bag (metadata written at its end)


def read_terminal(fd: int, output: list[bytes]) -> None:
    """What the studio writes to its terminal, until the terminal closes."""
    while True:
        try:
            chunk = os.read(fd, 4096)
        except OSError:
            return
        if not chunk:
            return
        output.append(chunk)


def accepts_connections(port: int) -> bool:
    try:
        socket.create_connection(("127.0.0.1", port), timeout=1.0).close()
    except OSError:
        return False
    return True


def worlds_in(domain: int, program: bytes = b"create_world") -> list[int]:
    """Process ids of the ``program`` processes (create_world) running on ROS domain ``domain``."""
    found = []
    for proc in Path("/proc").iterdir():
        try:
            env = (proc / "environ").read_bytes().split(b"\0")
            cmdline = (proc / "cmdline").read_bytes()
        except (OSError, ValueError):
            continue
        if f"ROS_DOMAIN_ID={domain}".encode() in env and program in cmdline:
            found.append(int(proc.name))
    return found
