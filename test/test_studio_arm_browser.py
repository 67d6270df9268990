"""The studio's Arm page driven as a student drives it: a real Chromium (Debian's) through Selenium.

One studio process, one browser and one IRB120 world (started from the page) serve the module;
the tests run in order. What the arm does is read from the test's own ROS node (``joint_states``,
``end_effector_pose``), as any client would. Skipped with one line without Debian's ``chromium``
and ``chromium-driver``; ``STUDIO_SCREENSHOTS=1`` also saves the page into docs/studio_arm.png.
"""

from __future__ import annotations

import math
import time
from pathlib import Path

import pytest
from studio_browser_support import NO_CHROMIUM

if NO_CHROMIUM:
    pytest.skip(NO_CHROMIUM, allow_module_level=True)

from geometry_msgs.msg import PoseStamped
from selenium.webdriver.common.action_chains import ActionChains
from selenium.webdriver.common.by import By
from sensor_msgs.msg import JointState
from studio_browser_support import (
    click,
    find,
    listener_node,
    screenshot,
    studio_domain,
    type_into,
    wait,
)

from sim_runtime.qos import ANY_PUBLISHER_QOS
from sim_runtime.testing import Collector, spin_until

# A domain of its own (not the Create pages' test domain): nothing other tests leave behind shows up.
WINDOW_SIZE = "1400,1400"
STUDIO_DOMAIN = studio_domain(51)
TRAJECTORY = """\
joint_names: [joint_1, joint_2, joint_3]
points:
  - {time: 0.5, positions: [20*deg, 10*deg, -10*deg]}
  - {time: 1.0, positions: [30*deg, 0, 0]}
"""


@pytest.fixture(scope="module")
def workspace(tmp_path_factory) -> Path:
    return tmp_path_factory.mktemp("studio_arm_ws")


@pytest.fixture(scope="module")
def listener():
    """The test's own ROS node in the studio's domain: the arm's joint states and flange pose."""
    with listener_node(STUDIO_DOMAIN, "studio_arm_test_listener") as (executor, node):
        # The page's first arm world goes to its default namespace, /arm1.
        joints = Collector(node, JointState, "/arm1/joint_states", ANY_PUBLISHER_QOS)
        pose = Collector(node, PoseStamped, "/arm1/end_effector_pose", ANY_PUBLISHER_QOS)
        yield executor, joints, pose


def text_of(driver, css: str) -> str:
    return find(driver, css).text


def drawn_meshes(driver) -> int:
    """Meshes on the page's three.js scene (an STL is added once its file has loaded)."""
    return driver.execute_script(
        "const el = document.querySelector('.studio-arm-view');"
        "const scene = el && window['scene_' + el.id]; if (!scene) return 0;"
        "let n = 0; scene.traverse(o => { if (o.isMesh && o.geometry && o.geometry.type === 'BufferGeometry'"
        " && o.parent && o.parent.name && o.parent.name.includes('/meshes/')) n++; }); return n;"
    )


def test_the_arm_page_starts_an_irb120_world_and_draws_its_seven_meshes(browser, studio_url, listener):
    executor, joints, _pose = listener
    browser.get(studio_url + "/arm")
    wait(browser, lambda d: d.execute_script("return document.readyState") == "complete")
    click(browser, ".studio-new-arm-world .q-item")
    wait(browser, lambda d: find(d, ".studio-arm-config input").get_attribute("value") == "arm/irb120.yaml")
    assert find(browser, ".studio-arm-ns input").get_attribute("value") == "/arm1"
    click(browser, ".studio-arm-start")
    assert spin_until(executor, lambda: joints.last is not None, timeout=60.0), text_of(browser, "body")
    wait(browser, lambda d: "7 of 7 elements drawn" in text_of(d, ".studio-arm-meshes"), timeout=30.0)
    wait(browser, lambda d: drawn_meshes(d) == 7)
    assert "IRB120_link2.stl" in text_of(browser, ".studio-arm-elements")


def test_moving_joint_2_with_its_slider_moves_the_arm(browser, listener):
    executor, joints, _pose = listener
    slider = find(browser, ".studio-joint-2 .q-slider")
    width = slider.size["width"]
    ActionChains(browser).move_to_element_with_offset(slider, round(width * 0.25), 0).click().perform()
    # The slider's number field shows what was sent (degrees); joint_2's limits are ±110°.
    wanted = wait(
        browser,
        lambda d: (v := float(find(d, ".studio-joint-2 .studio-joint-number input").get_attribute("value"))) > 20 and v,
    )
    assert 40.0 < wanted < 70.0

    def joint_2_there() -> bool:
        return abs(joints.last.position[1] - math.radians(wanted)) < 1e-3 and joints.last.velocity[1] == 0.0

    assert spin_until(executor, joint_2_there, timeout=20.0), (joints.last.position, wanted)
    assert max(abs(q) for k, q in enumerate(joints.last.position) if k != 1) < 1e-9  # only joint 2 moved
    wait(browser, lambda d: f"{wanted:.1f} °" in text_of(d, ".studio-joint-2 .studio-joint-readout"))


