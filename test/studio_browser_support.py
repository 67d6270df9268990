"""What the studio's browser tests share: Debian's Chromium through Selenium, a studio subprocess on
a ROS domain of its own, a listener node in that domain, and waits that show the page and the
studio's output (its worlds' lines included) when they fail.

A test module starts with::

    from studio_browser_support import NO_CHROMIUM
    if NO_CHROMIUM:
        pytest.skip(NO_CHROMIUM, allow_module_level=True)

and then imports the rest (Selenium is only imported once Chromium is known to be there).
"""

from __future__ import annotations

import inspect
import os
import shutil
import socket
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
CHROMIUM = Path("/usr/lib/chromium/chromium")
CHROMEDRIVER = shutil.which("chromedriver") or "/usr/bin/chromedriver"
NO_CHROMIUM = (
    ""
    if CHROMIUM.exists() and Path(CHROMEDRIVER).exists()
    else "browser tests skipped: no Chromium; enable them with `apt-get install -y chromium chromium-driver`"
)

_logs: list[Path] = []  # the running studio's output file, for the failure messages


def studio_domain(offset: int) -> int:
    """A ROS domain for one module's studio, its worlds and its listener: worlds or graph entries
    that other tests leave behind in the suite's domain must not show up in the studio. Above
    the suite's own domains (1-100, test/conftest.py), so no parallel worker's suite uses it.
    From the run's base domain, not the worker's: each module has its own offset and runs in one
    worker (`--dist loadgroup`), so two workers' studios never meet."""
    base = os.environ.get("ROBOT_SIMS_TEST_DOMAIN") or os.environ.get("ROS_DOMAIN_ID", "0")
    return 101 + (int(base) + offset) % 101


def studio_env(domain: int) -> dict[str, str]:
    """The environment of a studio and the worlds started beside it: its domain, and no
    PYTEST_CURRENT_TEST (NiceGUI would run in its test mode)."""
    env = {k: v for k, v in os.environ.items() if k != "PYTEST_CURRENT_TEST"}
    return {**env, "ROS_DOMAIN_ID": str(domain)}


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


@contextmanager
def running_studio(workspace: Path, domain: int) -> Iterator[str]:
    """``robot_sims studio`` on ``workspace`` in ``domain``; yields its URL. On exit the studio
    stops (and with it the worlds it started); its output's tail is printed for a failing test."""
    log = Path(tempfile.mkdtemp(prefix="studio_log_")) / "studio.log"
    port = free_port()
    with log.open("w") as out:  # a file: a pipe nobody reads would block the studio once full
        process = subprocess.Popen(
            [sys.executable, "-m", "studio", "--workspace", str(workspace), "--port", str(port)],
            stdout=out,
            stderr=subprocess.STDOUT,
            text=True,
            cwd=ROOT,
            env=studio_env(domain),
        )
    _logs.append(log)
    try:
        deadline = time.monotonic() + 60.0
        while True:  # until the server accepts connections
            try:
                socket.create_connection(("127.0.0.1", port), timeout=1.0).close()
                break
            except OSError:
                assert process.poll() is None and time.monotonic() < deadline, log.read_text()
                time.sleep(0.05)
        assert f"http://127.0.0.1:{port}/" in log.read_text().splitlines()[0]  # printed before serving
        yield f"http://127.0.0.1:{port}"
    finally:
        process.terminate()
        process.wait(timeout=20)
        print(log.read_text()[-5000:])  # shown with a failing test's report
        _logs.remove(log)
        shutil.rmtree(log.parent, ignore_errors=True)


@contextmanager
def new_browser(window_size: str = "1400,1600"):
    """A headless Debian Chromium driven by Selenium (never a downloaded driver)."""
    from selenium import webdriver
    from selenium.webdriver.chrome.service import Service

    options = webdriver.ChromeOptions()
    options.binary_location = str(CHROMIUM)
    for arg in ("--headless=new", "--no-sandbox", "--disable-dev-shm-usage", f"--window-size={window_size}"):
        options.add_argument(arg)
    os.environ["SE_CHROMEDRIVER"] = CHROMEDRIVER
    driver = webdriver.Chrome(options=options, service=Service(CHROMEDRIVER))
    driver.implicitly_wait(0)
    try:
        yield driver
    finally:
        driver.quit()


