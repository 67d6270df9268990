"""The SIMROBOT pages driven as a student drives them: a real Chromium (Debian's) through Selenium.

One studio and one browser serve the module; the tests run in order: build a two-robot world with
one laser in the editor, save it, run it, watch both robots move and the laser's beams, click a
robot for its info and power, draw the tracks. ``STUDIO_SCREENSHOTS=1`` saves the pictures in docs/.
"""

from __future__ import annotations

import math
import re
import subprocess
import time
import urllib.request
from pathlib import Path

import pytest
from studio_browser_support import NO_CHROMIUM

if NO_CHROMIUM:
    pytest.skip(NO_CHROMIUM, allow_module_level=True)

from geometry_msgs.msg import Twist
from selenium.webdriver.common.action_chains import ActionChains
from selenium.webdriver.common.by import By
from selenium.webdriver.common.keys import Keys
from studio_browser_support import (
    find,
    listener_node,
    open_page,
    screenshot,
    studio_domain,
    studio_env,
    type_into,
    wait,
)

from simrobot_sim.world_file import load_world
from studio.simrobot.doc import blank_walls, map_image

WINDOW_SIZE = "1400,1400"
STUDIO_DOMAIN = studio_domain(53)  # the other studio modules use 50-52


LINKS = {  # in the workspace: links out of it and links to nothing, with the names the pages list
    "out.m": "/etc/hostname",
    "gone.m": "no_such_alg.m",
    "out.yaml": "/etc/hostname",
    "gone.yaml": "no_such_world.yaml",
    "out.png": "/etc/hostname",
    "gone.png": "no_such_map.png",
}


@pytest.fixture(scope="module")
def workspace(tmp_path_factory) -> Path:
    """The student's folder, with links out of it and dangling links lying about in it (every
    test of the module runs with them there)."""
    ws = tmp_path_factory.mktemp("simrobot_ws")
    for name, target in LINKS.items():
        (ws / name).symlink_to(target)
    return ws


@pytest.fixture(scope="module")
def ros():
    """A node on the studio's domain: the students' controllers driving the robots."""
    with listener_node(STUDIO_DOMAIN, "simrobot_browser_test") as (_executor, node):
        yield node


def click_at(driver, css: str, x_m: float, y_m: float) -> None:
    """Click the view ``css`` at world point (x, y), through the transform the page drew with."""
    cx, cy, scale = (
        float(v)
        for v in wait(
            driver,
            lambda d: d.execute_script(
                f"const g = document.querySelector('{css} g.view, {css} g.frame');"
                "return g && [g.dataset.centreX, g.dataset.centreY, g.dataset.scale];"
            ),
        )
    )
    image = find(driver, css)
    ActionChains(driver).move_to_element_with_offset(
        image, round((x_m - cx) * scale), round(-(y_m - cy) * scale)
    ).click().perform()


def click_text(driver, text: str) -> None:
    """Click the button labelled ``text`` (a toggle's own button, not its group)."""
    xpath = f"//button[contains(@class,'q-btn')][.//*[normalize-space(text())='{text}']]"
    wait(driver, lambda d: d.find_element(By.XPATH, xpath)).click()


def choose(driver, css: str, option: str) -> None:
    """Pick ``option`` in the q-select ``css``."""
    find(driver, css).click()
    item = f"[.//span[normalize-space(text())='{option}']]"
    xpath = "//div[contains(@class,'q-menu')]//div[contains(@class,'q-item')]" + item
    wait(driver, lambda d: d.find_element(By.XPATH, xpath)).click()


def robots_drawn(driver, css: str) -> dict[str, tuple[float, float]]:
    found = driver.execute_script(
        f"return Array.from(document.querySelectorAll('{css} .robot'))"
        ".map(p => [p.dataset.name, p.dataset.x, p.dataset.y]);"
    )
    return {name: (float(x), float(y)) for name, x, y in found or []}


def text(driver, css: str) -> str:
    """An element's text, read in one script (the page may replace the element meanwhile)."""
    found = driver.execute_script(f"const e = document.querySelector('{css}'); return e ? e.innerText : '';")
    return " ".join(found.split())


def message(driver) -> str:
    return text(driver, ".simrobot-editor-message")


