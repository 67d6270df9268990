"""An m-file control program started from the studio's Autonomous section, in a real Chromium:
it drives the robot through Octave and the MATLAB bridge, Stop ends it and the robot stops, and
a program that fails shows Octave's error line. Skipped with one line each where Debian's
Chromium or GNU Octave is absent (CI installs both)."""

from __future__ import annotations

import contextlib
import math
import re
import shutil
from collections.abc import Callable
from pathlib import Path

import pytest
import yaml
from studio_browser_support import NO_CHROMIUM

if NO_CHROMIUM:
    pytest.skip(NO_CHROMIUM, allow_module_level=True)
if shutil.which("octave-cli") is None:
    pytest.skip("m-file program tests skipped: no octave-cli (CI installs it: .ci/run)", allow_module_level=True)

from nav_msgs.msg import Odometry
from selenium.webdriver.common.by import By
from selenium.webdriver.support.ui import WebDriverWait
from studio_browser_support import click, click_text, find, listener_node, open_page, studio_domain, type_into, wait

from sim_runtime.qos import ANY_PUBLISHER_QOS
from sim_runtime.testing import Collector, spin_until
from sim_tools.matlab.bridge import KEY_ENV

NS = "/mlab"
STUDIO_DOMAIN = studio_domain(55)  # the other studio modules use 50-54

CIRCLES = """\
function circles(serPort)
% Drive on a circle until stopped, saying where odometry has got to.
disp('circles: driving');
tic;
while toc < 600
    SetFwdVelAngVelCreate(serPort, 0.3, 0.2);
    pause(0.2);
end
end
"""
WANDER = """\
function new = wander(simrobot, matrix, step)
% Straight on, turning left when the front sonar sees something nearer than 20 cells.
[dist, num] = readusonic(simrobot, 'sens1', matrix);
if dist < 20
  simrobot = setvel(simrobot, [0 3]);
else
  simrobot = setvel(simrobot, [3 3]);
end
new = simrobot;
"""
GIVES_UP = """\
function gives_up(serPort)
% gives up once the robot has moved 5 cm (in the world's time: a busy machine cannot skip it),
% commanding its speed every turn of the loop as a control program does
moved = 0;
while moved < 0.05
  SetFwdVelAngVelCreate(serPort, 0.2, 0);
  moved = moved + DistanceSensorRoomba(serPort);
  pause(0.05);
end
error('lab:gave_up', 'gave up on purpose');
end
"""


@pytest.fixture(scope="module")
def workspace(tmp_path_factory) -> Path:
    ws = tmp_path_factory.mktemp("studio_matlab_ws")
    (ws / "labs").mkdir()
    (ws / "labs" / "circles.m").write_text(CIRCLES)
    (ws / "gives_up.m").write_text(GIVES_UP)
    (ws / "labs" / "wander.m").write_text(WANDER)
    return ws


@pytest.fixture(scope="module")
def odom():
    """The robot's odometry, read by the test's own node in the studio's domain."""
    with listener_node(STUDIO_DOMAIN, "studio_matlab_listener") as (executor, node):
        yield executor, Collector(node, Odometry, f"{NS}/odom", ANY_PUBLISHER_QOS)


def choose_program(driver, label: str, css: str = ".studio-controller-choice") -> None:
    """Pick ``label`` in the Autonomous section's list (the workspace's programs are listed there).

    A click while the menu still opens (or the page redraws, on a busy machine) may land beside
    the item: the menu is opened and the item clicked again until the choice shows it."""
    xpath = (
        f"//div[contains(@class,'q-menu')]//div[contains(@class,'q-item')][.//span[normalize-space(text())='{label}']]"
    )
    for _attempt in range(5):
        if label in text_of(driver, css):
            return
        if not driver.find_elements(By.XPATH, xpath):
            find(driver, css).click()
        with contextlib.suppress(Exception):  # the item went stale or was covered: try again
            wait(driver, lambda d: d.find_element(By.XPATH, xpath)).click()
        with contextlib.suppress(Exception):
            WebDriverWait(driver, 5.0, poll_frequency=0.05).until(lambda d: label in text_of(d, css))
    wait(driver, lambda d: label in text_of(d, css))


def click_until_it_takes(driver, css: str, took: Callable, tries: int = 3) -> None:
    """Click ``css`` until ``took(driver)``, at most ``tries`` times, 10 s apart.

    Stop's handler first forgets the controller (the state reads "manual control" at the next
    redraw, whatever then happens to Octave and the bridge): a state still "running" 15 s after a
    click, as seen once at load 25, means the handler never ran, the click was lost in the page
    (a redraw under the pointer), not that stopping failed. A user clicks again; so does this."""
    for _attempt in range(tries):
        find(driver, css).click()
        with contextlib.suppress(Exception):
            WebDriverWait(driver, 10.0, poll_frequency=0.05).until(took)
            return
    wait(driver, took)


def text_of(driver, css: str) -> str:
    """An element's text, read in one script (the page redraws it twice a second)."""
    return driver.execute_script(f"const e = document.querySelector('{css}'); return e ? e.innerText : '';")


def controller_state(driver) -> str:
    return text_of(driver, ".studio-controller-state")


@pytest.fixture(scope="module")
def world(browser, studio_url, odom):
    """A Create world in ``NS``, started once from the studio's page for the module's tests."""
    executor, odometry = odom
    open_page(browser, studio_url + "/")
    find(browser, ".studio-new-world").click()
    type_into(browser, ".studio-world-ns", NS)
    # Twice at the end of a full run the click started nothing (no world's log in the studio's
    # output): lost in the page, as click_until_it_takes says of Stop. A user clicks again; a click
    # while the world is starting only shows "already runs".
    for _attempt in range(3):
        click(browser, ".studio-start-world")
        if spin_until(executor, lambda: odometry.last is not None, timeout=20.0):
            return odom
    raise AssertionError(f"the world did not start: {text_of(browser, '.studio-world-error')!r}")


