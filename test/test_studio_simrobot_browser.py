"""The SIMROBOT pages driven as a student drives them: a real Chromium (Debian's) through Selenium.

One studio and one browser serve the module; the tests run in order: build a two-robot world with
one laser in the editor, save it, run it, watch both robots move and the laser's beams, click a
robot for its info and power, draw the tracks. ``STUDIO_SCREENSHOTS=1`` saves the pictures in docs/.
"""

from __future__ import annotations

import math
import time
from pathlib import Path

import pytest
from studio_browser_support import NO_CHROMIUM

if NO_CHROMIUM:
    pytest.skip(NO_CHROMIUM, allow_module_level=True)

from geometry_msgs.msg import Twist
from selenium.webdriver.common.action_chains import ActionChains
from selenium.webdriver.common.by import By
from studio_browser_support import (
    find,
    listener_node,
    open_page,
    screenshot,
    studio_domain,
    type_into,
    wait,
)

from simrobot_sim.world_file import load_world

WINDOW_SIZE = "1400,1400"
STUDIO_DOMAIN = studio_domain(53)  # the other studio modules use 50-52


@pytest.fixture(scope="module")
def workspace(tmp_path_factory) -> Path:
    return tmp_path_factory.mktemp("simrobot_ws")


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
    wait(browser, lambda d: d.current_url.endswith("/simrobot"), timeout=90)
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
    click_text(browser, "Draw tracks")
    wait(browser, lambda d: "saved simrobot_tracks.png" in text(d, ".simrobot-tracks-message"))
    assert (workspace / "simrobot_tracks.png").read_bytes()[:4] == b"\x89PNG"