def test_both_pages_serve_a_workspace_with_links_out_of_it_and_dangling_links(browser, studio_url, workspace):
    for page in ("/simrobot/editor", "/simrobot"):
        with urllib.request.urlopen(studio_url + page, timeout=30) as reply:  # an HTTP error raises
            assert reply.status == 200
    open_page(browser, studio_url + "/simrobot/editor")
    find(browser, ".simrobot-controller").click()
    listed = wait(browser, lambda d: text(d, ".q-menu"))
    assert "(none: topics)" in listed and "avoid" in listed
    assert "out.m" not in listed and "gone.m" not in listed  # an algorithm leading nowhere is not offered
    browser.find_element(By.TAG_NAME, "body").send_keys(Keys.ESCAPE)
    for name, field, button in (("out.yaml", "world", "Open"), ("out.png", "map", "Import")):
        type_into(browser, f".simrobot-{field}-name", name)
        click_text(browser, button)
        wait(browser, lambda d, name=name: f"error: '{name}' is outside the workspace" in message(d))
    outside = workspace.parent / f"{workspace.name}_outside.png"  # a world file whose map is elsewhere
    map_image(blank_walls(1.0, 1.0, 0.01)).save(outside)
    (workspace / "elsewhere.yaml").write_text(f"map: {outside}\nrobots: [{{name: r1, position: [0.5, 0.5]}}]\n")
    type_into(browser, ".simrobot-world-name", "elsewhere.yaml")
    click_text(browser, "Open")
    said = "is outside the workspace .*: copy the bitmap into the workspace and name it in the world file's map:"
    wait(browser, lambda d: re.fullmatch(f"error: elsewhere.yaml: its map .*{said}", message(d)))
    for name, field, button in (("gone.yaml", "world", "Open"), ("gone.png", "map", "Import")):
        type_into(browser, f".simrobot-{field}-name", name)
        click_text(browser, button)
        wait(
            browser,
            lambda d, name=name: re.fullmatch(
                f"error: {name}: the link leads to .*, which does not exist: .*", message(d)
            ),
        )


def test_a_two_robot_world_with_a_laser_is_built_in_the_editor_and_saved(browser, studio_url, workspace):
    open_page(browser, studio_url + "/simrobot/editor")
    find(browser, ".simrobot-editor-view g.view")
    type_into(browser, ".simrobot-world-name", "two.yaml")
    type_into(browser, ".simrobot-map-name", "two.png")
    # paint a block of wall in front of where r1 will look
    click_text(browser, "Paint")
    click_at(browser, ".simrobot-editor-view", 1.0, 1.0)
    click_text(browser, "Add robot")
    click_at(browser, ".simrobot-editor-view", 0.4, 1.0)
    click_at(browser, ".simrobot-editor-view", 2.0, 0.6)
    wait(browser, lambda d: set(robots_drawn(d, ".simrobot-editor-view")) == {"r1", "r2"})
    # r1: the laser
    choose(browser, ".simrobot-robot", "r1")
    wait(browser, lambda d: find(d, ".simrobot-robot-name input").get_attribute("value") == "r1")
    type_into(browser, ".simrobot-sensor-new", "front")
    click_text(browser, "Add sensor")
    wait(browser, lambda d: "added sensor front to r1" in message(d))
    choose(browser, ".simrobot-sensor-type", "laser")
    type_into(browser, ".simrobot-range", "0.8")
    wait(browser, lambda d: d.find_elements(By.CSS_SELECTOR, ".simrobot-editor-view path.beam.laser"))
    browser.execute_script("window.scrollTo(0, 0)")
    screenshot(browser, "simrobot_editor")
    click_text(browser, "Save world")
    wait(browser, lambda d: "saved two.yaml" in message(d), timeout=60)
    spec = load_world(workspace / "two.yaml")
    assert [r.name for r in spec.robots] == ["r1", "r2"]
    assert [(s.name, s.kind, s.range) for s in spec.robots[0].sensors] == [("front", "laser", 0.8)]
    assert spec.walls[100, 100]  # the painted block at (1.0, 1.0)


def test_the_editor_refuses_overlapping_robots_with_the_command_lines_words(browser):
    choose(browser, ".simrobot-robot", "r2")
    type_into(browser, ".simrobot-x", "0.42")
    type_into(browser, ".simrobot-y", "1.0")
    click_text(browser, "Validate")
    wait(
        browser,
        lambda d: "robots[1] ('r2').position [0.42, 1.0]: the robot overlaps robot 'r1'" in message(d),
        timeout=60,
    )
    type_into(browser, ".simrobot-x", "2.0")
    type_into(browser, ".simrobot-y", "0.6")
    click_text(browser, "Save world")  # overwrite is off by default, as on every page
    wait(browser, lambda d: "two.yaml: file exists (tick 'overwrite' to replace it)" in message(d), timeout=60)
    find(browser, ".simrobot-overwrite").click()
    click_text(browser, "Save world")
    wait(browser, lambda d: "saved two.yaml" in message(d), timeout=60)