@pytest.fixture
def simulator_page(browser, studio_url, world):
    """The Simulator page following the module's world (each test starts there, in any order)."""
    if not browser.current_url.rstrip("/").endswith(studio_url.rstrip("/")):
        open_page(browser, studio_url + "/")
    wait(browser, lambda d: NS in text_of(d, ".studio-status"), timeout=30.0)  # the page follows it
    return world


def test_an_m_file_program_started_from_autonomous_drives_the_robot_and_stop_stops_it(browser, simulator_page):
    executor, odometry = simulator_page
    choose_program(browser, "labs/circles.m (Octave)")
    find(browser, ".studio-controller-start").click()
    assert spin_until(executor, lambda: odometry.last.twist.twist.linear.x == pytest.approx(0.3), timeout=60.0), (
        controller_state(browser)
    )
    start = odometry.last.pose.pose.position
    assert spin_until(executor, lambda: abs(odometry.last.pose.pose.position.x - start.x) > 0.1, timeout=15.0)
    wait(browser, lambda d: "circles.m (Octave) running" in controller_state(d))

    assert running_in(STUDIO_DOMAIN, b"octave-cli") and running_in(STUDIO_DOMAIN, b"matlab_bridge")
    # The run's key: one, fresh, in the environment of both (not their command lines, which ps shows).
    pids = running_in(STUDIO_DOMAIN, b"octave-cli") + running_in(STUDIO_DOMAIN, b"matlab_bridge")
    (key,) = {run_key(pid) for pid in pids}
    assert re.fullmatch(r"[0-9a-f]{64}", key)
    assert not any(key.encode() in Path(f"/proc/{pid}/cmdline").read_bytes() for pid in pids)

    click_until_it_takes(browser, ".studio-controller-stop", lambda d: "running" not in controller_state(d))
    assert spin_until(executor, lambda: odometry.last.twist.twist.linear.x == 0.0, timeout=30.0)
    wait(browser, lambda d: controller_state(d) == "manual control", timeout=30.0)
    assert running_in(STUDIO_DOMAIN, b"octave-cli") == running_in(STUDIO_DOMAIN, b"matlab_bridge") == []


def test_a_program_that_fails_shows_octaves_error_and_leaves_the_robot_stopped(browser, simulator_page):
    executor, odometry = simulator_page
    choose_program(browser, "gives_up.m (Octave)")
    before = len(odometry.msgs)
    find(browser, ".studio-controller-start").click()
    driven = spin_until(
        executor, lambda: any(m.twist.twist.linear.x == pytest.approx(0.2) for m in odometry.msgs[before:]), 60.0
    )
    assert driven, controller_state(browser)
    wait(browser, lambda d: "gives_up.m (Octave) ended: error: gave up on purpose" in controller_state(d), timeout=30.0)
    assert spin_until(executor, lambda: odometry.last.twist.twist.linear.x == 0.0, timeout=15.0)
    wait(browser, lambda d: running_in(STUDIO_DOMAIN, b"matlab_bridge") == [])  # ended with its program


def running_in(domain: int, name: bytes) -> list[int]:
    """Process ids of the processes on ROS domain ``domain`` whose command line holds ``name``."""
    found = []
    for proc in Path("/proc").iterdir():
        try:
            env = (proc / "environ").read_bytes().split(b"\0")
            cmdline = (proc / "cmdline").read_bytes()
        except (OSError, ValueError):
            continue
        if f"ROS_DOMAIN_ID={domain}".encode() in env and name in cmdline:
            found.append(int(proc.name))
    return found


def run_key(pid: int) -> str:
    """The bridge key in process ``pid``'s environment ("" without one)."""
    for entry in Path(f"/proc/{pid}/environ").read_bytes().split(b"\0"):
        if entry.startswith(f"{KEY_ENV}=".encode()):
            return entry.split(b"=", 1)[1].decode()
    return ""


def robots_drawn(driver) -> dict[str, tuple[float, float]]:
    found = driver.execute_script(
        "return Array.from(document.querySelectorAll('.simrobot-view .robot'))"
        ".map(p => [p.dataset.name, p.dataset.x, p.dataset.y]);"
    )
    return {name: (float(x), float(y)) for name, x, y in found or []}


def test_the_simrobot_editor_gives_a_robot_an_algorithm_m_file_that_drives_it(browser, studio_url, workspace):
    open_page(browser, studio_url + "/simrobot/editor")
    find(browser, ".simrobot-editor-view g.view")
    type_into(browser, ".simrobot-world-name", "alg.yaml")
    type_into(browser, ".simrobot-map-name", "alg.png")
    click_text(browser, "Add")
    wait(browser, lambda d: "added r1" in text_of(d, ".simrobot-editor-message"))
    click_text(browser, "Add sensor")
    wait(browser, lambda d: "added sensor sens1 to r1" in text_of(d, ".simrobot-editor-message"))
    choose_program(browser, "labs/wander.m (Octave)", ".simrobot-controller")
    click_text(browser, "Save world")
    wait(browser, lambda d: "saved alg.yaml" in text_of(d, ".simrobot-editor-message"), timeout=60)
    assert yaml.safe_load((workspace / "alg.yaml").read_text())["robots"][0]["algorithm"] == "labs/wander.m"

    click_text(browser, "Run it")
    wait(browser, lambda d: d.current_url.endswith("/simrobot"), timeout=90)
    start = wait(browser, lambda d: robots_drawn(d).get("r1"), timeout=30)
    wait(browser, lambda d: math.dist(robots_drawn(d)["r1"], start) > 0.05, timeout=30)  # driven by Octave
