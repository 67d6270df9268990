"""The replay page driven as a student drives ReplayGUI, in a real Chromium (Debian's) through Selenium.

A short Create run is written into the workspace as a bag; the page opens it, steps through it with
the arrow keys (the time and pose shown must be the bag's), plays it at ¼ speed, exports it to Rerun
and draws its tracks. A recorded arm run is drawn in 3D, its links where the bag has them at each
instant. ``STUDIO_SCREENSHOTS=1`` also saves the pages' pictures into docs/.
"""

from __future__ import annotations

import time
from pathlib import Path

import pytest
from studio_browser_support import NO_CHROMIUM

if NO_CHROMIUM:
    pytest.skip(NO_CHROMIUM, allow_module_level=True)

from studio_browser_support import (
    find,
    open_page,
    screenshot,
    studio_domain,
    wait,
)

from create_sim.synthetic_run import write_create_run
from sim_runtime.bag.reader import open_bag
from sim_runtime.msgs import yaw_from_quaternion
from sim_tools.rerun_view.convert import default_output

ROOT = Path(__file__).resolve().parent.parent
STUDIO_DOMAIN = studio_domain(52)
BAG = "runs/demo_run"
ARM_BAG = "runs/arm_run"
START_S = 100.0  # the bag's first message is at 100 s: the page shows time since the start
DURATION_S = 10.0  # the robot meets a wall and turns after ~7.5 s


@pytest.fixture(scope="module")
def workspace(tmp_path_factory) -> Path:
    from arm_sim.demo import run_demo
    from sim_tools.demo import _Recording

    ws = tmp_path_factory.mktemp("replay_ws")
    write_create_run(ws / BAG, DURATION_S, start_s=START_S)
    recording = _Recording(ws / ARM_BAG)  # the arm demo recorded for real (its own private domain)
    run_demo(None, extra_nodes=recording)
    recording.close()
    return ws


@pytest.fixture(scope="module")
def poses(workspace) -> list[tuple[float, float, float, float]]:
    """(seconds since the bag's start, x, y, θ) of every ground-truth pose, read from the bag."""
    bag = open_bag(workspace / BAG)
    out = []
    for m in bag.messages(topics=["/overhead_pose"]):
        p = m.msg.pose
        out.append(
            ((m.log_time_ns - bag.start_ns) / 1e9, p.position.x, p.position.y, yaw_from_quaternion(p.orientation))
        )
    return out


def choose_bag(driver, name: str) -> None:
    from selenium.webdriver.common.by import By

    find(driver, ".studio-replay-bag").click()
    wait(
        driver, lambda d: d.find_element(By.XPATH, f"//*[contains(@class,'q-item') and contains(., '{name}')]")
    ).click()
    find(driver, ".studio-replay-open").click()
    wait(driver, lambda d: f"{name}:" in find(d, ".studio-replay-message").text, timeout=30.0)


def shown(driver) -> tuple[float, tuple[float, float, float]]:
    """The time (s) and pose the page shows, read in one script (playback redraws them)."""
    text, pose = driver.execute_script(
        "return [document.querySelector('.studio-replay-time').textContent,"
        " (document.querySelector('.studio-replay-pose') || {}).textContent];"
    )
    assert pose, "no pose shown"
    return float(text.split()[2]), tuple(float(v) for v in pose.split())


def press(driver, key: str) -> None:
    from selenium.webdriver.common.action_chains import ActionChains

    ActionChains(driver).send_keys(key).perform()


def assert_at(driver, sample) -> None:
    t, x, y, theta = sample
    wait(driver, lambda d: abs(shown(d)[0] - t) < 5e-4)
    _t, pose = shown(driver)
    assert pose == (pytest.approx(x, abs=5e-4), pytest.approx(y, abs=5e-4), pytest.approx(theta, abs=5e-4))