def test_run_it_shows_both_robots_moving_and_the_laser_beams(browser, ros):
    click_text(browser, "Run it")
    wait(browser, lambda d: d.current_url.endswith("/simrobot"), timeout=300)  # a first start compiles kernels
    wait(browser, lambda d: set(robots_drawn(d, ".simrobot-view")) == {"r1", "r2"}, timeout=30)
    start = robots_drawn(browser, ".simrobot-view")
    # The editor's first world goes to its default namespace, /simrobot1.
    pubs = [ros.create_publisher(Twist, f"/simrobot1/{name}/cmd_vel", 10) for name in ("r1", "r2")]
    cmd = Twist()
    cmd.linear.x, cmd.angular.z = 0.05, 0.3

    def moved(d) -> bool:
        for pub in pubs:
            pub.publish(cmd)
        now = robots_drawn(d, ".simrobot-view")
        return all(math.dist(now[n], start[n]) > 0.03 for n in start)

    wait(browser, moved, timeout=30)
    # read in one script: the drawing is replaced every frame
    rays = wait(browser, lambda d: d.execute_script(
        "const p = document.querySelector('.simrobot-view path.beam.laser'); return p && p.getAttribute('d');"
    ))  # fmt: skip
    assert rays.count("M") == 30  # every ray of the laser
    assert wait(browser, lambda d: d.execute_script("return document.querySelector('.simrobot-view path.hit')"))
    wait(browser, lambda d: d.execute_script("return document.querySelector('.simrobot-view polyline.track')"))
    for pub in pubs:
        ros.destroy_publisher(pub)


def test_the_studio_is_one_ros_node_following_both_simrobot_and_arm_worlds(browser, ros):
    """Every family's client is made on the studio's one node (no second context, node or thread
    for SIMROBOT): with a SIMROBOT world and an arm world followed, the graph holds one studio
    node, subscribed to both."""
    from sim_runtime.paths import config_path
    from sim_tools.cli import executable_command
    from studio.arm.worlds import arm_world_ros_args

    args = arm_world_ros_args("/familyarm", str(config_path("arm/irb120.yaml")), "")
    arm = subprocess.Popen(
        executable_command("arm", args),
        env=studio_env(STUDIO_DOMAIN),
        stdout=subprocess.DEVNULL,
        stderr=subprocess.STDOUT,
    )

    def studio_nodes() -> list[tuple[str, str]]:
        return [
            (name, ns)
            for name, ns in ros.get_node_names_and_namespaces()
            if name.startswith("studio_") and not name.startswith("studio_record")
        ]

    def subscribed(_d) -> set[str]:
        return {topic for node in studio_nodes() for topic, _ in ros.get_subscriber_names_and_types_by_node(*node)}

    def following_both(d) -> bool:
        topics = subscribed(d)
        return "/simrobot1/robot_states" in topics and any(
            t.startswith("/familyarm/") and t.endswith("/joint_states") for t in topics
        )

    try:
        wait(browser, following_both, timeout=180)  # an arm world's first start loads its meshes
        assert len(studio_nodes()) == 1, studio_nodes()
    finally:
        arm.terminate()
        try:
            arm.wait(timeout=20)
        except subprocess.TimeoutExpired:
            arm.kill()
            arm.wait()


def test_a_clicked_robot_shows_its_info_and_can_be_powered_off(browser):
    r2 = robots_drawn(browser, ".simrobot-view")["r2"]
    click_at(browser, ".simrobot-view", *r2)
    wait(browser, lambda d: "r2" in text(d, ".simrobot-info"))
    click_text(browser, "Power off")
    wait(browser, lambda d: "power off" in text(d, ".simrobot-info"))
    screenshot(browser, "simrobot")