def test_a_reachable_target_pose_moves_the_flange_there_and_the_sliders_follow(browser, listener):
    executor, joints, pose = listener
    click(browser, ".studio-target-current")
    wait(browser, lambda d: float(find(d, ".studio-target-x input").get_attribute("value")) != 0.0)
    x = float(find(browser, ".studio-target-x input").get_attribute("value"))
    z = float(find(browser, ".studio-target-z input").get_attribute("value"))
    type_into(browser, ".studio-target-z", f"{z - 0.1:.3f}")
    click(browser, ".studio-target-go")
    wait(browser, lambda d: "reached" in text_of(d, ".studio-target-status"), timeout=30.0)

    def there() -> bool:
        p = pose.last.pose.position
        return abs(p.x - x) < 2e-3 and abs(p.z - (z - 0.1)) < 2e-3

    assert spin_until(executor, there, timeout=10.0), pose.last.pose.position

    def slider_follows_the_arm(d) -> bool:  # once the arm is still, the sliders show where it is
        number = float(find(d, ".studio-joint-2 .studio-joint-number input").get_attribute("value"))
        return abs(number - math.degrees(joints.last.position[1])) < 0.1

    spin_until(executor, lambda: False, timeout=0.2)
    wait(browser, slider_follows_the_arm)
    screenshot(browser, "arm")


def test_an_unreachable_target_pose_says_so_and_leaves_the_arm_still(browser, listener):
    executor, joints, _pose = listener
    spin_until(executor, lambda: False, timeout=0.3)  # what was in flight has arrived
    before = list(joints.last.position)
    type_into(browser, ".studio-target-x", "3.0")
    click(browser, ".studio-target-go")
    wait(browser, lambda d: "unreachable" in text_of(d, ".studio-target-status"), timeout=30.0)
    spin_until(executor, lambda: False, timeout=0.3)
    assert list(joints.last.position) == pytest.approx(before, abs=1e-9)


def test_a_stored_trajectory_file_plays_on_the_arm(browser, workspace, listener):
    executor, joints, _pose = listener
    (workspace / "wave.yaml").write_text(TRAJECTORY)
    type_into(browser, ".studio-trajectory-file", "wave.yaml")
    click(browser, ".studio-trajectory-play")
    wait(browser, lambda d: "playing wave.yaml: 2 points" in text_of(d, ".studio-trajectory-status"))
    target = [math.radians(30.0), 0.0, 0.0]
    assert spin_until(
        executor, lambda: joints.last.position[:3].tolist() == pytest.approx(target, abs=1e-6), timeout=20.0
    ), joints.last.position
    type_into(browser, ".studio-trajectory-file", "missing.yaml")
    click(browser, ".studio-trajectory-play")
    wait(browser, lambda d: "error" in text_of(d, ".studio-trajectory-status"))
    assert "missing.yaml" in text_of(browser, ".studio-trajectory-status")


def test_an_element_can_be_hidden_and_made_transparent(browser):
    row = wait(
        browser,
        lambda d: next(
            (r for r in d.find_elements(By.CSS_SELECTOR, ".studio-arm-element") if "IRB120_base.stl" in r.text), None
        ),
    )
    row.find_element(By.CSS_SELECTOR, ".q-checkbox").click()
    base = (
        "const el = document.querySelector('.studio-arm-view'); const scene = window['scene_' + el.id];"
        "let found = null; scene.traverse(o => { if (o.name && o.name.endsWith('/meshes/0')) found = o; });"
    )
    wait(browser, lambda d: d.execute_script(base + "return found && found.visible === false;"))
    row.find_element(By.CSS_SELECTOR, ".q-checkbox").click()
    slider = row.find_element(By.CSS_SELECTOR, ".q-slider")
    ActionChains(browser).move_to_element_with_offset(slider, 0, 0).click().perform()  # half way
    opacity = base + "let m = null; found.traverse(o => { if (o.material) m = o.material; }); return m && m.opacity;"
    wait(browser, lambda d: d.execute_script(base + "return found.visible;") and 0.3 < d.execute_script(opacity) < 0.7)


def test_an_arm_world_that_ends_with_an_error_says_so_on_the_arm_page_only(browser, studio_url, workspace):
    (workspace / "broken_arm.yaml").write_text("joints: 7\n")  # a YAML file, not a robot config
    browser.get(studio_url + "/arm")
    click(browser, ".studio-new-arm-world .q-item")
    type_into(browser, ".studio-arm-config", "broken_arm.yaml")
    type_into(browser, ".studio-arm-ns", "/armbroken")
    click(browser, ".studio-arm-start")
    error = wait(browser, lambda d: "error" in (t := text_of(d, ".studio-arm-world-error")) and t, timeout=60.0)
    assert error.startswith("/armbroken: error: ") and "broken_arm.yaml" in error
    browser.get(studio_url + "/")  # the Create Simulator page: its worlds only
    wait(browser, lambda d: "Robot (namespace)" in text_of(d, "body"))
    time.sleep(1.5)  # three of the page's refreshes, each of which would show an ended world
    assert "armbroken" not in text_of(browser, "body")


def test_a_namespace_that_is_not_a_ros_name_is_refused_in_a_sentence(browser, studio_url):
    browser.get(studio_url + "/arm")
    click(browser, ".studio-new-arm-world .q-item")
    type_into(browser, ".studio-arm-ns", "bad name!")
    click(browser, ".studio-arm-start")
    error = wait(browser, lambda d: "error" in (t := text_of(d, ".studio-arm-world-error")) and t, timeout=30.0)
    assert error == (
        "error: namespace '/bad name!' is not a ROS name (it holds ' ', '!'): type letters, digits and _ "
        "between slashes, each part starting with a letter or _ (for example /create2)"
    )