def test_a_bag_opens_at_its_first_instant_and_the_arrow_keys_step_through_it(browser, studio_url, poses):
    from selenium.webdriver.common.keys import Keys

    open_page(browser, studio_url + "/replay")
    choose_bag(browser, BAG)
    assert not find(browser, ".studio-replay-arm-view").is_displayed()  # no arm in this bag
    assert_at(browser, poses[0])
    lidar = (
        "const p = document.querySelector('.studio-replay-view polyline.lidar'); return p && p.getAttribute('points');"
    )
    assert len(wait(browser, lambda d: d.execute_script(lidar)).split()) == 681

    for k in (1, 2, 3):
        press(browser, Keys.ARROW_RIGHT)
        assert_at(browser, poses[k])
    press(browser, Keys.ARROW_LEFT)
    assert_at(browser, poses[2])
    press(browser, Keys.ARROW_DOWN)
    assert_at(browser, poses[3])
    press(browser, Keys.ARROW_UP)
    press(browser, Keys.ARROW_UP)
    assert_at(browser, poses[1])
    commands = find(browser, ".studio-replay-commands").text
    assert "/cmd_vel" in commands and "v 0.300 m/s" in commands  # the controller's first command


def test_quarter_speed_plays_forwards_pause_holds_and_stop_goes_back_to_the_start(browser, poses):
    find(browser, ".studio-replay-slow").click()
    wait(browser, lambda d: find(d, ".studio-replay-speed").text == "playing at ¼ speed")
    wait(browser, lambda d: shown(d)[0] > 0.3)
    find(browser, ".studio-replay-pause").click()
    wait(browser, lambda d: find(d, ".studio-replay-speed").text == "paused")
    held = shown(browser)[0]
    started = time.monotonic()
    wait(browser, lambda d: time.monotonic() - started > 0.3)
    assert shown(browser)[0] == held
    # Whatever instant it stopped at (exact in the drawing's data-t, ns), the pose shown is the bag's
    # latest pose at or before it. The drawing and the label are two updates to the page, which a
    # busy browser may apply a frame apart: wait until both show the paused instant.
    wait(browser, lambda d: abs(exact_time(d) - shown(d)[0]) < 5e-4)
    exact = exact_time(browser)
    assert exact == pytest.approx(held, abs=5e-4)
    latest = max((p for p in poses if p[0] <= exact), key=lambda p: p[0])
    assert shown(browser)[1] == pytest.approx(latest[1:], abs=5e-4)
    find(browser, ".studio-replay-rewind").click()
    wait(browser, lambda d: find(d, ".studio-replay-speed").text == "backwards at ¼ speed")
    wait(browser, lambda d: shown(d)[0] < held - 0.05)
    find(browser, ".studio-replay-stop").click()
    assert_at(browser, poses[0])


def exact_time(driver) -> float:
    """The instant drawn, exactly (the view's data-t, ns), in seconds since the bag's start."""
    t_ns = int(driver.execute_script("return document.querySelector('.studio-replay-view g.view').dataset.t"))
    return (t_ns - round(START_S * 1e9)) / 1e9


def test_a_click_on_the_timeline_seeks_there(browser, poses):
    from selenium.webdriver.common.action_chains import ActionChains

    slider = find(browser, ".studio-replay-slider")
    width = slider.size["width"]
    # 95 % along the timeline (Selenium offsets are from the centre of the element)
    ActionChains(browser).move_to_element_with_offset(slider, round(0.45 * width), 0).click().perform()
    wait(browser, lambda d: shown(d)[0] > 0.8 * DURATION_S)
    assert find(browser, ".studio-replay-speed").text == "paused"
    exact = exact_time(browser)
    latest = max((p for p in poses if p[0] <= exact), key=lambda p: p[0])
    assert shown(browser)[1] == pytest.approx(latest[1:], abs=5e-4)
    ActionChains(browser).move_to_element(find(browser, ".studio-replay-panel")).perform()  # no tooltip in the picture
    screenshot(browser, "replay")


def test_export_to_rerun_and_draw_tracks_write_their_files_beside_the_bag(browser, workspace):
    find(browser, ".studio-replay-rerun").click()
    wait(browser, lambda d: "wrote" in find(d, ".studio-replay-output").text, timeout=60.0)
    rrd = default_output(workspace / BAG)
    assert rrd.exists() and rrd.stat().st_size > 10_000
    find(browser, ".studio-replay-tracks").click()
    wait(browser, lambda d: "tracks.png" in find(d, ".studio-replay-output").text, timeout=60.0)
    png = workspace / "runs" / "demo_run_tracks.png"
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def link_positions(driver) -> dict[str, tuple[float, float, float]]:
    """Where the 3D view has put each arm mesh: marker key → position of its three.js object."""
    return driver.execute_script(
        "const el = document.querySelector('.studio-replay-arm-view');"
        "const scene = el && window['scene_' + el.id]; const out = {}; if (!scene) return out;"
        "scene.traverse(o => { if (o.name && o.name.includes('/meshes/') && o.children.some(c => c.isMesh))"
        " out[o.name.split('|')[1]] = [o.position.x, o.position.y, o.position.z]; }); return out;"
    )