def test_pause_holds_the_world_and_step_advances_it_one_step(browser):
    def sim_time(d) -> float:
        return float(d.execute_script("return document.querySelector('.simrobot-view g.frame').dataset.simTime"))

    find(browser, ".simrobot-pause").click()
    seen = {"time": sim_time(browser), "since": time.monotonic()}

    def held(d) -> bool:  # the drawn sim time has stood still for a second
        t = sim_time(d)
        if t != seen["time"]:
            seen.update(time=t, since=time.monotonic())
        return time.monotonic() - seen["since"] > 1.0

    wait(browser, held)
    click_text(browser, "Step")
    wait(browser, lambda d: math.isclose(sim_time(d), seen["time"] + 0.1, abs_tol=1e-6))


def test_draw_tracks_writes_a_png_of_the_run(browser, workspace):
    type_into(browser, ".simrobot-tracks-name", "out.png")  # a link out of the workspace: refused, not followed
    click_text(browser, "Draw tracks")
    wait(browser, lambda d: "error: 'out.png' is outside the workspace" in text(d, ".simrobot-tracks-message"))
    type_into(browser, ".simrobot-tracks-name", "simrobot_tracks.png")
    click_text(browser, "Draw tracks")
    wait(browser, lambda d: "saved simrobot_tracks.png" in text(d, ".simrobot-tracks-message"))
    assert (workspace / "simrobot_tracks.png").read_bytes()[:4] == b"\x89PNG"


def test_the_step_counter_and_sim_time_are_shown_and_a_small_robot_takes_clicks_beside_it(browser):
    steps = wait(browser, lambda d: re.fullmatch(r"step (\d+) · sim time (\d+\.\d\d) s", text(d, ".simrobot-steps")))
    assert math.isclose(int(steps[1]) * 0.1, float(steps[2]), abs_tol=0.006)  # dt 0.1: step k at k * 0.1 s
    r1 = robots_drawn(browser, ".simrobot-view")["r1"]
    scale = float(browser.execute_script("return document.querySelector('.simrobot-view g.frame').dataset.scale"))
    assert 0.04 * scale < 12  # the default robot is a dozen pixels: hard to hit on its outline
    click_at(browser, ".simrobot-view", r1[0] + 17 / scale, r1[1])  # beside it, in the ring drawn round it
    wait(browser, lambda d: "robot r1" in text(d, ".simrobot-info"))
    assert browser.find_elements(By.CSS_SELECTOR, ".simrobot-view circle.robot-ring")
    assert labels_cut_off(browser) == []  # the simulator page's fields too


def test_run_replay_shows_the_steps_seen_again_in_order_and_stop_replay_returns_to_the_world(browser):
    click_text(browser, "Run replay")  # the world is paused (above): the steps seen are all there
    seen: list[tuple[int, float]] = []

    def replayed(d) -> bool:
        frame = d.execute_script(
            "const g = document.querySelector('.simrobot-view g.frame.replay');"
            "return g && [g.dataset.replayK, g.dataset.simTime];"
        )
        if frame and (not seen or seen[-1][0] != int(frame[0])):
            seen.append((int(frame[0]), float(frame[1])))
        return "(done: Stop replay to watch the world live)" in text(d, ".simrobot-steps")

    wait(browser, replayed, timeout=120)
    assert len(seen) >= 3 and seen == sorted(seen)  # in order, and sim time with it
    assert [t for _, t in seen] == sorted(t for _, t in seen)
    click_text(browser, "Stop replay")
    wait(browser, lambda d: d.execute_script("return document.querySelector('.simrobot-view g.frame:not(.replay)')"))


EVERY_FIELD = {  # field → what the student types: the world, the robot, its sensor
    "resolution": "0.02",
    "dt": "0.2",
    "steps-limit": "300",
    "step-time": "0.05",
    "robot-name": "rover",
    "x": "1.5",
    "y": "0.7",
    "heading": "30",
    "scale": "1.5",
    "R": "0.012",
    "la": "0.035",
    "lb": "0.005",
    "colour": "#ff8000",
    "sx": "0.04",
    "sy": "0.01",
    "axis": "15",
    "beamwidth": "40",
    "range": "0.5",
    "rays": "12",
}
WORLD_FIELDS = ("resolution", "dt", "steps-limit", "step-time")
SENSOR_FIELDS = ("sx", "sy", "axis", "beamwidth", "range", "rays")


def field_value(driver, name: str) -> str:
    return find(driver, f".simrobot-{name} input").get_attribute("value")


def checked(driver, name: str) -> bool:
    return find(driver, f".simrobot-{name}").get_attribute("aria-checked") == "true"