@contextmanager
def listener_node(domain: int, name: str):
    """A test's own ROS node and executor in ``domain``: what the worlds publish, read as any
    client would. Yields ``(executor, node)``."""
    import rclpy
    from rclpy.context import Context
    from rclpy.node import Node

    from sim_runtime.run import make_executor

    context = Context()
    rclpy.init(context=context, domain_id=domain)
    executor = make_executor(context)
    node = Node(name, context=context)
    executor.add_node(node)
    try:
        yield executor, node
    finally:
        executor.remove_node(node)
        node.destroy_node()
        executor.shutdown()
        rclpy.shutdown(context=context)


def what_happened(driver) -> str:
    """The page's text and the studio's latest output, for a failure message."""
    from selenium.common.exceptions import WebDriverException
    from selenium.webdriver.common.by import By

    try:
        page = driver.find_element(By.TAG_NAME, "body").text
    except WebDriverException as err:
        page = f"(unreadable: {err.msg})"
    log = _logs[-1].read_text().splitlines()[-60:] if _logs and _logs[-1].exists() else ["(no studio running)"]
    return "the page says:\n" + page[-2000:] + "\nthe studio's output ends:\n" + "\n".join(log)


def wait(driver, condition: Callable, timeout: float = 15.0):
    """``condition(driver)`` once truthy; on timeout a failure showing the page and the studio's output."""
    from selenium.common.exceptions import TimeoutException
    from selenium.webdriver.support.ui import WebDriverWait

    try:
        return WebDriverWait(driver, timeout, poll_frequency=0.05).until(lambda d: condition(d))
    except TimeoutException:
        pytest.fail(f"not true within {timeout:g} s: {inspect.getsource(condition).strip()}\n{what_happened(driver)}")


def find(driver, css: str):
    from selenium.webdriver.common.by import By

    return wait(driver, lambda d: d.find_element(By.CSS_SELECTOR, css))


def click(driver, css: str) -> None:
    """Click an element once it takes clicks (the page may still be laying itself out)."""
    from selenium.common.exceptions import ElementNotInteractableException

    def clicked(d) -> bool:
        try:
            find(d, css).click()
        except ElementNotInteractableException:
            return False
        return True

    wait(driver, clicked)


def click_text(driver, text: str, within: str = "body") -> None:
    """Click the button labelled ``text`` (inside ``within``)."""
    from selenium.webdriver.common.by import By

    xpath = f"//*[contains(@class,'q-btn') and .//*[normalize-space(text())='{text}']]"
    scope = find(driver, within)
    wait(driver, lambda d: scope.find_element(By.XPATH, "." + xpath)).click()


def open_page(driver, url: str) -> None:
    driver.get(url)
    wait(driver, lambda d: d.execute_script("return document.readyState") == "complete")
    find(driver, ".nicegui-content")


def type_into(driver, css: str, text: str) -> None:
    """Replace a text field's contents, once it takes input (an expansion may still be opening)."""
    from selenium.common.exceptions import ElementNotInteractableException
    from selenium.webdriver.common.keys import Keys

    def typed(d) -> bool:
        field = find(d, f"{css} input")
        try:
            field.send_keys(Keys.CONTROL, "a")
            field.send_keys(Keys.BACKSPACE)
            field.send_keys(text)
        except ElementNotInteractableException:
            return False
        return True

    wait(driver, typed)


def screenshot(driver, name: str) -> None:
    """With ``STUDIO_SCREENSHOTS=1``, save the page as ``docs/studio_<name>.png``."""
    if os.environ.get("STUDIO_SCREENSHOTS"):
        driver.save_screenshot(str(ROOT / "docs" / f"studio_{name}.png"))
