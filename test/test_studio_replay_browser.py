"""The replay page driven as a student drives ReplayGUI, in a real Chromium (Debian's) through Selenium.

A short Create run is written into the workspace as a bag; the page opens it, steps through it with
the arrow keys (the time and pose shown must be the bag's), plays it at ¼ speed, exports it to Rerun
and draws its tracks. ``STUDIO_SCREENSHOTS=1`` also saves the page's picture into docs/.
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
from sim_runtime.rerun_view.convert import default_output

ROOT = Path(__file__).resolve().parent.parent
STUDIO_DOMAIN = studio_domain(52)
BAG = "runs/demo_run"
START_S = 100.0  # the bag's first message is at 100 s: the page shows time since the start
DURATION_S = 10.0  # the robot meets a wall and turns after ~7.5 s


@pytest.fixture(scope="module")
def workspace(tmp_path_factory) -> Path:
    ws = tmp_path_factory.mktemp("replay_ws")
    write_create_run(ws / BAG, DURATION_S, start_s=START_S)
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
    from selenium.webdriver.common.by import By
    from selenium.webdriver.common.keys import Keys

    open_page(browser, studio_url + "/replay")
    find(browser, ".studio-replay-bag").click()
    wait(
        browser, lambda d: d.find_element(By.XPATH, f"//*[contains(@class,'q-item') and contains(., '{BAG}')]")
    ).click()
    find(browser, ".studio-replay-open").click()
    wait(browser, lambda d: "messages" in find(d, ".studio-replay-message").text, timeout=30.0)
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
    # latest pose at or before it.
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