def test_every_field_of_the_editor_is_saved_as_typed_and_shown_again_when_reopened(browser, studio_url, workspace):
    open_page(browser, studio_url + "/simrobot/editor")
    type_into(browser, ".simrobot-world-name", "every.yaml")
    type_into(browser, ".simrobot-map-name", "every.png")
    for name in WORLD_FIELDS:
        type_into(browser, f".simrobot-{name}", EVERY_FIELD[name])
    find(browser, ".simrobot-lockstep").click()
    click_text(browser, "Add")
    wait(browser, lambda d: "added r1" in message(d))
    for name in ("robot-name", "x", "y", "heading", "scale", "R", "la", "lb", "colour"):
        type_into(browser, f".simrobot-{name}", EVERY_FIELD[name])
    find(browser, ".simrobot-power").click()
    shape = find(browser, ".simrobot-shape textarea")
    shape.send_keys(Keys.CONTROL, "a")
    shape.send_keys(Keys.BACKSPACE)
    shape.send_keys("-0.03, 0.03\n0.05, 0\n-0.03, -0.03")
    click_text(browser, "Apply shape")
    wait(browser, lambda d: "shape applied" in message(d))
    # Algorithm > New: the original's template, chosen for the robot and opened for editing
    type_into(browser, ".simrobot-algorithm-name", "alg_every")
    click_text(browser, "New")
    editor = find(browser, ".simrobot-algorithm-text textarea")
    wait(browser, lambda d: "function new = alg_every(simrobot, matrix, step)" in editor.get_attribute("value"))
    editor.send_keys(Keys.CONTROL, Keys.END)
    editor.send_keys("% turn left\n")
    find(browser, ".simrobot-algorithm-save").click()
    wait(browser, lambda d: "saved alg_every.m" in message(d))
    assert (workspace / "alg_every.m").read_text().endswith("new = simrobot;\n% turn left\n")
    (workspace / "mem_every.txt").write_text("1 2\n3 4\n")  # Memory > Load from disk
    type_into(browser, ".simrobot-memory-file", "mem_every.txt")
    click_text(browser, "Load memory")
    wait(browser, lambda d: "loaded mem_every.txt into rover's memory: 2 x 2 double" in message(d))
    type_into(browser, ".simrobot-sensor-new", "front")
    click_text(browser, "Add sensor")
    wait(browser, lambda d: "added sensor front to rover" in message(d))  # its fields take input from now
    choose(browser, ".simrobot-sensor-type", "laser")
    for name in SENSOR_FIELDS:
        type_into(browser, f".simrobot-{name}", EVERY_FIELD[name])
    click_text(browser, "Save world")
    wait(browser, lambda d: "saved every.yaml" in message(d), timeout=60)

    spec = load_world(workspace / "every.yaml")
    assert (spec.resolution, spec.dt, spec.steps_limit, spec.replay_step_time, spec.lockstep) == (
        0.02, 0.2, 300, 0.05, True
    )  # fmt: skip
    assert spec.walls.shape == (300, 200)  # the blank map's cells, now of 2 cm
    (r,) = spec.robots
    assert (r.name, r.position, r.scale, r.R, r.la, r.lb, r.power) == (
        "rover",
        (1.5, 0.7),
        1.5,
        0.012,
        0.035,
        0.005,
        False,
    )
    assert math.isclose(math.degrees(r.heading), 30) and r.color == pytest.approx((1.0, 128 / 255, 0.0), abs=1e-3)
    assert r.shape == ((-0.03, 0.03), (0.05, 0.0), (-0.03, -0.03))
    assert r.algorithm == str(workspace / "alg_every.m") and r.controller is None
    assert r.memory == ((1.0, 2.0), (3.0, 4.0))
    (sensor,) = r.sensors
    assert (sensor.name, sensor.kind, sensor.position, sensor.range, sensor.rays) == (
        "front",
        "laser",
        (0.04, 0.01),
        0.5,
        12,
    )
    assert math.isclose(math.degrees(sensor.axis), 15) and math.isclose(math.degrees(sensor.beamwidth), 40)

    open_page(browser, studio_url + "/simrobot/editor")  # a fresh tab: nothing but the file
    type_into(browser, ".simrobot-world-name", "every.yaml")
    click_text(browser, "Open")
    wait(browser, lambda d: "opened every.yaml: 1 robots" in message(d))
    choose(browser, ".simrobot-robot", "rover")
    wait(browser, lambda d: field_value(d, "robot-name") == "rover")
    shown = {name: field_value(browser, name) for name in EVERY_FIELD}
    assert {k: v if k in ("robot-name", "colour") else float(v) for k, v in shown.items()} == {
        k: v if k in ("robot-name", "colour") else float(v) for k, v in EVERY_FIELD.items()
    }
    assert checked(browser, "lockstep") and not checked(browser, "power")
    assert text(browser, ".simrobot-memory-info") == "memory: 2 x 2 double (32 bytes)"
    assert "alg_every.m" in text(browser, ".simrobot-controller")
    assert text(browser, ".simrobot-sensor-type").split()[:2] == ["type", "laser"]
    assert field_value(browser, "map-name") == "every.png"