def test_an_arm_bag_is_drawn_in_3d_with_each_link_where_the_bag_has_it(browser, studio_url, workspace):
    from selenium.webdriver.common.action_chains import ActionChains
    from selenium.webdriver.common.keys import Keys

    from studio.arm.ros_client import drawables

    bag = open_bag(workspace / ARM_BAG)
    markers = {}  # log time (ns) → marker key → position, as recorded
    for m in bag.messages(topics=["/robot_markers"]):
        look, poses = drawables(m.msg)
        markers[m.log_time_ns] = {d.key: tuple(p[:3]) for d, p in zip(look, poses.tolist(), strict=True)}
    times = sorted(markers)

    def drawn_at(t_ns: int) -> bool:
        here = link_positions(browser)
        want = markers[max(t for t in times if t <= t_ns)]
        return len(here) == 7 and all(
            here[k] == pytest.approx(want[k], abs=1e-6) for k in want if k.startswith("IRB120/meshes/")
        )

    def drawn_t() -> int:
        return int(browser.execute_script("return document.querySelector('.studio-replay-view g.view').dataset.t"))

    open_page(browser, studio_url + "/replay")
    choose_bag(browser, ARM_BAG)
    assert "arms /" in find(browser, ".studio-replay-message").text
    wait(browser, lambda d: find(d, ".studio-replay-arm-view").is_displayed())
    wait(browser, lambda d: not find(d, ".studio-replay-view").is_displayed())  # nothing to draw on a map
    assert drawn_t() == times[0]  # the first frame: the first joints, 10 ms after the latched description
    wait(browser, lambda d: drawn_at(times[0]), timeout=30.0)  # the meshes load, then sit as there
    start = link_positions(browser)

    slider = find(browser, ".studio-replay-slider")
    ActionChains(browser).move_to_element_with_offset(slider, round(0.3 * slider.size["width"]), 0).click().perform()
    wait(browser, lambda d: drawn_t() > bag.start_ns + 0.6 * (bag.end_ns - bag.start_ns))
    wait(browser, lambda d: drawn_at(drawn_t()))
    moved = link_positions(browser)
    assert max(abs(a - b) for k in moved for a, b in zip(moved[k], start[k], strict=True)) > 0.05
    before = drawn_t()
    ActionChains(browser).send_keys(Keys.ARROW_RIGHT).perform()
    wait(browser, lambda d: drawn_t() == min(t for t in times if t > before))  # one joint_states frame on
    wait(browser, lambda d: drawn_at(drawn_t()))
    assert "end effector" in find(browser, ".studio-replay-panel").text
    ActionChains(browser).move_to_element(find(browser, ".studio-replay-panel")).perform()
    screenshot(browser, "replay_arm")


def test_a_bag_of_two_worlds_shows_one_world_at_a_time_each_on_its_own_map(browser, studio_url, workspace):
    from selenium.webdriver.common.by import By
    from test_studio_replay import write_two_world_bag

    write_two_world_bag(workspace / "runs" / "two_worlds")
    open_page(browser, studio_url + "/replay")
    choose_bag(browser, "runs/two_worlds")
    assert "2 worlds, shown one at a time" in find(browser, ".studio-replay-message").text
    labels = "return [...document.querySelectorAll('.studio-replay-view text')].map(t => t.textContent)"
    grid = "return !!document.querySelector('.studio-replay-view image')"  # SIMROBOT's occupancy grid
    wait(browser, lambda d: "/create1" in d.execute_script(labels))
    assert not any("simrobot1" in t for t in browser.execute_script(labels)) and not browser.execute_script(grid)
    find(browser, ".studio-replay-world").click()
    item = "//*[contains(@class,'q-item') and contains(., '/simrobot1 (simrobot)')]"
    wait(browser, lambda d: d.find_element(By.XPATH, item)).click()
    wait(browser, lambda d: "/simrobot1/r1" in d.execute_script(labels) and d.execute_script(grid))
    assert "/create1" not in browser.execute_script(labels)  # the Create is not drawn in SIMROBOT's map