def test_a_value_outside_its_field_s_limits_is_refused_with_its_unit_and_what_to_type(browser):
    for name, typed, said in (
        ("resolution", "-0.01", "m per cell: -0.01 is not above 0: type the size of one map cell in metres"),
        ("rays", "0", "rays: 0 is below 1: type the number of rays, a whole number from 1"),
        ("R", "0", "wheel radius (m): 0 is not above 0: type the wheels' radius in metres"),
        ("steps-limit", "2.5", "steps limit: 2.5 is not a whole number: type the number of steps"),
    ):
        type_into(browser, f".simrobot-{name}", typed)
        click_text(browser, "Validate")
        wait(browser, lambda d, said=said: message(d).startswith(f"error: {said}"))
        type_into(browser, f".simrobot-{name}", EVERY_FIELD[name])
    click_text(browser, "Validate")
    wait(browser, lambda d: "every.yaml: valid (1 robots, 1 sensors)" in message(d), timeout=30)


def labels_cut_off(driver) -> list[str]:
    return driver.execute_script(
        "return Array.from(document.querySelectorAll('.q-field__label'))"
        ".filter(l => l.offsetParent && l.scrollWidth > l.clientWidth + 1).map(l => l.textContent);"
    )


def test_no_field_label_of_the_editor_is_cut_off(browser):
    assert labels_cut_off(browser) == []
    assert len(browser.find_elements(By.CSS_SELECTOR, ".q-field__label")) > 20


def test_importing_a_file_that_is_no_image_says_so_in_a_sentence(browser, workspace):
    (workspace / "notes.png").write_text("my notes, not a picture\n")
    type_into(browser, ".simrobot-map-name", "notes.png")
    click_text(browser, "Import")
    wait(browser, lambda d: "the file is not an image; save the map as a 1-bit or greyscale PNG or BMP" in message(d))
    assert "BytesIO" not in message(browser) and "object at 0x" not in message(browser)


def world_shown(driver) -> str:
    """The world the SIMROBOT page's selector shows ('' while none)."""
    return text(driver, ".simrobot-world .q-field__native")


def test_each_tab_keeps_the_world_it_picked_over_a_reload(browser, studio_url, ros):
    from sim_tools.cli import executable_command

    # a second world beside the editor's /simrobot1, started from a terminal as a user would
    other = subprocess.Popen(
        executable_command(
            "simrobot_world", ["--ros-args", "-r", "__ns:=/other", "-p", "world_file:=simrobot/demo.yaml"]
        ),
        env=studio_env(STUDIO_DOMAIN),
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
    )
    first = browser.current_window_handle
    try:
        # up once it publishes (a first start may compile kernels)
        deadline = time.monotonic() + 300
        while not any(name.startswith("/other/") for name, _types in ros.get_topic_names_and_types()):
            assert other.poll() is None and time.monotonic() < deadline, "the second world did not start"
            time.sleep(0.5)
        open_page(browser, studio_url + "/simrobot")
        wait(browser, lambda d: world_shown(d) != "", timeout=60)
        choose(browser, ".simrobot-world", "/other")
        wait(browser, lambda d: world_shown(d) == "/other")
        browser.switch_to.new_window("tab")
        try:
            open_page(browser, studio_url + "/simrobot")
            choose(browser, ".simrobot-world", "/simrobot1")  # the world picked last, by another tab
            wait(browser, lambda d: world_shown(d) == "/simrobot1")
        finally:
            browser.close()
            browser.switch_to.window(first)
        for _reload in range(2):
            open_page(browser, studio_url + "/simrobot")
            shown = wait(browser, lambda d: world_shown(d) in ("/other", "/simrobot1") and world_shown(d))
            assert shown == "/other"
    finally:
        other.terminate()
        other.wait(timeout=30)
